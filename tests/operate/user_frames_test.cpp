// Pivot point and user frames: algebra, the pivot kept still by a rotation (checked through the
// kinematics: leg lengths -> forward kinematics -> pivot), validation of user input.
#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/user_frames.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::HomePose;
using operate_test::kDeg;
using operate_test::Sampler;

Pose RandomPose(Sampler& s) {
  Vector6d v;
  v << s.Uniform(-0.05, 0.05), s.Uniform(-0.05, 0.05), s.Uniform(0.40, 0.50),
      s.Uniform(-10, 10) * kDeg, s.Uniform(-10, 10) * kDeg, s.Uniform(-10, 10) * kDeg;
  return PoseFromVector(v);
}

TEST(UserFrames, ComposeAndInverseRoundTrip) {
  Sampler s(7);
  for (int i = 0; i < 1000; ++i) {
    const Pose a = RandomPose(s), b = RandomPose(s);
    const Pose back = Compose(Compose(a, b), Inverse(b));
    EXPECT_LT((back.p_BP_B_m - a.p_BP_B_m).norm(), 1e-14);
    EXPECT_LT((back.R_BP - a.R_BP).norm(), 1e-14);
  }
}

// Rotation about a pivot 12 cm above the platform origin, 1 s at 0.2 rad/s about a tilted
// axis: the leg lengths of every pose, turned back into a pose by forward kinematics (Newton,
// kinematics.hpp), put the pivot where it started.
TEST(UserFrames, RotationAboutThePivotKeepsItStillThroughTheKinematics) {
  const RigParams rig = MakeReferenceRig();
  const Eigen::Vector3d p_PC_P(0.02, -0.03, 0.12);
  Vector6d twist = Vector6d::Zero();
  twist.tail<3>() = Eigen::Vector3d(0.1, 0.15, 0.05).normalized() * 0.2;
  Pose X_BP = HomePose(rig);
  const Eigen::Vector3d pivot_start = PivotPose(X_BP, p_PC_P).p_BP_B_m;
  double worst_m = 0.0, rotated_rad = 0.0;
  for (int k = 0; k < 200; ++k) {
    X_BP = IntegratePivotTwist(X_BP, p_PC_P, twist, 0.005);
    LegArray<double> length_m{};
    InverseKinematics(rig.geometry, X_BP, length_m);
    NewtonFkResult fk;
    ASSERT_EQ(NewtonRaphsonFk(rig.geometry, length_m, HomePose(rig), NewtonFkConfig{}, fk),
              KinStatus::kOk);
    worst_m = std::max(worst_m, (PivotPose(fk.pose, p_PC_P).p_BP_B_m - pivot_start).norm());
    rotated_rad = PoseError(fk.pose, HomePose(rig)).tail<3>().norm();
  }
  EXPECT_NEAR(rotated_rad, 0.2, 1e-9);  // it did turn
  EXPECT_LT(worst_m, 1e-9);
  // The platform origin itself moved: the pivot, not the origin, is the centre.
  EXPECT_GT((X_BP.p_BP_B_m - HomePose(rig).p_BP_B_m).norm(), 0.01);
}

TEST(UserFrames, PlatformTwistMatchesFiniteDifferences) {
  Sampler s(11);
  const Eigen::Vector3d p_PC_P(0.0, 0.05, 0.2);
  for (int i = 0; i < 200; ++i) {
    const Pose X = RandomPose(s);
    Vector6d twist;
    for (int k = 0; k < 6; ++k) twist[k] = s.Uniform(-0.3, 0.3);
    const double h = 1e-6;
    const Pose next = IntegratePivotTwist(X, p_PC_P, twist, h);
    const Vector6d expected = PlatformTwistFromPivotTwist(X, p_PC_P, twist);
    const Vector6d numeric = PoseError(next, X) / h;
    EXPECT_LT((numeric - expected).norm(), 1e-6) << i;
  }
}

TEST(UserFrames, ToolFrameJogAxesTurnWithThePlatform) {
  UserFramesConfig frames;
  frames.X_PT.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, 90 * kDeg));
  Pose X_BP;
  X_BP.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, 30 * kDeg));
  Vector6d along_tool_x = Vector6d::Zero();
  along_tool_x[0] = 1.0;
  const Vector6d in_B = TwistInBase(along_tool_x, JogAxes(JogFrame::kTool, X_BP, frames));
  // Tool x = platform y, platform yawed 30 deg: B direction at 120 deg.
  EXPECT_NEAR(in_B[0], std::cos(120 * kDeg), 1e-15);
  EXPECT_NEAR(in_B[1], std::sin(120 * kDeg), 1e-15);
  const Vector6d in_work = TwistInBase(along_tool_x, JogAxes(JogFrame::kWork, X_BP, frames));
  EXPECT_NEAR(in_work[0], 1.0, 1e-15);  // work frame = B by default
}

TEST(UserFrames, ToolGoalInWorkFrameRoundTrips) {
  Sampler s(3);
  UserFramesConfig frames;
  frames.X_PT = RandomPose(s);
  frames.X_PT.p_BP_B_m *= 0.2;
  frames.X_BW = RandomPose(s);
  frames.Validate();
  for (int i = 0; i < 100; ++i) {
    const Pose X_BP = RandomPose(s);
    const Pose back = PlatformPoseFromToolGoal(ToolPoseInWork(X_BP, frames), frames);
    EXPECT_LT((back.p_BP_B_m - X_BP.p_BP_B_m).norm(), 1e-14);
    EXPECT_LT((back.R_BP - X_BP.R_BP).norm(), 1e-14);
  }
}

TEST(UserFrames, DisplacementRotatesAboutThePivot) {
  const RigParams rig = MakeReferenceRig();
  UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(0, 0, 0.3);
  frames.X_BW.R_BP = RotationFromRollPitchYaw(Eigen::Vector3d(0, 0, 45 * kDeg));
  Vector6d d = Vector6d::Zero();
  d[3] = 5 * kDeg;  // roll about the work frame's x
  const Pose X = PlatformPoseFromDisplacement(HomePose(rig), d, frames);
  EXPECT_LT((PivotPose(X, frames.p_PC_P_m).p_BP_B_m -
             PivotPose(HomePose(rig), frames.p_PC_P_m).p_BP_B_m).norm(), 1e-15);
  const Eigen::AngleAxisd aa(X.R_BP);
  EXPECT_NEAR(aa.angle(), 5 * kDeg, 1e-12);
  EXPECT_LT((aa.axis() - Eigen::Vector3d(std::sqrt(0.5), std::sqrt(0.5), 0)).norm(), 1e-12);
  d.setZero();
  d[0] = 0.01;
  const Pose moved = PlatformPoseFromDisplacement(HomePose(rig), d, frames);
  EXPECT_NEAR(moved.p_BP_B_m.x(), 0.01 * std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(moved.p_BP_B_m.y(), 0.01 * std::sqrt(0.5), 1e-15);
}

TEST(UserFrames, ValidateRefusesAFarPivotAndABadRotation) {
  UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(10.0, 0.0, 0.0);
  try {
    frames.Validate();
    FAIL() << "a pivot 10 m away was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("frames.p_PC_P_m"), std::string::npos) << what;
    EXPECT_NE(what.find("value 10 m"), std::string::npos) << what;
    EXPECT_NE(what.find("<= 0.5 m"), std::string::npos) << what;
  }
  frames = UserFramesConfig{};
  frames.X_BW.R_BP(0, 0) = 1.1;
  EXPECT_THROW(frames.Validate(), std::invalid_argument);
  frames = UserFramesConfig{};
  frames.X_PT.p_BP_B_m.y() = std::nan("");
  EXPECT_THROW(frames.Validate(), std::invalid_argument);
  EXPECT_NO_THROW(UserFramesConfig{}.Validate());
}

TEST(UserFrames, NonUnitQuaternionIsRefused) {
  Eigen::Matrix3d R;
  EXPECT_FALSE(RotationFromUnitQuaternion(1.0, 0.1, 0.0, 0.0, R));
  EXPECT_FALSE(RotationFromUnitQuaternion(std::nan(""), 0.0, 0.0, 0.0, R));
  EXPECT_FALSE(RotationFromUnitQuaternion(0.0, 0.0, 0.0, 0.0, R));
  ASSERT_TRUE(RotationFromUnitQuaternion(std::cos(0.1), 0.0, 0.0, std::sin(0.1), R));
  EXPECT_NEAR(RollPitchYawFromRotation(R).z(), 0.2, 1e-15);
}

}  // namespace
}  // namespace hexa
