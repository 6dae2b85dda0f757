#include "calibrate_in_process.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "calibration_fit.hpp"

namespace hexa::calib {

bool CalibrateInProcess(const LockstepConfig& base, KinematicCalibration& out, std::FILE* report,
                        PayloadEstimate& payload) {
  LockstepConfig config = base;
  config.tracker.enabled = true;
  config.controllers.reset();  // nominal model: what is being calibrated
  // The outer loop integrates estimation noise at rest (docs/task_space.md, idle wander:
  // ~1 mm); the calibration wants the legs still where they are commanded.
  config.supervisor.outer_loop.enabled = false;
  LockstepSimulation sim(config);
  sim.Tick();
  const Supervisor& sup = sim.supervisor();
  const StartRequest start = sup.PrepareStart(MakeCalibrationTrajectory(
      config.rig, sup.rest_xyz_rpy(), sup.home_xyz_rpy(), sup.timing(),
      CalibrationProcedureParams{}));
  if (!start.feasibility.feasible) {
    std::fprintf(stderr, "calibration trajectory rejected: %s\n", start.feasibility.message.c_str());
    return false;
  }
  CalibrationSampleCollector collector(StillWindowParams{});
  PayloadRecord payload_record;
  bool started = false, left_idle = false;
  while (sim.time_s() < 1000.0) {
    const bool due = sim.supervisor_due();
    const auto cmd = due && !started ? OperatorCommandKind::kStart : OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == OperatorCommandKind::kStart ? &start : nullptr) !=
        PlantStatus::kOk) {
      return false;
    }
    const std::uint64_t tick = sim.tick() - 1;
    const auto& p = sim.plant_before_step();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      collector.AddReading(tick, i, p.legs[i].length_m);
      payload_record.Add(tick, i, p.legs[i].length_m, p.legs[i].chamber1_pressure_pa,
                         p.legs[i].chamber2_pressure_pa);
    }
    if (p.tracker.fresh) collector.AddTracker(tick, p.tracker.p_BP_B_m, p.tracker.q_BP);
    if (!due) continue;
    started = true;
    const auto& out = sim.supervisor_output();
    collector.AddDesired(tick, out.desired_xyz_rpy, out.state != SupervisorState::kHold);
    if (out.state == SupervisorState::kHold) {
      std::fprintf(stderr, "calibration run went to HOLD: %s\n", out.fault_detail.data());
      return false;
    }
    if (out.state != SupervisorState::kIdle) left_idle = true;
    if (left_idle && out.state == SupervisorState::kIdle) break;
  }
  const auto samples = collector.Samples();
  const double mid = config.rig.cylinder.mid_stroke_length_m;
  const auto fit = FitKinematicCalibration(
      samples, mid, NominalCalibration(config.rig.geometry), FitOptions{});
  std::fprintf(report, "calibration: %.1f s simulated, %zu samples (tracker measurements in still windows), %s\n", sim.time_s(), samples.size(),
              fit.message.c_str());
  if (!fit.ok) return false;
  const PlatformPlant& plant = sim.plant();
  double worst_joint = 0, worst_offset = 0, worst_gain = 0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegCalibration truth;
    truth.p_BA_B_m = plant.true_geometry().p_BA_B[i];
    truth.p_PB_P_m = plant.true_geometry().p_PB_P[i];
    truth.potentiometer_offset_m = plant.sensors().calibration().offset_m[i];
    truth.potentiometer_gain = 1.0 + plant.sensors().calibration().gain_error[i];
    const LegCalibrationVector e = fit.calibration[i].AsVector() - truth.AsVector();
    double truth_rms = 0.0;  // how well the TRUE parameters explain the data (data quality)
    for (const auto& smp : samples) {
      const double r = smp.reading_m[i] - PredictedReadingM(truth, smp.pose, mid);
      truth_rms += r * r;
    }
    truth_rms = std::sqrt(truth_rms / static_cast<double>(samples.size()));
    std::fprintf(report, "  leg %zu: data residual with the true parameters %.4f mm\n", i + 1, 1e3 * truth_rms);
    worst_joint = std::max(worst_joint, e.head<6>().cwiseAbs().maxCoeff());
    worst_offset = std::max(worst_offset, std::abs(e[6]));
    worst_gain = std::max(worst_gain, std::abs(e[7]));
    std::fprintf(report, "  leg %zu residual vs truth: joints (mm)", i + 1);
    for (int k = 0; k < 6; ++k) std::fprintf(report, " %+.4f", 1e3 * e[k]);
    std::fprintf(report, " | offset %+.4f mm | gain %+.1f ppm | fit rms %.4f mm\n", 1e3 * e[6], 1e6 * e[7],
                1e3 * fit.legs[i].final_rms_m);
  }
  std::fprintf(report, "  worst residual: joint %.4f mm, offset %.4f mm, gain %.1f ppm\n", 1e3 * worst_joint,
              1e3 * worst_offset, 1e6 * worst_gain);
  out = fit.calibration;
  payload = EstimatePayload(config.rig, fit.calibration, payload_record, PayloadEstimatorConfig{});
  if (payload.ok) {
    std::fprintf(report, "payload scale: estimate %.4f +- %.4f (%s), truth %.4f\n", payload.scale,
                 payload.scale_std, payload.precise ? "applied" : "not applied: not precise enough",
                 config.disturbance.payload_scale);
  } else {
    std::fprintf(report, "payload: not estimated (%s)\n", payload.message.c_str());
  }
  return true;
}


void ApplyKinematicCalibration(const KinematicCalibration& calibration, const PayloadEstimate& payload,
                               LockstepConfig& config) {
  ControllerModel model = *config.controllers;
  if (payload.precise) {
    model.platform.mass_kg = payload.mass_kg;
    model.platform.inertia_diag_kg_m2 = payload.inertia_diag_kg_m2;
  }
  model.geometry = CalibratedGeometry(model.geometry, calibration);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    model.legs[i].potentiometer.offset_m = calibration[i].potentiometer_offset_m;
    model.legs[i].potentiometer.gain = calibration[i].potentiometer_gain;
  }
  config.controllers = model;
}

}  // namespace hexa::calib
