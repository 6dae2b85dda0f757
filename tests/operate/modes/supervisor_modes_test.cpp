// The supervisor's operator modes in the in-process lockstep simulation (six leg controllers,
// the plant, the supervisor; fixed seed), checked against the plant's ground truth: a jog moves
// the platform the way it was asked, in the work and the tool frame, and stops after the
// dead-man time within the braking distance at the acceleration limit; a pose goal is reached
// within a stated tolerance; a jog held into a soft limit stops at it; a goal outside the
// limits is refused with its reason; stop and the state machine's rules.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/operator_motion.hpp"
#include "modes_session.hpp"

namespace hexa {
namespace {

using modes_test::Jog;
using modes_test::ModesSession;

// The jog's limits (JogProfileConfig defaults): V, A, J per linear axis, the dead-man time.
const JogProfileConfig kJog{};

TEST(SupervisorModes, JogMovesAlongTheAskedAxisAndStopsWithinTheDeadmanTimePlusBraking) {
  ModesSession s;
  const Pose start_truth = s.truth();
  const Pose start_setpoint = s.setpoint();
  const double v = 0.04;  // m/s, below V = 0.05
  const JogRequest jog = Jog(JogFrame::kWork, v, 0, 0);
  s.SetJog(jog);
  ASSERT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kAccepted);
  EXPECT_EQ(s.sim().supervisor_output().state, SupervisorState::kJogging);
  s.Run(2.0, &jog);  // messages every 20 ms for 2 s, then none
  const double t_last = s.last_jog_s();
  const Pose at_last_setpoint = s.setpoint();
  const Pose at_last_truth = s.truth();
  const double stop_s = s.RunUntilIdle(3.0);
  ASSERT_EQ(s.sim().supervisor_output().state, SupervisorState::kIdle);
  const double idle_after_last_s = s.sim().time_s() - t_last;
  s.Run(0.5, nullptr);  // settle
  const Pose end_setpoint = s.setpoint(), end_truth = s.truth();

  // The bound of docs/operate.md: after the last message at speed v the pivot stops within
  // T_d + v/A + A/J and travels at most v T_d + v (v/A + A/J) / 2.
  const double A = kJog.linear.max_acceleration, J = kJog.linear.max_jerk, Td = kJog.deadman_timeout_s;
  const double stop_time_bound_s = Td + v / A + A / J;
  const double travel_bound_m = v * Td + v * (v / A + A / J) / 2.0;
  const double setpoint_travel = (end_setpoint.p_BP_B_m - at_last_setpoint.p_BP_B_m).norm();
  const double truth_travel = (end_truth.p_BP_B_m - at_last_truth.p_BP_B_m).x();
  const Eigen::Vector3d moved = end_truth.p_BP_B_m - start_truth.p_BP_B_m;
  std::printf("jog +x %.3f m/s for 2 s: truth moved (%.5f %.5f %.5f) m, setpoint %.5f m; after "
              "the last message: IDLE after %.4f s (bound %.4f s), setpoint travel %.5f m, truth "
              "travel %.5f m (bound %.5f m); stop ran %.3f s\n",
              v, moved.x(), moved.y(), moved.z(),
              (end_setpoint.p_BP_B_m - start_setpoint.p_BP_B_m).x(), idle_after_last_s,
              stop_time_bound_s, setpoint_travel, truth_travel, travel_bound_m, stop_s);
  // Moved the asked way: ~ v * (2 s + the stop) along x, little sideways or up.
  EXPECT_GT(moved.x(), 0.9 * v * 2.0);
  EXPECT_LT(std::hypot(moved.y(), moved.z()), 0.05 * moved.x());
  // Stopped in time (one supervisor tick of margin: the last message lands on a tick) and
  // within the braking distance: the setpoint exactly, the platform with its tracking error.
  EXPECT_LE(idle_after_last_s, stop_time_bound_s + 0.005 + 1e-9);
  EXPECT_LE(setpoint_travel, travel_bound_m + 1e-6);
  EXPECT_LE(truth_travel, travel_bound_m + 0.003);
  EXPECT_GT(truth_travel, 0.0);
  // The setpoint never accelerated beyond A (per axis; here one axis moves).
  EXPECT_LE(s.peak_setpoint_acceleration(), A * 1.02);
  // At rest where the setpoint rests (within the estimator's static offset from the truth,
  // ~5 mm on this rig: PoseGoalIsReachedWithinTolerance).
  EXPECT_LT((end_truth.p_BP_B_m - end_setpoint.p_BP_B_m).norm(), 0.008);
}

TEST(SupervisorModes, JogInTheToolFrameTurnsWithThePlatform) {
  ModesSession s;
  // Yaw the platform by about 0.2 rad first (work frame, w_z = 0.1 rad/s for 2 s).
  const JogRequest yaw = Jog(JogFrame::kWork, 0, 0, 0, 0, 0, 0.1);
  s.SetJog(yaw);
  s.Run(2.0, &yaw);
  s.RunUntilIdle(3.0);
  s.Run(0.3, nullptr);
  const double yaw_rad = RollPitchYawFromRotation(s.setpoint().R_BP).z();
  const Pose before = s.truth();
  // Then +x of the tool frame: along the platform's own x axis, (cos yaw, sin yaw, 0) in B.
  const JogRequest tool = Jog(JogFrame::kTool, 0.04, 0, 0);
  s.SetJog(tool);
  s.Run(1.5, &tool);
  s.RunUntilIdle(3.0);
  s.Run(0.5, nullptr);
  const Eigen::Vector3d moved = s.truth().p_BP_B_m - before.p_BP_B_m;
  const double heading = std::atan2(moved.y(), moved.x());
  std::printf("tool-frame jog after a yaw of %.4f rad: moved (%.5f %.5f %.5f) m, heading %.4f rad\n",
              yaw_rad, moved.x(), moved.y(), moved.z(), heading);
  EXPECT_GT(yaw_rad, 0.15);
  EXPECT_GT(moved.norm(), 0.04);
  EXPECT_NEAR(heading, yaw_rad, 0.05);  // a work-frame jog would head at 0
}

TEST(SupervisorModes, PoseGoalIsReachedWithinTolerance) {
  ModesSession s;
  s.Run(0.5, nullptr);
  const Pose start_setpoint = s.setpoint(), start_truth = s.truth();
  Pose goal = s.setpoint();
  goal.p_BP_B_m += Eigen::Vector3d(0.03, -0.02, 0.015);
  goal.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0.05, -0.03, 0.1));
  const SupervisorOutput& out = s.Command(OperatorCommandKind::kGoal, &goal);
  ASSERT_EQ(out.command_result, CommandResult::kAccepted) << out.command_detail.data();
  EXPECT_EQ(out.state, SupervisorState::kGoal);
  const double planned_s = s.sim().supervisor().operator_motion().goal_duration_s();
  const double took_s = s.RunUntilIdle(10.0);
  ASSERT_EQ(s.sim().supervisor_output().state, SupervisorState::kIdle);
  const Pose at_idle_setpoint = s.setpoint();
  s.Run(1.0, nullptr);
  const Vector6d setpoint_error = PoseError(goal, at_idle_setpoint);
  const Vector6d truth_error = PoseError(goal, s.truth());
  // The move itself: the platform's displacement against the one asked (the static offset of
  // the estimate from the truth, the same before and after, cancels).
  const Eigen::Vector3d asked = goal.p_BP_B_m - start_setpoint.p_BP_B_m;
  const Eigen::Vector3d moved = s.truth().p_BP_B_m - start_truth.p_BP_B_m;
  const double static_offset_m = (start_truth.p_BP_B_m - start_setpoint.p_BP_B_m).norm();
  std::printf("goal (30, -20, 15) mm, (0.05, -0.03, 0.1) rad: planned %.4f s, IDLE after %.4f s; "
              "setpoint error %.2e m %.2e rad; truth error 1 s later %.5f m %.5f rad (at rest "
              "before the goal %.5f m), displacement error %.5f m; peak setpoint acceleration "
              "%.4f m/s2\n",
              planned_s, took_s, setpoint_error.head<3>().norm(), setpoint_error.tail<3>().norm(),
              truth_error.head<3>().norm(), truth_error.tail<3>().norm(), static_offset_m,
              (moved - asked).norm(), s.peak_setpoint_acceleration());
  EXPECT_NEAR(took_s, planned_s, 0.006);
  EXPECT_LT(setpoint_error.head<3>().norm(), 1e-9);
  EXPECT_LT(setpoint_error.tail<3>().norm(), 1e-9);
  // The platform (ground truth) at rest on the goal: within 8 mm and 8 mrad (the estimator's
  // static offset from the truth included), and the move itself within 3 mm of the one asked.
  EXPECT_LT(truth_error.head<3>().norm(), 0.008);
  EXPECT_LT(truth_error.tail<3>().norm(), 0.008);
  EXPECT_LT((moved - asked).norm(), 0.003);
  // The pivot's (here the origin's) path acceleration stays within the goal's limit.
  EXPECT_LE(s.peak_setpoint_acceleration(), OperatorMotionConfig{}.goal_linear.max_acceleration * 1.02);
}

TEST(SupervisorModes, GoalOutsideTheSoftLimitsIsRefusedWithItsReason) {
  ModesSession s;
  Pose goal = s.setpoint();
  goal.p_BP_B_m.x() += 0.12;  // the pose box is +-0.10 m about home
  const SupervisorOutput& out = s.Command(OperatorCommandKind::kGoal, &goal);
  EXPECT_EQ(out.command_result, CommandResult::kRefused);
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  const std::string why = out.command_detail.data();
  EXPECT_NE(why.find("pose box"), std::string::npos) << why;
  EXPECT_NE(why.find("beyond the limit 0.1000"), std::string::npos) << why;
}

TEST(SupervisorModes, JogHeldIntoTheSoftLimitStopsAtIt) {
  ModesSession s;
  const double limit_x = s.sim().supervisor().operator_motion().limits().config().box_max[0];
  const JogRequest jog = Jog(JogFrame::kWork, 0.05, 0, 0);
  s.SetJog(jog);
  double worst_setpoint_x = -1.0, worst_truth_x = -1.0;
  for (int k = 0; k < 300; ++k) {  // 3 s at V = 0.05 m/s: the 0.10 m limit is reached at ~2.2 s
    s.Run(0.01, &jog, 0.01);
    worst_setpoint_x = std::max(worst_setpoint_x, s.setpoint().p_BP_B_m.x());
    worst_truth_x = std::max(worst_truth_x, s.truth().p_BP_B_m.x());
  }
  std::printf("jog +x held into the box limit x = %.4f m: setpoint peak %.7f m (overshoot "
              "%.2e m), truth peak %.5f m (overshoot %.5f m)\n",
              limit_x, worst_setpoint_x, worst_setpoint_x - limit_x, worst_truth_x,
              worst_truth_x - limit_x);
  EXPECT_LE(worst_setpoint_x, limit_x + 1e-6);
  EXPECT_GT(worst_setpoint_x, limit_x - 0.005);  // it got there
  EXPECT_LE(worst_truth_x, limit_x + 0.003);
  EXPECT_EQ(s.sim().supervisor_output().state, SupervisorState::kJogging);
}

TEST(SupervisorModes, StopEndsAGoalEarlyAtRestAndTheStateMachineKeepsItsRules) {
  ModesSession s;
  Pose goal = s.setpoint();
  goal.p_BP_B_m.y() += 0.06;
  ASSERT_EQ(s.Command(OperatorCommandKind::kGoal, &goal).command_result, CommandResult::kAccepted);
  // While a goal runs: neither a jog nor a second goal nor a start is taken.
  s.Run(0.6, nullptr);
  EXPECT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kRefused);
  EXPECT_EQ(s.Command(OperatorCommandKind::kGoal, &goal).command_result, CommandResult::kRefused);
  EXPECT_EQ(s.Command(OperatorCommandKind::kHome).command_result, CommandResult::kRefused);
  ASSERT_EQ(s.Command(OperatorCommandKind::kStop).command_result, CommandResult::kAccepted);
  const double stop_s = s.RunUntilIdle(3.0);
  ASSERT_EQ(s.sim().supervisor_output().state, SupervisorState::kIdle);
  const double y = s.setpoint().p_BP_B_m.y();
  std::printf("goal of 60 mm stopped after 0.6 s: at rest after %.4f s at y = %.5f m\n", stop_s, y);
  EXPECT_GT(y, 0.0);
  EXPECT_LT(y, 0.05);  // short of the goal
  // From IDLE the next jog is taken, and a home after it.
  EXPECT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kAccepted);
  EXPECT_EQ(s.Command(OperatorCommandKind::kStop).command_result, CommandResult::kAccepted);
  s.RunUntilIdle(3.0);
  EXPECT_EQ(s.Command(OperatorCommandKind::kHome).command_result, CommandResult::kAccepted);
}

}  // namespace
}  // namespace hexa
