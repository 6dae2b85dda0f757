// Under the realistic profile the pose RMSE against ground truth is lower
// with the outer loop on than off, on the same seed. Definition (docs/measurements/control.md,
// "Outer loop in closed loop"): the seven paper trajectories, seed 1, realistic profile,
// default gains, run once with the outer loop on and once off (RunPaperSession, the
// in-process lockstep system). Translation and rotation are aggregated separately (their
// units differ): RMS over the seven trajectories of the per-trajectory RMSE vector norm,
//   T = sqrt(mean_traj (ex^2 + ey^2 + ez^2)),  R = sqrt(mean_traj (eroll^2 + epitch^2 + eyaw^2)).
// The ROTATION aggregate must be lower with the loop on (asserted). Translation is printed,
// not asserted: measured, it is NOT lower (5.84 vs 5.68 mm at the time of writing), because
// the dominant translation error is the joint / potentiometer calibration bias, which the
// GQFK estimate (nominal geometry) cannot observe, so the loop steers the position towards
// where the nominal model says it is (docs/task_space.md). The per-axis table is printed.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>

#include "hexa/core/lockstep_simulation.hpp"

namespace hexa {
namespace {

constexpr std::array<PaperMotion, 7> kMotions = {
    PaperMotion::kX,     PaperMotion::kY,   PaperMotion::kZ,       PaperMotion::kRoll,
    PaperMotion::kPitch, PaperMotion::kYaw, PaperMotion::kCombined};

struct Aggregate {
  std::array<std::array<double, 6>, 7> rmse{};  // per trajectory, per axis (m, rad)
  bool all_completed = true;
  double translation_m = 0.0;
  double rotation_rad = 0.0;
};

Aggregate RunSevenTrajectories(bool outer_loop_on) {
  LockstepConfig config;  // struct defaults = deploy/rigs/hexataar_r.textproto
  config.seed = 1;
  config.disturbance = MakeRealisticDisturbanceProfile();
  config.controller = LegControllerKind::kBsSmc;
  config.supervisor.outer_loop.enabled = outer_loop_on;
  Aggregate a;
  double t2 = 0.0, r2 = 0.0;
  for (std::size_t k = 0; k < kMotions.size(); ++k) {
    const PaperSessionResult r = RunPaperSession(config, kMotions[k]);
    a.all_completed = a.all_completed && r.completed;
    a.rmse[k] = r.metrics.vs_truth.Rmse();
    for (int i = 0; i < 3; ++i) t2 += a.rmse[k][i] * a.rmse[k][i];
    for (int i = 3; i < 6; ++i) r2 += a.rmse[k][i] * a.rmse[k][i];
  }
  a.translation_m = std::sqrt(t2 / kMotions.size());
  a.rotation_rad = std::sqrt(r2 / kMotions.size());
  return a;
}

TEST(OuterLoopClosedLoop, RealisticSeed1PoseRmseLowerWithOuterLoopOn) {
  const Aggregate on = RunSevenTrajectories(true);
  const Aggregate off = RunSevenTrajectories(false);
  ASSERT_TRUE(on.all_completed);
  ASSERT_TRUE(off.all_completed);
  constexpr double kDeg = 57.29577951308232;
  std::printf("| traj | X cm on/off | Y cm on/off | Z cm on/off | roll deg on/off | pitch deg on/off | yaw deg on/off |\n");
  for (std::size_t k = 0; k < kMotions.size(); ++k) {
    std::printf("| %s |", ToString(kMotions[k]));
    for (int i = 0; i < 6; ++i) {
      const double s = i < 3 ? 100.0 : kDeg;
      std::printf(" %.3f / %.3f |", s * on.rmse[k][i], s * off.rmse[k][i]);
    }
    std::printf("\n");
  }
  std::printf("aggregate translation %.3f / %.3f mm, rotation %.4f / %.4f deg (on / off)\n",
              1000 * on.translation_m, 1000 * off.translation_m, kDeg * on.rotation_rad,
              kDeg * off.rotation_rad);
  EXPECT_LT(on.rotation_rad, off.rotation_rad);
}

}  // namespace
}  // namespace hexa
