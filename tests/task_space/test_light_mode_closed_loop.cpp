// The legs' velocity loop on the platform's light modes (docs/measurements/control_light_modes.md "Per-leg
// lag and leg 2's overshoot on combined"). Leg-space mass matrix at home J^-T M_p J^-1 + m_leg:
// two 0.88 kg modes (roll / pitch). The BS-SMC's velocity gain (200 N s/m) through the
// backstepping loop and ~7 ms of lag has a 20.7 Hz crossover with -20 deg phase margin on them:
// a 20 Hz limit cycle on the 1 Hz combined motion. The velocity estimate's delay is part of
// that lag; the default centre lag went from 2 samples (2.32 ms) to 1 (1.54 ms).
//
// Ideal profile (plant = the controllers' model, no noise: deterministic and seed-free),
// combined trajectory, rig-file defaults: the default must track better than the old delay,
// scored as the sum over the six axes of RMSE / (one fifth of the paper's Table 10). Measured
// when written: 15.55 with the default, 17.07 with 2 samples (ratio 0.911). With the old
// default both runs are the same configuration and the test fails. With the feedback rate in
// phi_dot on (defaults): 7.79 vs 8.72 (ratio 0.893). The friction adaptation at
// speed (docs/controller.md, added after) is off in these runs: it moves the ideal plant's
// friction estimate by a few per cent (theta 0.96-1.05) and with it the score (8.72 vs 9.06,
// ratio 0.962, measured 2026-11-27); the test is about the velocity estimate's delay alone.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <vector>

#include "hexa/core/lockstep_simulation.hpp"
#include "tracking_session.hpp"

namespace hexa {
namespace {

constexpr double kTable10Fifth[6] = {0.00169, 0.00241, 0.00059, 1.193 / 5.0 * 3.14159265358979323846 / 180.0,
                                     1.817 / 5.0 * 3.14159265358979323846 / 180.0,
                                     2.433 / 5.0 * 3.14159265358979323846 / 180.0};

// Thresholds of the velocity error's part above ~10 Hz (test at the end). Measured when
// written (seed 1): ideal 0.114 m/s with the feedback rate (a 0.4), 0.194 without;
// realistic 0.071 with, 0.185 without. On the ideal plant (nominal 0.88 kg modes, predicted
// margin +5.6 deg) a smaller 20 Hz oscillation remains, hence the higher threshold there.
constexpr double kLimitCycleThresholdIdeal_m_s = 0.15;
constexpr double kLimitCycleThresholdRealistic_m_s = 0.12;

double CombinedScore(double centre_lag_samples) {
  LockstepConfig config;  // struct defaults = deploy/rigs/hexataar_r.textproto
  config.disturbance = MakeIdealDisturbanceProfile();
  config.controller = LegControllerKind::kBsSmc;
  config.leg_controller.differentiator.centre_lag_samples = centre_lag_samples;
  config.leg_controller.bssmc.friction_adaptation_rate_1_n_m = 0.0;  // see the header
  const PaperSessionResult r = RunPaperSession(config, PaperMotion::kCombined, 0, 60.0);
  EXPECT_TRUE(r.completed) << "centre lag " << centre_lag_samples;
  const auto e = r.metrics.vs_truth.Rmse();
  double score = 0.0;
  for (std::size_t k = 0; k < 6; ++k) score += e[k] / kTable10Fifth[k];
  std::printf("centre lag %.0f: RMSE x %.3f y %.3f z %.3f cm, roll %.3f pitch %.3f yaw %.3f deg, score %.2f\n",
              centre_lag_samples, 100 * e[0], 100 * e[1], 100 * e[2], e[3] * 180 / 3.14159265358979323846,
              e[4] * 180 / 3.14159265358979323846, e[5] * 180 / 3.14159265358979323846, score);
  return score;
}

TEST(LightModeClosedLoop, DefaultVelocityEstimateDelayTracksCombinedBetterOnTheIdealPlant) {
  const double default_lag = LegControllerParams{}.differentiator.centre_lag_samples;
  const double with_default = CombinedScore(default_lag);
  const double with_old = CombinedScore(2.0);
  EXPECT_LT(with_default, 0.95 * with_old);
}

// The feedback rate in phi_dot (docs/measurements/control_light_modes.md "Feedback rate in phi_dot"): the rate of phi's feedback part
// in phi_dot, from the leg observer, gives the velocity loop its phase back on the light modes.
// Measured: the legs' velocity error v_hat - v_d over the tracking window of combined, all six
// legs, its part above ~10 Hz (minus a centred 100-sample moving average, whose first null is at
// 10 Hz), RMS.
struct Oscillation {
  double rms_m_s = 0.0;
  double above_10hz_rms_m_s = 0.0;
  bool completed = false;
};

Oscillation CombinedVelocityError(bool realistic, double feedback_rate_fraction) {
  LockstepConfig config;  // struct defaults = deploy/rigs/hexataar_r.textproto
  config.seed = 1;
  config.disturbance = realistic ? MakeRealisticDisturbanceProfile() : MakeIdealDisturbanceProfile();
  config.controller = LegControllerKind::kBsSmc;
  config.leg_controller.bssmc.feedback_rate_fraction = feedback_rate_fraction;
  Oscillation o;
  std::vector<double> e[kNumLegs];
  const bool completed = RunTrackingWindow(config, PaperMotion::kCombined, [&](const LockstepSimulation& sim) {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const auto& out = sim.leg_outputs()[i];
      e[i].push_back(out.velocity_m_s - out.desired_velocity_m_s);
    }
  });
  o.completed = completed && e[0].size() > 1000;
  if (!o.completed) return o;
  constexpr std::size_t kHalf = 50;
  double sum = 0.0, sum_hf = 0.0;
  long n = 0, n_hf = 0;
  for (const auto& v : e) {
    for (double x : v) sum += x * x;
    n += static_cast<long>(v.size());
    for (std::size_t k = kHalf; k + kHalf < v.size(); ++k) {
      double mean = 0.0;
      for (std::size_t j = k - kHalf; j < k + kHalf; ++j) mean += v[j];
      const double hf = v[k] - mean / (2.0 * kHalf);
      sum_hf += hf * hf;
      ++n_hf;
    }
  }
  o.rms_m_s = std::sqrt(sum / n);
  o.above_10hz_rms_m_s = std::sqrt(sum_hf / n_hf);
  std::printf("%s, feedback rate fraction %.2f: velocity error RMS %.4f m/s, above 10 Hz %.4f m/s\n",
              realistic ? "realistic seed 1" : "ideal", feedback_rate_fraction, o.rms_m_s,
              o.above_10hz_rms_m_s);
  return o;
}

TEST(LightModeClosedLoop, FeedbackRateInPhiDotStopsTheLightModeLimitCycleOnCombined) {
  const double fraction = LegControllerParams{}.bssmc.feedback_rate_fraction;
  for (bool realistic : {false, true}) {
    const Oscillation now = CombinedVelocityError(realistic, fraction);
    const Oscillation old = CombinedVelocityError(realistic, 0.0);
    ASSERT_TRUE(now.completed && old.completed);
    const double threshold = realistic ? kLimitCycleThresholdRealistic_m_s : kLimitCycleThresholdIdeal_m_s;
    EXPECT_LT(now.above_10hz_rms_m_s, threshold) << (realistic ? "realistic" : "ideal");
    EXPECT_GT(old.above_10hz_rms_m_s, threshold) << (realistic ? "realistic" : "ideal");
  }
}

}  // namespace
}  // namespace hexa
