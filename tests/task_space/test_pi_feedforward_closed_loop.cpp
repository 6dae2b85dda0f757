// The PI baseline with the platform feed-forward must not be a weakened baseline:
// on the six pure motions (realistic, seed 1, in the lockstep simulation) its score, the mean
// over the trajectories of (moving-axis RMSE against ground truth / the paper's Table 9
// figure), is at most 15 % above the same PI without the feed-forward (its term
// Kf (F_ff - F), docs/controller.md). With the first, untuned Kf = 0.01 V/N the score was
// 2.25 x (x 0.508 vs 0.330 cm, yaw 0.867 vs 0.269 deg): this test failed then; Kf 0.001 V/N
// (grid on all seven trajectories, seeds 1-3, docs/controller.md) gives 1.01 x.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>

#include "hexa/core/lockstep_simulation.hpp"

namespace hexa {
namespace {

constexpr std::array<PaperMotion, 6> kPure = {PaperMotion::kX,    PaperMotion::kY,     PaperMotion::kZ,
                                              PaperMotion::kRoll, PaperMotion::kPitch, PaperMotion::kYaw};
constexpr std::array<double, 6> kTable9 = {0.00782, 0.00841, 0.00197, 1.012 / 57.29577951308232,
                                           1.346 / 57.29577951308232, 1.836 / 57.29577951308232};

double PureMotionScore(bool feedforward) {
  LockstepConfig config;  // struct defaults = deploy/rigs/hexataar_r.textproto
  config.seed = 1;
  config.disturbance = MakeRealisticDisturbanceProfile();
  config.controller = LegControllerKind::kPi;
  config.supervisor.feedforward_enabled = feedforward;
  double score = 0.0;
  for (std::size_t k = 0; k < kPure.size(); ++k) {
    const PaperSessionResult r = RunPaperSession(config, kPure[k]);
    EXPECT_TRUE(r.completed) << ToString(kPure[k]);
    const double ratio = r.metrics.vs_truth.Rmse()[k] / kTable9[k];
    std::printf("%s %s: moving axis / paper %.3f\n", feedforward ? "ff " : "off", ToString(kPure[k]), ratio);
    score += ratio / static_cast<double>(kPure.size());
  }
  return score;
}

TEST(PiFeedforwardClosedLoop, FeedforwardDoesNotWeakenThePiOnThePureMotions) {
  const double with_ff = PureMotionScore(true);
  const double without = PureMotionScore(false);
  std::printf("score with feed-forward %.4f, without %.4f\n", with_ff, without);
  EXPECT_LE(with_ff, 1.15 * without);
}

}  // namespace
}  // namespace hexa
