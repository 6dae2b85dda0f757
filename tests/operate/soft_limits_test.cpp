// Soft limits: a jog held into each limit stops at it (overshoot measured), speed clamps,
// goals refused with their reason, recovery after tightened limits, and a fixed-seed property:
// every output of random steps is inside every limit.
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/soft_limits.hpp"
#include "hexa/core/user_frames.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::HomePose;
using operate_test::kDeg;
using operate_test::Sampler;

constexpr double kPeriod_s = 0.005;

struct JogResult {
  Pose final_pose;
  SoftLimitsOutput last;
  int clamped_ticks = 0;
};

// Holds a constant twist (of the platform origin) for `seconds`, every step through the limits.
JogResult HoldJog(const SoftLimits& limits, const Pose& start, const Vector6d& twist,
                  double seconds) {
  JogResult r;
  Pose setpoint = start;
  for (int k = 0; k < static_cast<int>(seconds / kPeriod_s); ++k) {
    SoftLimitsInput in;
    in.previous = setpoint;
    in.candidate = IntegratePivotTwist(setpoint, Eigen::Vector3d::Zero(), twist, kPeriod_s);
    in.period_s = kPeriod_s;
    limits.Update(in, r.last);
    setpoint = r.last.setpoint;
    if (r.last.result == SoftLimitsResult::kClamped) ++r.clamped_ticks;
  }
  r.final_pose = setpoint;
  return r;
}

TEST(SoftLimits, HomeIsInsideAndPassesUnchanged) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  EXPECT_EQ(limits.CheckPose(HomePose(rig)).kind, SoftLimitKind::kNone);
  SoftLimitsInput in;
  in.previous = in.candidate = HomePose(rig);
  in.candidate.p_BP_B_m.x() += 0.001;
  SoftLimitsOutput out;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kInside);
  EXPECT_EQ(out.setpoint.p_BP_B_m, in.candidate.p_BP_B_m);
}

// The default joint limits (20 deg) hold every pose of the default box that keeps the legs in
// their stroke: the box corners' largest deflection is printed.
TEST(SoftLimits, DefaultJointLimitsHoldTheDefaultBox) {
  const RigParams rig = MakeReferenceRig();
  SoftLimitsConfig config = MakeSoftLimitsConfig(rig, SupervisorParams{});
  const SoftLimits limits(rig, config);
  Sampler s(5);
  double worst_base = 0.0, worst_platform = 0.0;
  int inside_stroke = 0;
  for (int i = 0; i < 20000; ++i) {
    Vector6d q;
    for (int k = 0; k < 6; ++k) q[k] = s.Uniform(config.box_min[k], config.box_max[k]);
    const Pose pose = PoseFromVector(q);
    const PoseLimitCheck check = limits.CheckPose(pose);
    if (check.kind == SoftLimitKind::kStroke) continue;
    ++inside_stroke;
    EXPECT_EQ(check.kind, SoftLimitKind::kNone) << ToString(check.kind) << " leg " << check.index;
    LegArray<double> base{}, platform{};
    limits.JointAngles(pose, base, platform);
    for (int leg = 0; leg < 6; ++leg) {
      worst_base = std::max(worst_base, base[leg]);
      worst_platform = std::max(worst_platform, platform[leg]);
    }
  }
  std::printf("box poses inside the stroke: %d of 20000; largest joint deflection: base %.2f deg, "
              "platform %.2f deg\n", inside_stroke, worst_base / kDeg, worst_platform / kDeg);
  EXPECT_GT(inside_stroke, 1000);
  EXPECT_LT(worst_base, config.max_base_joint_angle_rad);
  EXPECT_LT(worst_platform, config.max_platform_joint_angle_rad);
}

TEST(SoftLimits, JogIntoThePoseBoxStopsAtIt) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimitsConfig config = MakeSoftLimitsConfig(rig, SupervisorParams{});
  const SoftLimits limits(rig, config);
  Vector6d twist = Vector6d::Zero();
  twist[0] = 0.05;  // 5 cm/s towards +x, for 3 s: 15 cm asked, the box allows 10
  const JogResult r = HoldJog(limits, HomePose(rig), twist, 3.0);
  const double x = r.final_pose.p_BP_B_m.x();
  std::printf("x jog: stopped at %.9f m, box %.3f m, overshoot %.3g m\n", x, config.box_max[0],
              x - config.box_max[0]);
  EXPECT_LE(x, config.box_max[0]);
  EXPECT_GT(x, config.box_max[0] - 0.05 * kPeriod_s * 1e-5);  // within 1e-5 of one step
  EXPECT_EQ(r.last.active, SoftLimitKind::kPoseBox);
  EXPECT_EQ(r.last.index, 1);
  EXPECT_GT(r.clamped_ticks, 190);  // held there for the last second
}

TEST(SoftLimits, JogIntoTheStrokeStopsAtIt) {
  const RigParams rig = MakeReferenceRig();
  SoftLimitsConfig config = MakeSoftLimitsConfig(rig, SupervisorParams{});
  config.box_max[2] = 1.0;  // the stroke binds first
  const SoftLimits limits(rig, config);
  Vector6d twist = Vector6d::Zero();
  twist[2] = 0.1;
  const JogResult r = HoldJog(limits, HomePose(rig), twist, 3.0);
  LegArray<double> length_m{};
  InverseKinematics(rig.geometry, r.final_pose, length_m);
  const double longest = *std::max_element(length_m.begin(), length_m.end());
  std::printf("z jog: longest leg %.9f m, limit %.9f m, overshoot %.3g m\n", longest,
              limits.max_length_m(), longest - limits.max_length_m());
  EXPECT_LE(longest, limits.max_length_m());
  EXPECT_GT(longest, limits.max_length_m() - 1e-6);
  EXPECT_EQ(r.last.active, SoftLimitKind::kStroke);
  EXPECT_NEAR(limits.max_length_m(), 0.6184, 1e-4);  // docs/task_space.md: [0.3884, 0.6184] m
}

TEST(SoftLimits, JogIntoAJointAngleStopsAtIt) {
  const RigParams rig = MakeReferenceRig();
  SoftLimitsConfig config = MakeSoftLimitsConfig(rig, SupervisorParams{});
  config.max_platform_joint_angle_rad = 8 * kDeg;
  config.max_base_joint_angle_rad = 1.0;
  const SoftLimits limits(rig, config);
  Vector6d twist = Vector6d::Zero();
  twist[5] = 0.2;  // yaw: twists every leg about the platform joint
  const JogResult r = HoldJog(limits, HomePose(rig), twist, 3.0);
  LegArray<double> base{}, platform{};
  limits.JointAngles(r.final_pose, base, platform);
  const double worst = *std::max_element(platform.begin(), platform.end());
  std::printf("yaw jog: platform joint %.6f deg, limit 8 deg\n", worst / kDeg);
  EXPECT_LE(worst, config.max_platform_joint_angle_rad);
  EXPECT_GT(worst, config.max_platform_joint_angle_rad - 1e-6);
  EXPECT_EQ(r.last.active, SoftLimitKind::kPlatformJointAngle);
}

TEST(SoftLimits, ATooFastStepIsCutToTheSpeedLimit) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  SoftLimitsInput in;
  in.previous = in.candidate = HomePose(rig);
  in.candidate.p_BP_B_m.y() += 0.02;  // 4 m/s asked, 0.8 allowed
  in.period_s = kPeriod_s;
  SoftLimitsOutput out;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kClamped);
  const double speed = (out.setpoint.p_BP_B_m - in.previous.p_BP_B_m).norm() / kPeriod_s;
  EXPECT_LE(speed, 0.8 + 1e-12);
  EXPECT_GT(speed, 0.8 * (1 - 1e-5));
  // Which binds first, the platform's 0.8 m/s or a leg's 0.8 m/s: the legs move slower than
  // the platform here (leg direction ~27 deg from vertical), so the platform speed.
  EXPECT_EQ(out.active, SoftLimitKind::kLinearSpeed);
  in.candidate = HomePose(rig);
  in.candidate.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0.1, 0, 0));  // 20 rad/s asked
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kClamped);
  EXPECT_TRUE(out.active == SoftLimitKind::kAngularSpeed || out.active == SoftLimitKind::kLegSpeed);
  EXPECT_LE(PoseError(out.setpoint, in.previous).tail<3>().norm() / kPeriod_s, 1.0 + 1e-9);
}

TEST(SoftLimits, NotFiniteCandidateIsHeld) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  SoftLimitsInput in;
  in.previous = in.candidate = HomePose(rig);
  in.candidate.p_BP_B_m.z() = std::nan("");
  SoftLimitsOutput out;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kHeld);
  EXPECT_EQ(out.active, SoftLimitKind::kNotFinite);
  EXPECT_EQ(out.setpoint.p_BP_B_m, in.previous.p_BP_B_m);
}

TEST(SoftLimits, GoalOutsideIsRefusedWithItsReason) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  Pose goal = HomePose(rig);
  goal.p_BP_B_m.x() = 0.12;
  GoalCheck check = limits.CheckGoal(HomePose(rig), goal);
  EXPECT_FALSE(check.accepted);
  EXPECT_STREQ(check.message.data(),
               "goal refused: the goal leaves the pose box: x 0.1200 m beyond the limit 0.1000");
  goal = HomePose(rig);
  goal.p_BP_B_m = Eigen::Vector3d(0.05, 0.05, 0.5);
  EXPECT_TRUE(limits.CheckGoal(HomePose(rig), goal).accepted);
  // Stroke: a goal inside a wide box whose legs cannot reach.
  SoftLimitsConfig wide = MakeSoftLimitsConfig(rig, SupervisorParams{});
  wide.box_max[2] = 1.0;
  const SoftLimits wide_limits(rig, wide);
  goal = HomePose(rig);
  goal.p_BP_B_m.z() = 0.60;
  check = wide_limits.CheckGoal(HomePose(rig), goal);
  std::printf("%s\n", check.message.data());
  EXPECT_FALSE(check.accepted);
  EXPECT_EQ(check.violation.kind, SoftLimitKind::kStroke);
  EXPECT_NE(std::string(check.message.data()).find("breaks the stroke limit of leg"),
            std::string::npos) << check.message.data();
}

// A goal whose end points are inside but whose path leaves the box: a yaw of +-0.2 rad about a
// pivot 0.4 m ahead of the platform swings the origin on an arc that bulges 7.9 mm towards -x
// beyond its end points, which sit 5 mm inside the box.
TEST(SoftLimits, GoalWhosePathLeavesTheBoxIsRefused) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  const Eigen::Vector3d p_PC_P(0.4, 0, 0);
  const auto platform_at_yaw = [&](double yaw) {
    Pose X_BC;
    X_BC.p_BP_B_m = Eigen::Vector3d(-0.095 + 0.4 * std::cos(0.2), 0, 0.45);
    X_BC.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, yaw));
    return PlatformFromPivot(X_BC, p_PC_P);
  };
  const Pose start = platform_at_yaw(-0.2), goal = platform_at_yaw(0.2);
  ASSERT_EQ(limits.CheckPose(start).kind, SoftLimitKind::kNone);
  ASSERT_EQ(limits.CheckPose(goal).kind, SoftLimitKind::kNone);
  const GoalCheck check = limits.CheckGoal(start, goal, p_PC_P);
  std::printf("%s\n", check.message.data());
  EXPECT_FALSE(check.accepted);
  EXPECT_GT(check.path_fraction, 0.0);
  EXPECT_LT(check.path_fraction, 1.0);
  EXPECT_EQ(check.violation.kind, SoftLimitKind::kPoseBox);
  EXPECT_NE(std::string(check.message.data()).find("the path at"), std::string::npos)
      << check.message.data();
  // The same end points reached about the platform origin stay inside.
  EXPECT_TRUE(limits.CheckGoal(start, goal).accepted);
}

TEST(SoftLimits, OutsideAfterTighteningOnlyMovesBackIn) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  SoftLimitsInput in;
  in.previous = HomePose(rig);
  in.previous.p_BP_B_m.x() = 0.11;  // outside the box
  in.candidate = in.previous;
  in.candidate.p_BP_B_m.x() = 0.111;
  SoftLimitsOutput out;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kHeld);
  EXPECT_EQ(out.setpoint.p_BP_B_m.x(), 0.11);
  in.candidate.p_BP_B_m.x() = 0.109;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kRecovering);
  EXPECT_EQ(out.setpoint.p_BP_B_m.x(), 0.109);
  // Moving back in still keeps the speed limits: a jump to 5 cm (12 m/s) is cut to 0.8 m/s.
  in.period_s = kPeriod_s;
  in.candidate.p_BP_B_m.x() = 0.05;
  limits.Update(in, out);
  EXPECT_EQ(out.result, SoftLimitsResult::kRecovering);
  EXPECT_EQ(out.active, SoftLimitKind::kLinearSpeed);
  EXPECT_NEAR(out.setpoint.p_BP_B_m.x(), 0.11 - 0.8 * kPeriod_s, 1e-7);
}

// 50,000 random steps from random poses inside the limits: every output is inside every
// limit (static and speed), and an inside candidate is passed unchanged.
TEST(SoftLimits, RandomStepsNeverLeaveTheLimits) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimitsConfig config = MakeSoftLimitsConfig(rig, SupervisorParams{});
  const SoftLimits limits(rig, config);
  Sampler s(20261207);
  int clamped = 0, tested = 0;
  while (tested < 50000) {
    Vector6d q;
    for (int k = 0; k < 6; ++k) q[k] = s.Uniform(config.box_min[k], config.box_max[k]);
    SoftLimitsInput in;
    in.previous = PoseFromVector(q);
    if (limits.CheckPose(in.previous).kind != SoftLimitKind::kNone) continue;
    ++tested;
    Vector6d step;
    for (int k = 0; k < 6; ++k) step[k] = s.Uniform(-1, 1) * (k < 3 ? 0.004 : 0.005);
    in.candidate = PoseFromVector(q + step);
    in.period_s = kPeriod_s;
    SoftLimitsOutput out;
    limits.Update(in, out);
    ASSERT_EQ(limits.CheckPose(out.setpoint).kind, SoftLimitKind::kNone) << tested;
    ASSERT_LE((out.setpoint.p_BP_B_m - in.previous.p_BP_B_m).norm() / kPeriod_s,
              config.max_linear_speed_m_s * (1 + 1e-12));
    ASSERT_LE(PoseError(out.setpoint, in.previous).tail<3>().norm() / kPeriod_s,
              config.max_angular_speed_rad_s * (1 + 1e-9));
    if (out.result == SoftLimitsResult::kClamped) {
      ++clamped;
      ASSERT_LT(out.fraction, 1.0);
      ASSERT_NE(out.active, SoftLimitKind::kNone);
    } else {
      ASSERT_EQ(out.result, SoftLimitsResult::kInside);
    }
  }
  std::printf("random steps: %d of %d clamped\n", clamped, tested);
  EXPECT_GT(clamped, 10000);          // the steps are large enough to hit limits often
  EXPECT_LT(clamped, tested - 10000);  // and small enough to pass unchanged often
}

TEST(SoftLimits, ValidateNamesFieldValueAndLimit) {
  SoftLimitsConfig config;
  config.box_min[1] = 0.2;
  try {
    config.Validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("soft_limits.box_max.y: box maximum must exceed its "
                                         "minimum (value 0.1, limit > 0.2)"),
              std::string::npos) << e.what();
  }
  config = SoftLimitsConfig{};
  config.max_leg_speed_m_s = std::nan("");
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = SoftLimitsConfig{};
  config.stroke_margin_m = 0.2;  // half the 0.25 m stroke is 0.125
  EXPECT_THROW(SoftLimits(MakeReferenceRig(), config), std::invalid_argument);
}

}  // namespace
}  // namespace hexa
