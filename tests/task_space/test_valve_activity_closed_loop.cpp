// Valve activity on the combined trajectory (limit: "no worse than 0.21 V per
// tick mean step, 3 % saturated"), BS-SMC with the feed-forward, realistic profile, seeds
// 1-3, in the lockstep simulation. Same definition as platform_study (docs/measurements/tuning.md "Valve
// chatter"): over the TRACKING window, all six legs, mean |u(k) - u(k-1)| per 1 ms tick and
// the fraction of ticks with u < 0.05 V or u > 9.95 V.
// Before the outer loop's speed gate (docs/measurements/control.md "Outer loop speed gate") the
// corrections swung between their +-5 mm bounds at 1 Hz and 4.2-4.9 % of the ticks were
// saturated (seeds 1-3); this test failed then.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "hexa/core/lockstep_simulation.hpp"
#include "tracking_session.hpp"

namespace hexa {
namespace {

struct Activity {
  double mean_step_v = 0.0;
  double saturated_fraction = 0.0;
  bool completed = false;
};

Activity RunCombined(std::uint64_t seed) {
  LockstepConfig config;  // struct defaults = deploy/rigs/hexataar_r.textproto
  config.seed = seed;
  config.disturbance = MakeRealisticDisturbanceProfile();
  config.controller = LegControllerKind::kBsSmc;
  bool primed = false;
  LegArray<double> prev{};
  double sum_step = 0.0;
  long saturated = 0, samples = 0;
  const bool completed = RunTrackingWindow(config, PaperMotion::kCombined, [&](const LockstepSimulation& sim) {
    const LegArray<double>& u = sim.applied_valve_v();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      if (primed) {
        sum_step += std::abs(u[i] - prev[i]);
        saturated += (u[i] < 0.05 || u[i] > 9.95) ? 1 : 0;
        ++samples;
      }
      prev[i] = u[i];
    }
    primed = true;
  });
  Activity a;
  a.completed = completed && samples > 0;
  if (samples > 0) {
    a.mean_step_v = sum_step / static_cast<double>(samples);
    a.saturated_fraction = static_cast<double>(saturated) / static_cast<double>(samples);
  }
  return a;
}

TEST(ValveActivityClosedLoop, CombinedWithFeedforwardWithinTheValveActivityLimits) {
  std::array<double, 3> steps{};
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const Activity a = RunCombined(seed);
    ASSERT_TRUE(a.completed) << "seed " << seed;
    std::printf("seed %llu: mean step %.4f V/tick, saturated %.2f %%\n",
                static_cast<unsigned long long>(seed), a.mean_step_v, 100.0 * a.saturated_fraction);
    EXPECT_LT(a.saturated_fraction, 0.03) << "seed " << seed;
    steps[seed - 1] = a.mean_step_v;
  }
  std::sort(steps.begin(), steps.end());
  EXPECT_LE(steps[1], 0.21);  // median of the three seeds
}

}  // namespace
}  // namespace hexa
