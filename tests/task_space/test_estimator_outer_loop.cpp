// Pose estimator (IMU orientation + GQFK eq 47 / six-leg least squares) and the Jacobian
// outer loop (eq 48) in a pure kinematic loop with a calibration error the controller does
// not know.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/outer_loop.hpp"
#include "hexa/core/pose_estimator.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {
namespace {

std::array<double, 4> Quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.w(), q.x(), q.y(), q.z()};
}

std::vector<Vector6d> TestPoses(const RigParams& rig) {
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  std::vector<Vector6d> poses{home};
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 50; ++k) {
    Vector6d q = home;
    for (int j = 0; j < 3; ++j) q[j] += 0.07 * u(rng);
    for (int j = 3; j < 6; ++j) q[j] += 0.2 * u(rng);
    poses.push_back(q);
  }
  return poses;
}

TEST(PoseEstimator, ReturnsTheTruePoseWithExactInputs) {
  const RigParams rig = MakeReferenceRig();
  for (bool lsq : {false, true}) {
    PoseEstimatorConfig config;
    config.least_squares = lsq;
    const PoseEstimator estimator(rig.geometry, config);
    for (const Vector6d& q : TestPoses(rig)) {
      const Pose truth = PoseFromVector(q);
      PoseEstimatorInput in;
      InverseKinematics(rig.geometry, truth, in.length_m);
      in.orientation_wxyz = Quat(truth.R_BP);
      PoseEstimatorOutput out;
      estimator.Update(in, out);
      ASSERT_EQ(out.status, KinStatus::kOk) << (lsq ? "lsq" : "gqfk");
      EXPECT_LT((out.pose.p_BP_B_m - truth.p_BP_B_m).norm(), 1e-9) << (lsq ? "lsq" : "gqfk");
      EXPECT_LT((out.pose.R_BP - truth.R_BP).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_LT((out.xyz_rpy - q).cwiseAbs().maxCoeff(), 1e-9);
      if (lsq) {
        EXPECT_EQ(out.excluded_leg, -1);
      }
    }
  }
}

TEST(PoseEstimator, LeastSquaresToleratesOneBadLegGqfkDoesNot) {
  const RigParams rig = MakeReferenceRig();
  const Pose truth = PoseFromVector(TestPoses(rig)[3]);
  PoseEstimatorInput in;
  InverseKinematics(rig.geometry, truth, in.length_m);
  in.orientation_wxyz = Quat(truth.R_BP);
  in.length_m[2] += 0.02;  // leg 3 (used by GQFK) reads 20 mm long
  PoseEstimatorConfig config;
  PoseEstimatorOutput gqfk, lsq;
  PoseEstimator(rig.geometry, config).Update(in, gqfk);
  config.least_squares = true;
  PoseEstimator(rig.geometry, config).Update(in, lsq);
  ASSERT_EQ(lsq.status, KinStatus::kOk);
  EXPECT_EQ(lsq.excluded_leg, 2);
  EXPECT_LT((lsq.pose.p_BP_B_m - truth.p_BP_B_m).norm(), 1e-6);
  ASSERT_EQ(gqfk.status, KinStatus::kOk);
  EXPECT_GT((gqfk.pose.p_BP_B_m - truth.p_BP_B_m).norm(), 5e-3);
}

TEST(PoseEstimator, InvalidImuQuaternionIsReported) {
  const RigParams rig = MakeReferenceRig();
  const PoseEstimator estimator(rig.geometry, PoseEstimatorConfig{});
  PoseEstimatorInput in;
  InverseKinematics(rig.geometry, PoseFromVector(HomePoseVector(rig.geometry.home_position_m)),
                    in.length_m);
  PoseEstimatorOutput out;
  in.orientation_wxyz = {0.5, 0.0, 0.0, 0.0};
  estimator.Update(in, out);
  EXPECT_EQ(out.status, KinStatus::kInvalidInput);
  in.orientation_wxyz = {NAN, 0.0, 0.0, 0.0};
  estimator.Update(in, out);
  EXPECT_EQ(out.status, KinStatus::kInvalidInput);
}

TEST(OuterLoop, MapsAPoseErrorToTheLegLengthChangeAndSaturates) {
  const RigParams rig = MakeReferenceRig();
  OuterLoopParams params;
  params.gain = 1.0;
  params.max_correction_m = 0.005;
  OuterLoop loop(rig.geometry, params);
  const Pose desired = PoseFromVector(HomePoseVector(rig.geometry.home_position_m));
  Pose estimated = desired;
  estimated.p_BP_B_m.z() -= 0.001;  // platform 1 mm low -> every leg must lengthen
  OuterLoopOutput out;
  loop.Update({desired, estimated, true, false}, out);
  LegArray<double> l_d{}, l_e{};
  InverseKinematics(rig.geometry, desired, l_d);
  InverseKinematics(rig.geometry, estimated, l_e);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_GT(out.correction_m[i], 0.0);
    EXPECT_NEAR(out.mapped_error_m[i], l_d[i] - l_e[i], 1e-6);  // J e = first-order dl
  }
  for (int k = 0; k < 20; ++k) loop.Update({desired, estimated, true, false}, out);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_DOUBLE_EQ(out.correction_m[i], 0.005);
    EXPECT_TRUE(out.saturated[i]);
  }
  const LegArray<double> before = out.correction_m;
  loop.Update({desired, estimated, true, true}, out);  // freeze
  EXPECT_EQ(out.correction_m, before);
  loop.Update({desired, estimated, false, false}, out);  // invalid estimate
  EXPECT_EQ(out.correction_m, before);
}

// Speed gate: the integration step is gain / (1 + (v / v0)^2) of the mapped
// error, v = the largest desired leg speed; v0 = 0 leaves the paper's constant gain.
TEST(OuterLoop, SpeedGateScalesTheIntegrationStepWithTheLegSpeed) {
  const RigParams rig = MakeReferenceRig();
  const Pose desired = PoseFromVector(HomePoseVector(rig.geometry.home_position_m));
  Pose estimated = desired;
  estimated.p_BP_B_m.z() -= 0.001;
  auto first_step = [&](double gate_m_s, double leg_speed_m_s) {
    OuterLoopParams params;
    params.gain = 0.2;
    params.gate_leg_speed_m_s = gate_m_s;
    OuterLoop loop(rig.geometry, params);
    OuterLoopInput in{desired, estimated, true, false};
    in.max_leg_speed_m_s = leg_speed_m_s;
    OuterLoopOutput out;
    loop.Update(in, out);
    return out;
  };
  const OuterLoopOutput ungated = first_step(0.0, 0.5);
  const OuterLoopOutput at_rest = first_step(0.05, 0.0);
  const OuterLoopOutput at_gate = first_step(0.05, 0.05);
  const OuterLoopOutput fast = first_step(0.05, 0.5);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double full = 0.2 * ungated.mapped_error_m[i];
    ASSERT_GT(std::abs(full), 1e-5);
    EXPECT_NEAR(ungated.correction_m[i], full, 1e-15);
    EXPECT_NEAR(at_rest.correction_m[i], full, 1e-15);
    EXPECT_NEAR(at_gate.correction_m[i], 0.5 * full, 1e-15);
    EXPECT_NEAR(fast.correction_m[i], full / 101.0, 1e-15);
  }
}

// Pure kinematic loop: the true base joints are off by up to 2 mm (fixed seed); the legs
// reach exactly the commanded lengths IK_nominal(desired) + correction; the true pose is
// the forward kinematics of the true geometry; the IMU reads the true orientation; the
// estimate uses the nominal geometry.
struct KinematicLoopResult {
  double initial_estimated_error = 0.0, final_estimated_error = 0.0;
  double initial_true_rotation_error = 0.0, final_true_rotation_error = 0.0;
  double initial_true_position_error = 0.0, final_true_position_error = 0.0;
  LegArray<double> correction_m{};
};

KinematicLoopResult RunKinematicLoop(bool enabled, bool least_squares, const Vector6d& q_desired) {
  const RigParams rig = MakeReferenceRig();
  GeometryParams truth = rig.geometry;
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& a : truth.p_BA_B) {
    Eigen::Vector3d d(u(rng), u(rng), u(rng));
    a += 0.002 / std::sqrt(3.0) * d;  // |offset| <= 2 mm
  }
  OuterLoopParams params;
  params.enabled = enabled;
  OuterLoop loop(rig.geometry, params);
  PoseEstimatorConfig config;
  config.least_squares = least_squares;
  const PoseEstimator estimator(rig.geometry, config);
  const Pose desired = PoseFromVector(q_desired);
  LegArray<double> l_nominal{};
  InverseKinematics(rig.geometry, desired, l_nominal);
  Pose true_pose = desired;
  KinematicLoopResult result;
  OuterLoopOutput out;
  for (int step = 0; step < 200; ++step) {
    LegArray<double> l_cmd{};
    for (std::size_t i = 0; i < kNumLegs; ++i) l_cmd[i] = l_nominal[i] + loop.correction_m()[i];
    NewtonFkResult fk;
    EXPECT_EQ(NewtonRaphsonFk(truth, l_cmd, true_pose, NewtonFkConfig{}, fk), KinStatus::kOk);
    true_pose = fk.pose;
    PoseEstimatorInput in;
    in.length_m = l_cmd;  // exact potentiometers
    in.orientation_wxyz = Quat(true_pose.R_BP);
    PoseEstimatorOutput est;
    estimator.Update(in, est);
    EXPECT_EQ(est.status, KinStatus::kOk);
    loop.Update({desired, est.pose, true, false}, out);
    const double estimated_error = out.error.norm();
    const double true_rot = PoseError(desired, true_pose).tail<3>().norm();
    const double true_pos = PoseError(desired, true_pose).head<3>().norm();
    if (step == 0) {
      result.initial_estimated_error = estimated_error;
      result.initial_true_rotation_error = true_rot;
      result.initial_true_position_error = true_pos;
    }
    result.final_true_position_error = true_pos;
    result.final_estimated_error = estimated_error;
    result.final_true_rotation_error = true_rot;
  }
  result.correction_m = loop.correction_m();
  return result;
}

class KinematicCalibrationLoop : public ::testing::TestWithParam<bool> {};

TEST_P(KinematicCalibrationLoop, OuterLoopDrivesTheEstimatedErrorToZero) {
  const RigParams rig = MakeReferenceRig();
  Vector6d off_home = HomePoseVector(rig.geometry.home_position_m);
  off_home += (Vector6d() << 0.03, -0.02, 0.04, 0.1, -0.05, 0.15).finished();
  for (const Vector6d& q : std::vector<Vector6d>{HomePoseVector(rig.geometry.home_position_m), off_home}) {
    const KinematicLoopResult on = RunKinematicLoop(true, GetParam(), q);
    const KinematicLoopResult off = RunKinematicLoop(false, GetParam(), q);
    // The calibration error is visible to the estimator...
    EXPECT_GT(on.initial_estimated_error, 5e-4);
    // ...stays with the loop off, and is removed with it on.
    EXPECT_NEAR(off.final_estimated_error, off.initial_estimated_error, 1e-12);
    EXPECT_LT(on.final_estimated_error, 1e-3 * on.initial_estimated_error);
    // The IMU sees the true orientation, so the true orientation error goes too.
    EXPECT_GT(on.initial_true_rotation_error, 1e-4);
    EXPECT_LT(on.final_true_rotation_error, 1e-3 * on.initial_true_rotation_error);
    for (double c : on.correction_m) EXPECT_LT(std::abs(c), 0.005);
    // Not asserted: the position part of a base-joint error is not observable from the
    // lengths and the IMU alone (docs/task_space.md); reported for the record.
    std::printf("%s: estimated error %.3g -> %.3g, true rotation error %.3g -> %.3g rad, "
                "true position error %.3g -> %.3g m\n",
                GetParam() ? "lsq " : "gqfk", on.initial_estimated_error,
                on.final_estimated_error, on.initial_true_rotation_error,
                on.final_true_rotation_error, on.initial_true_position_error,
                on.final_true_position_error);
  }
}

INSTANTIATE_TEST_SUITE_P(Estimators, KinematicCalibrationLoop, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return std::string(info.param ? "LeastSquares" : "Gqfk");
                         });

}  // namespace
}  // namespace hexa
