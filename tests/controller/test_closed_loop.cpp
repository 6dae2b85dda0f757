// Single leg in closed loop with the plant's SingleLegPlant, in-process, under the
// `realistic` conditions (sensor noise 0.05 mm + 12-bit quantisation on the length, 2 kPa on
// the pressures; plant friction x1.2, polytropic coefficients x1.1, load +20 % against the
// controller's nominal model). Sensors and control at 1 ms, setpoints every 5 ms.
// Gains were chosen on seed 7 (docs/controller.md); these tests run seed 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "leg_tracking_harness.hpp"

namespace hexa {
namespace {

using test::RunTracking;
using test::SingleLegControllerConfig;
using test::TrackingResult;
using test::TrackingScenario;

TrackingResult RunLeg(LegControllerKind kind, const TrackingScenario& sc) {
  const RigParams rig = MakeReferenceRig();
  return RunTracking(sc, SingleLegControllerConfig(rig, kind, LegControllerParams{}, sc), rig);
}

void Print(const char* name, const TrackingResult& r) {
  std::printf("%s: rmse %.4f mm (measured %.4f mm), max %.3f mm, valve [%.2f, %.2f] V\n", name,
              r.rmse_m * 1e3, r.rmse_measured_m * 1e3, r.max_abs_error_m * 1e3, r.valve_min_v, r.valve_max_v);
}

TEST(LegClosedLoop, BsSmcTracksTheSlowSineBelowOneMillimetreRealistic) {
  TrackingScenario sc;  // 0.1 Hz, +-50 mm, realistic, seed 1
  const TrackingResult r = RunLeg(LegControllerKind::kBsSmc, sc);
  Print("BS-SMC 0.1 Hz realistic", r);
  EXPECT_TRUE(r.finite);
  EXPECT_EQ(r.non_ok_ticks, 0);
  EXPECT_GT(r.samples, 19000);
  EXPECT_LT(r.rmse_m, 1.0e-3);
  EXPECT_GE(r.valve_min_v, 0.0);
  EXPECT_LE(r.valve_max_v, 10.0);
}

TEST(LegClosedLoop, BsSmcBeatsPiOnTheSameSlowRun) {
  // Same scenario and seed for both. Before the integral of S (docs/controller.md) the
  // grid-tuned PI was as good as the BS-SMC on the 0.1 Hz RMSE (0.555 vs 0.585 mm); with it
  // the BS-SMC is ahead on RMSE as well as on peak error (measured 0.425 vs 0.555 mm RMSE,
  // 0.96 vs 2.19 mm peak, `leg_tracking_report`).
  TrackingScenario sc;
  const TrackingResult bssmc = RunLeg(LegControllerKind::kBsSmc, sc);
  const TrackingResult pi = RunLeg(LegControllerKind::kPi, sc);
  Print("BS-SMC 0.1 Hz realistic", bssmc);
  Print("PI     0.1 Hz realistic", pi);
  EXPECT_TRUE(pi.finite);
  EXPECT_LT(bssmc.rmse_m, pi.rmse_m);
  EXPECT_LT(bssmc.max_abs_error_m, pi.max_abs_error_m);
}

TEST(LegClosedLoop, BsSmcBeatsPiAtTheCombinedTrajectorysLegSpeed) {
  // 1 Hz, +-100 mm: the leg motion of the paper's combined trajectory (eq 49).
  TrackingScenario sc;
  sc.frequency_hz = 1.0;
  sc.amplitude_m = 0.1;
  sc.duration_s = 13.0;
  const TrackingResult bssmc = RunLeg(LegControllerKind::kBsSmc, sc);
  const TrackingResult pi = RunLeg(LegControllerKind::kPi, sc);
  Print("BS-SMC 1 Hz realistic", bssmc);
  Print("PI     1 Hz realistic", pi);
  EXPECT_TRUE(bssmc.finite);
  EXPECT_TRUE(pi.finite);
  EXPECT_LT(bssmc.rmse_m, pi.rmse_m);
  EXPECT_LT(bssmc.rmse_m, 5.0e-3);
}

// Friction scale adaptation at speed (docs/controller.md "Friction adaptation at speed"): the
// plant's friction is scale x Table 8, the controller's model is Table 8. Over a run at the
// combined trajectory's leg speed, theta (averaged over the last 5 s) must land on the plant's
// scale; the other realistic mismatches (polytropic x1.1, load +20 %, noise) stay on, so theta
// may absorb a little of them: +-0.1. Returns {mean theta over the last 5 s, RMSE}.
struct AdaptationRun {
  double theta_end = 0.0;
  double theta_min = 1e9, theta_max = -1e9;  // over the whole run
  TrackingResult result;
};

AdaptationRun RunAdaptation(double plant_friction_scale, double frequency_hz, double amplitude_m,
                            double rate_1_n_m) {
  TrackingScenario sc;
  sc.frequency_hz = frequency_hz;
  sc.amplitude_m = amplitude_m;
  sc.duration_s = 23.0;
  sc.friction_scale = plant_friction_scale;
  const RigParams rig = MakeReferenceRig();
  LegControllerConfig config = SingleLegControllerConfig(rig, LegControllerKind::kBsSmc, LegControllerParams{}, sc);
  config.params.bssmc.friction_adaptation_rate_1_n_m = rate_1_n_m;
  AdaptationRun run;
  double sum = 0.0;
  int n = 0;
  run.result = RunTracking(sc, config, rig,
                           [&](double t, double, double, const LegControllerOutput& out, const SingleLegPlant&) {
                             run.theta_min = std::min(run.theta_min, out.friction_scale);
                             run.theta_max = std::max(run.theta_max, out.friction_scale);
                             if (t >= sc.duration_s - 5.0) {
                               sum += out.friction_scale;
                               ++n;
                             }
                           });
  run.theta_end = n > 0 ? sum / n : 0.0;
  return run;
}

TEST(LegClosedLoop, FrictionAdaptationLearnsThePlantsFrictionScaleAtSpeed) {
  const double rate = LegControllerParams{}.bssmc.friction_adaptation_rate_1_n_m;
  ASSERT_GT(rate, 0.0) << "the adaptation is expected on by default";
  for (const double scale : {0.8, 1.0, 1.2, 1.4}) {
    const AdaptationRun run = RunAdaptation(scale, 1.0, 0.1, rate);
    std::printf("plant friction x%.1f: theta %.3f (run range %.3f-%.3f), rmse %.3f mm\n", scale,
                run.theta_end, run.theta_min, run.theta_max, run.result.rmse_m * 1e3);
    EXPECT_TRUE(run.result.finite);
    EXPECT_EQ(run.result.non_ok_ticks, 0);
    EXPECT_NEAR(run.theta_end, scale, 0.1) << "plant friction x" << scale;
  }
}

TEST(LegClosedLoop, FrictionAdaptationLowersTheErrorOfAMismatchedFriction) {
  const double rate = LegControllerParams{}.bssmc.friction_adaptation_rate_1_n_m;
  const AdaptationRun on = RunAdaptation(1.4, 1.0, 0.1, rate);
  const AdaptationRun off = RunAdaptation(1.4, 1.0, 0.1, 0.0);
  std::printf("plant friction x1.4, 1 Hz: rmse %.3f mm adapted, %.3f mm not\n", on.result.rmse_m * 1e3,
              off.result.rmse_m * 1e3);
  EXPECT_LT(on.result.rmse_m, off.result.rmse_m);
  // Off: theta is exactly the nominal 1 throughout (the law of eq 14 unchanged).
  EXPECT_EQ(off.theta_min, 1.0);
  EXPECT_EQ(off.theta_max, 1.0);
}

TEST(LegClosedLoop, FrictionAdaptationLeavesSlowMotionsAtTheNominalEstimate) {
  // 0.1 Hz, +-50 mm: |v_d| <= 0.031 m/s, well below v_a = 0.12 m/s, where w <= 0.07: theta
  // barely moves and what it applies is (theta - 1) w, so the slow motions keep eq 14's
  // nominal estimate and the dither (the stick-slip they are sensitive to, docs/measurements/results.md).
  const AdaptationRun run = RunAdaptation(1.2, 0.1, 0.05, LegControllerParams{}.bssmc.friction_adaptation_rate_1_n_m);
  std::printf("0.1 Hz, plant friction x1.2: theta range %.4f-%.4f\n", run.theta_min, run.theta_max);
  EXPECT_GT(run.theta_min, 0.95);
  EXPECT_LT(run.theta_max, 1.05);
}

}  // namespace
}  // namespace hexa
