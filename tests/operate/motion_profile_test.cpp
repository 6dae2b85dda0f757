// Jerk-limited jog and pose-goal profiles: limits never exceeded (fixed-seed random targets),
// the time-optimal durations of the double-S, the dead-man stop within its bound, tool-frame
// jog, a goal reached with the pivot still.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <gtest/gtest.h>

#include "hexa/core/motion_profile.hpp"
#include "hexa/core/user_frames.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::kDeg;
using operate_test::Sampler;

TEST(JerkLimitedVelocity, RandomTargetsNeverBreakTheLimits) {
  const AxisLimits limits{0.05, 0.25, 2.5};
  const double dt = 0.005;
  Sampler s(42);
  AxisMotionState state;
  double target = 0.0, worst_v = 0.0, worst_a = 0.0, worst_j = 0.0;
  for (int k = 0; k < 200000; ++k) {
    if (k % 97 == 0) target = s.Uniform(-0.08, 0.08);  // beyond the limit too
    const double a_before = state.acceleration;
    StepJerkLimitedVelocity(target, limits, dt, state);
    worst_v = std::max(worst_v, std::abs(state.velocity));
    worst_a = std::max(worst_a, std::abs(state.acceleration));
    worst_j = std::max(worst_j, std::abs(state.acceleration - a_before) / dt);
  }
  EXPECT_LE(worst_v, limits.max_speed * (1 + 1e-12));
  EXPECT_LE(worst_a, limits.max_acceleration * (1 + 1e-12));
  EXPECT_LE(worst_j, limits.max_jerk * (1 + 1e-9));
  EXPECT_GT(worst_v, 0.99 * limits.max_speed);  // the limits were reached, not avoided
  EXPECT_GT(worst_a, 0.99 * limits.max_acceleration);
}

// From rest to V: the time-optimal jerk-limited ramp lasts V/A + A/J (A reached) and lands on V
// with zero acceleration. The discrete law reaches it within one step.
TEST(JerkLimitedVelocity, ReachesTheTargetInTheTimeOptimalDuration) {
  const AxisLimits limits{0.05, 0.25, 2.5};
  const double dt = 0.001;
  AxisMotionState state;
  int steps = 0;
  while (!(state.velocity == 0.05 && state.acceleration == 0.0) && steps < 10000) {
    StepJerkLimitedVelocity(0.05, limits, dt, state);
    ++steps;
  }
  const double optimal_s = 0.05 / 0.25 + 0.25 / 2.5;  // 0.3 s
  EXPECT_NEAR(steps * dt, optimal_s, 2 * dt);
}

JogProfileConfig TestJogConfig() {
  JogProfileConfig config;
  config.linear = AxisLimits{0.05, 0.25, 2.5};
  config.angular = AxisLimits{0.2, 1.0, 10.0};
  config.deadman_timeout_s = 0.25;
  return config;
}

// A jog at full speed whose messages stop: the twist is zero within the dead-man timeout plus
// the jerk-limited braking time, after travelling at most v T_deadman + v (v/A + A/J) / 2.
TEST(JogProfile, DeadmanStopsWithinTheTimeoutAndTheBrakingDistance) {
  const JogProfileConfig config = TestJogConfig();
  JogProfile jog(config);
  const double dt = 0.005;
  JogInput in;
  in.dt_s = dt;
  in.twist_jog << 0.05, 0, 0, 0, 0, 0;
  JogOutput out;
  double x_m = 0.0, t = 0.0, last_command_s = 0.0, x_at_last_command = 0.0;
  for (; t < 5.0; t += dt) {
    in.time_s = t;
    in.command_received = t < 2.0;  // 200 Hz messages for 2 s, then none
    if (in.command_received) {
      last_command_s = t;
      x_at_last_command = x_m;
    }
    jog.Update(in, out);
    x_m += out.twist_C_B[0] * dt;  // x_m: travelled distance of the pivot (rectangle rule)
    if (!in.command_received && out.status == JogStatus::kStill) break;
  }
  const double v = 0.05, A = 0.25, J = 2.5;
  const double braking_s = v / A + A / J;
  const double stop_time_s = t - last_command_s;
  const double after_m = x_m - x_at_last_command;
  const double bound_m = v * config.deadman_timeout_s + 0.5 * v * braking_s;
  std::printf("dead-man: still %.3f s after the last message (bound %.3f s), travelled %.4f mm "
              "(bound %.4f mm)\n", stop_time_s, config.deadman_timeout_s + braking_s,
              after_m * 1e3, bound_m * 1e3);
  EXPECT_EQ(out.status, JogStatus::kStill);
  EXPECT_LE(stop_time_s, config.deadman_timeout_s + braking_s + 2 * dt);
  EXPECT_LE(after_m, bound_m + v * dt);
  EXPECT_GT(after_m, bound_m - 2 * v * dt);  // the bound is what happens, not a loose cap
}

TEST(JogProfile, StatusSaysDeadmanWhileBraking) {
  JogProfile jog(TestJogConfig());
  JogInput in;
  in.twist_jog << 0, 0, 0, 0, 0, 0.2;
  JogOutput out;
  bool saw_deadman = false;
  for (int k = 0; k < 400; ++k) {
    in.time_s = k * in.dt_s;
    in.command_received = k < 100;
    jog.Update(in, out);
    if (k < 100 && k > 0) {
      EXPECT_EQ(out.status, JogStatus::kMoving);
    }
    if (out.status == JogStatus::kDeadmanStop) saw_deadman = true;
  }
  EXPECT_TRUE(saw_deadman);
  EXPECT_EQ(out.status, JogStatus::kStill);
  EXPECT_TRUE(jog.still());
}

TEST(JogProfile, NonFiniteCommandIsRejectedAndTheDeadmanRunsOn) {
  JogProfile jog(TestJogConfig());
  JogInput in;
  in.twist_jog << 0.05, 0, 0, 0, 0, 0;
  in.command_received = true;
  JogOutput out;
  jog.Update(in, out);
  in.twist_jog[1] = std::nan("");
  double peak = 0.0;
  for (int k = 1; k < 300; ++k) {
    in.time_s = k * in.dt_s;
    jog.Update(in, out);
    EXPECT_EQ(out.status, JogStatus::kRejected);
    EXPECT_TRUE(out.twist_C_B.allFinite());
    peak = std::max(peak, out.twist_C_B[0]);
  }
  EXPECT_EQ(out.twist_C_B[0], 0.0);  // stopped: the last good command is 1.5 s old
  EXPECT_GT(peak, 0.0);
}

TEST(JogProfile, ToolFrameJogFollowsTheToolAxes) {
  JogProfile jog(TestJogConfig());
  UserFramesConfig frames;
  Pose X_BP;
  X_BP.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, 90 * kDeg));
  JogInput in;
  in.twist_jog << 0.02, 0, 0, 0, 0, 0;
  in.R_B_jog = JogAxes(JogFrame::kTool, X_BP, frames);
  in.command_received = true;
  JogOutput out;
  for (int k = 0; k < 200; ++k) {
    in.time_s = k * in.dt_s;
    jog.Update(in, out);
  }
  EXPECT_NEAR(out.twist_C_B[0], 0.0, 1e-15);
  EXPECT_NEAR(out.twist_C_B[1], 0.02, 1e-12);  // tool x = B y when yawed 90 deg
}

TEST(JogProfile, ValidateNamesTheField) {
  JogProfileConfig config;
  config.linear.max_jerk = -1.0;
  try {
    JogProfile jog(config);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("jog.linear.max_jerk: jerk limit must be positive "
                                         "(value -1, limit > 0)"), std::string::npos) << e.what();
  }
  config = JogProfileConfig{};
  config.deadman_timeout_s = 10.0;
  EXPECT_THROW(JogProfile{config}, std::invalid_argument);
}

// The double-S in its three cases: duration equal to the closed forms, end at rest at the
// distance, velocity = derivative of position, acceleration and jerk within the limits.
TEST(DoubleS, ThreeCasesMatchTheirClosedFormsAndLimits) {
  const AxisLimits limits{1.0, 2.0, 10.0};
  struct Case { double h; double duration_s; };
  // h = 2: V reached: T = h/V + V/A + A/J = 2 + 0.5 + 0.2.
  // h = 0.5: A reached, not V (h >= 2 A^3/J^2 = 0.16): Ta = Tj/2 + sqrt(Tj^2/4 + h/A).
  // h = 0.05: neither: Tj = (h / 2J)^(1/3), T = 4 Tj.
  const double tj = 0.2;
  const Case cases[] = {{2.0, 2.7},
                        {0.5, 2 * (tj / 2 + std::sqrt(tj * tj / 4 + 0.5 / 2.0))},
                        {0.05, 4 * std::cbrt(0.05 / 20.0)}};
  for (const Case& c : cases) {
    const DoubleSProfile p = PlanDoubleS(c.h, limits);
    EXPECT_NEAR(p.duration_s(), c.duration_s, 1e-12) << c.h;
    double q, v, a, q_prev = 0, v_prev = 0, a_prev = 0, worst_j = 0;
    const double dt = 1e-5;
    for (double t = dt; t <= p.duration_s() + 2 * dt; t += dt) {
      EvaluateDoubleS(p, t, q, v, a);
      EXPECT_LE(std::abs(v), limits.max_speed * (1 + 1e-12));
      EXPECT_LE(std::abs(a), limits.max_acceleration * (1 + 1e-12));
      EXPECT_NEAR((q - q_prev) / dt, 0.5 * (v + v_prev), 1e-6) << c.h << " t " << t;
      EXPECT_NEAR((v - v_prev) / dt, 0.5 * (a + a_prev), 0.5 * limits.max_jerk * dt) << c.h << " t " << t;
      worst_j = std::max(worst_j, std::abs(a - a_prev) / dt);
      q_prev = q, v_prev = v, a_prev = a;
    }
    EXPECT_DOUBLE_EQ(q, c.h);
    EXPECT_EQ(v, 0.0);
    EXPECT_LE(worst_j, limits.max_jerk * (1 + 1e-6));
  }
}

// A goal of pure rotation about a pivot above the platform: the pivot does not move, the
// platform ends on the goal, the angular limits hold along the way.
TEST(PoseGoalProfile, PureRotationKeepsThePivotAndEndsOnTheGoal) {
  const Eigen::Vector3d p_PC_P(0, 0, 0.25);
  Pose X_BP;
  X_BP.p_BP_B_m = Eigen::Vector3d(0, 0, 0.45);
  Pose goal_C = PivotPose(X_BP, p_PC_P);
  goal_C.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(8 * kDeg, -5 * kDeg, 3 * kDeg));
  const AxisLimits linear{0.05, 0.25, 2.5}, angular{0.2, 1.0, 10.0};
  PoseGoalProfile goal;
  ASSERT_TRUE(goal.Plan(PivotPose(X_BP, p_PC_P), goal_C, linear, angular));
  PoseGoalSample sample;
  double worst_w = 0, worst_alpha = 0, pivot_drift = 0;
  for (double t = 0; t <= goal.duration_s() + 0.01; t += 0.001) {
    goal.Evaluate(t, sample);
    worst_w = std::max(worst_w, sample.twist_C_B.tail<3>().norm());
    worst_alpha = std::max(worst_alpha, sample.acceleration_C_B.tail<3>().norm());
    pivot_drift = std::max(pivot_drift, (sample.X_BC.p_BP_B_m - goal_C.p_BP_B_m).norm());
  }
  EXPECT_TRUE(sample.done);
  EXPECT_LT((sample.X_BC.R_BP - goal_C.R_BP).norm(), 1e-12);
  EXPECT_EQ(pivot_drift, 0.0);
  EXPECT_LE(worst_w, angular.max_speed * (1 + 1e-12));
  EXPECT_LE(worst_alpha, angular.max_acceleration * (1 + 1e-12));
  EXPECT_GT(worst_w, 0.99 * angular.max_speed);  // long enough a turn to cruise
}

TEST(PoseGoalProfile, CombinedMoveRespectsTheTighterLimit) {
  Pose start, goal;
  start.p_BP_B_m = Eigen::Vector3d(0, 0, 0.45);
  goal.p_BP_B_m = Eigen::Vector3d(0.06, -0.02, 0.47);
  goal.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, 2 * kDeg));
  const AxisLimits linear{0.05, 0.25, 2.5}, angular{0.2, 1.0, 10.0};
  PoseGoalProfile profile;
  ASSERT_TRUE(profile.Plan(start, goal, linear, angular));
  PoseGoalSample sample;
  double worst_v = 0;
  for (double t = 0; t <= profile.duration_s(); t += 0.001) {
    profile.Evaluate(t, sample);
    worst_v = std::max(worst_v, sample.twist_C_B.head<3>().norm());
    EXPECT_LE(sample.twist_C_B.tail<3>().norm(), angular.max_speed);
  }
  EXPECT_NEAR(worst_v, linear.max_speed, 1e-9);  // the linear part binds and cruises
  profile.Evaluate(profile.duration_s(), sample);
  EXPECT_LT((sample.X_BC.p_BP_B_m - goal.p_BP_B_m).norm(), 1e-15);
  Pose bad = goal;
  bad.p_BP_B_m.x() = std::nan("");
  EXPECT_FALSE(profile.Plan(start, bad, linear, angular));
}

}  // namespace
}  // namespace hexa
