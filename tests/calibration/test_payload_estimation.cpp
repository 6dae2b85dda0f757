// The payload estimate (core/payload_estimation.hpp) against the plant's known payload: the
// in-process lockstep simulation (realistic profile: friction x1.2 with a per-leg spread,
// noise, ripple) visits a short calibration pose sequence, and the estimator, given the plant's
// true kinematic calibration (so that only the estimator is under test), must find the plant's
// payload scale. Deterministic (fixed seeds).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "hexa/core/calibration.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/payload_estimation.hpp"

namespace {

using hexa::kNumLegs;

// Runs 12 designed poses (2 s moves, 1 s dwell) and estimates the payload.
hexa::PayloadEstimate RunAndEstimate(double payload_scale, std::uint64_t seed) {
  hexa::LockstepConfig config;
  config.disturbance.payload_scale = payload_scale;
  config.seed = seed;
  config.supervisor.outer_loop.enabled = false;  // as the calibration procedure
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::Supervisor& sup = sim.supervisor();
  hexa::CalibrationProcedureParams procedure;
  procedure.design.count = 12;
  procedure.dwell_s = 1.0;
  procedure.design.max_rotation_rad = 0.28;  // inside the core default soft limits (0.3 rad)
  procedure.design.max_rotation_angle_rad = 0.29;
  const hexa::StartRequest start = sup.PrepareStart(hexa::MakeCalibrationTrajectory(
      config.rig, sup.rest_xyz_rpy(), sup.home_xyz_rpy(), sup.timing(), procedure));
  EXPECT_TRUE(start.feasibility.feasible) << start.feasibility.message;
  hexa::PayloadRecord record;
  bool started = false, left_idle = false;
  while (sim.time_s() < 200.0) {
    const bool due = sim.supervisor_due();
    const auto cmd = due && !started ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr) != hexa::PlantStatus::kOk) {
      ADD_FAILURE() << "plant stopped at " << sim.time_s() << " s";
      break;
    }
    const auto& p = sim.plant_before_step();
    for (std::size_t i = 0; i < kNumLegs; ++i)
      record.Add(sim.tick() - 1, i, p.legs[i].length_m, p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa);
    if (!due) continue;
    started = true;
    const auto state = sim.supervisor_output().state;
    EXPECT_NE(state, hexa::SupervisorState::kHold);
    if (state == hexa::SupervisorState::kHold) break;
    if (state != hexa::SupervisorState::kIdle) left_idle = true;
    if (left_idle && state == hexa::SupervisorState::kIdle) break;
  }
  hexa::KinematicCalibration truth;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    truth[i].p_BA_B_m = sim.plant().true_geometry().p_BA_B[i];
    truth[i].p_PB_P_m = sim.plant().true_geometry().p_PB_P[i];
    truth[i].potentiometer_offset_m = sim.plant().sensors().calibration().offset_m[i];
    truth[i].potentiometer_gain = 1.0 + sim.plant().sensors().calibration().gain_error[i];
  }
  const auto est = hexa::EstimatePayload(config.rig, truth, record, hexa::PayloadEstimatorConfig{});
  std::printf("plant payload %.2f (seed %llu): estimate %.4f +- %.4f; legs", payload_scale,
              static_cast<unsigned long long>(seed), est.scale, est.scale_std);
  for (const auto& l : est.legs) std::printf(" %.3f (%zu, %.1f N)", l.scale, l.samples, l.residual_rms_n);
  std::printf("\n");
  return est;
}

// Bound: 0.05 on the scale (0.3 kg of the 6 kg platform) on this short run (12 poses, ~30
// sliding seconds per leg; measured 1.227 and 0.951); the full calibration session (50 poses)
// gives 1.216-1.234 against 1.2 (docs/measurements/payload.md). The rig file's value (1) and
// the realistic plant's (1.2) are 0.2 apart: the estimate must tell them apart.
TEST(PayloadEstimate, FindsTheRealisticPlantsPayloadFromTheLegForcesWhileSliding) {
  const hexa::PayloadEstimate est = RunAndEstimate(1.2, 1);
  ASSERT_TRUE(est.ok) << est.message;
  EXPECT_NEAR(est.scale, 1.2, 0.05);
  EXPECT_LT(est.scale_std, 0.03);
  EXPECT_NEAR(est.mass_kg, est.scale * 6.0, 1e-12);
  int legs = 0;
  for (const auto& leg : est.legs) legs += leg.information > 0.0 ? 1 : 0;
  EXPECT_GE(legs, 4);
}

TEST(PayloadEstimate, FindsTheRigFilesPayloadWhenThePlantCarriesNoMore) {
  const hexa::PayloadEstimate est = RunAndEstimate(1.0, 2);
  ASSERT_TRUE(est.ok) << est.message;
  EXPECT_NEAR(est.scale, 1.0, 0.05);
  EXPECT_LT(est.scale_std, 0.03);
}

TEST(PayloadEstimate, RefusesARecordWithoutMotion) {
  hexa::PayloadRecord record;
  const hexa::RigParams rig = hexa::MakeReferenceRig();
  for (std::uint64_t k = 0; k < 5000; ++k)
    for (std::size_t i = 0; i < kNumLegs; ++i) record.Add(k, i, rig.cylinder.mid_stroke_length_m, 3e5, 3e5);
  const auto est = hexa::EstimatePayload(rig, hexa::NominalCalibration(rig.geometry), record,
                                         hexa::PayloadEstimatorConfig{});
  EXPECT_FALSE(est.ok);
  EXPECT_FALSE(est.precise);
  EXPECT_NE(est.message.find("too few sliding samples"), std::string::npos) << est.message;
}

}  // namespace
