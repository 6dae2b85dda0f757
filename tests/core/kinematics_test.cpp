// Kinematics of the reference rig (eq 46-48): known values, round trips and fixed-seed
// randomized properties over the workspace of docs/design.md (x, y +-8 cm, z 0.45 +-8 cm,
// rotations +-15 deg, every leg inside its stroke).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"
#include "uniform_sampler.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr int kNumRandomPoses = 100000;

using Sampler = test::UniformSampler;

struct Sample {
  Pose pose;
  LegArray<double> length_m;
};

bool InsideStroke(const CylinderParams& cylinder, const LegArray<double>& length_m) {
  for (double l : length_m) {
    if (std::abs(l - cylinder.mid_stroke_length_m) > 0.5 * cylinder.stroke_m) return false;
  }
  return true;
}

// kNumRandomPoses poses of the workspace whose legs are all inside the stroke; fixed seed.
const std::vector<Sample>& WorkspaceSamples() {
  static const std::vector<Sample> samples = [] {
    const RigParams rig = MakeReferenceRig();
    Sampler sampler(20240611u);
    std::vector<Sample> out;
    out.reserve(kNumRandomPoses);
    while (static_cast<int>(out.size()) < kNumRandomPoses) {
      Vector6d v;
      v << sampler.Uniform(-0.08, 0.08), sampler.Uniform(-0.08, 0.08),
          0.45 + sampler.Uniform(-0.08, 0.08), sampler.Uniform(-15 * kDeg, 15 * kDeg),
          sampler.Uniform(-15 * kDeg, 15 * kDeg), sampler.Uniform(-15 * kDeg, 15 * kDeg);
      Sample s;
      s.pose = PoseFromVector(v);
      InverseKinematics(rig.geometry, s.pose, s.length_m);
      if (InsideStroke(rig.cylinder, s.length_m)) out.push_back(s);
    }
    return out;
  }();
  return samples;
}

double RotationErrorRad(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b) {
  Pose a, b;
  a.R_BP = R_a;
  b.R_BP = R_b;
  return PoseError(a, b).tail<3>().norm();
}

Pose HomePose(const RigParams& rig) {
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  return home;
}

// ---------------------------------------------------------------------------------------
// Known values

TEST(Kinematics, HomePoseGivesDesignLegLengthAndInclination) {
  const RigParams rig = MakeReferenceRig();
  LegArray<double> length_m;
  LegArray<Eigen::Vector3d> unit_B;
  InverseKinematics(rig.geometry, HomePose(rig), length_m, &unit_B);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    // docs/design.md quotes 0.5034 m (4 digits) and "about 27 deg from vertical".
    EXPECT_NEAR(length_m[i], 0.5034, 5e-5) << "leg " << i;
    EXPECT_NEAR(length_m[i], rig.cylinder.mid_stroke_length_m, 5e-5) << "leg " << i;
    EXPECT_NEAR(unit_B[i].norm(), 1.0, 1e-15);
    const double inclination_deg = std::acos(unit_B[i].z()) / kDeg;
    EXPECT_GT(inclination_deg, 26.0);
    EXPECT_LT(inclination_deg, 28.0);
  }
  // The rig is 3-fold symmetric at home: all legs have the same length to round-off.
  for (std::size_t i = 1; i < kNumLegs; ++i) EXPECT_NEAR(length_m[i], length_m[0], 1e-14);
}

TEST(Kinematics, PureVerticalMotionChangesEveryLegByTheSameAmount) {
  const RigParams rig = MakeReferenceRig();
  Pose up = HomePose(rig);
  up.p_BP_B_m.z() += 0.08;
  LegArray<double> home_m, up_m;
  InverseKinematics(rig.geometry, HomePose(rig), home_m);
  InverseKinematics(rig.geometry, up, up_m);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_NEAR(up_m[i] - home_m[i], up_m[0] - home_m[0], 1e-14);
    // docs/design.md: the pure z trajectory (+-8 cm) moves the legs by about 73 mm.
    EXPECT_NEAR(up_m[i] - home_m[i], 0.073, 0.001);
  }
}

// ---------------------------------------------------------------------------------------
// Rotation convention and pose helpers

TEST(Pose, RollPitchYawAreFixedAxisRotationsXThenYThenZ) {
  const double roll = 0.3, pitch = -0.2, yaw = 0.7;
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d Ry = Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_LT((RotationFromRollPitchYaw({roll, 0, 0}) - Rx).norm(), 1e-15);
  EXPECT_LT((RotationFromRollPitchYaw({0, pitch, 0}) - Ry).norm(), 1e-15);
  EXPECT_LT((RotationFromRollPitchYaw({0, 0, yaw}) - Rz).norm(), 1e-15);
  EXPECT_LT((RotationFromRollPitchYaw({roll, pitch, yaw}) - Rz * Ry * Rx).norm(), 1e-15);
  // A positive roll turns the platform's y axis toward +z (right-handed).
  EXPECT_GT((RotationFromRollPitchYaw({0.1, 0, 0}) * Eigen::Vector3d::UnitY()).z(), 0.0);
}

TEST(Pose, RotationHelpersRoundTrip) {
  Sampler sampler(7u);
  for (int n = 0; n < 10000; ++n) {
    const Eigen::Vector3d rpy(sampler.Uniform(-kPi, kPi), sampler.Uniform(-1.5, 1.5),
                              sampler.Uniform(-kPi, kPi));
    const Eigen::Matrix3d R = RotationFromRollPitchYaw(rpy);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
    const Eigen::Vector3d back = RollPitchYawFromRotation(R);
    ASSERT_LT((back - rpy).cwiseAbs().maxCoeff(), 1e-12) << rpy.transpose();
    Vector6d v;
    v << sampler.Uniform(-1, 1), sampler.Uniform(-1, 1), sampler.Uniform(-1, 1), rpy;
    ASSERT_LT((VectorFromPose(PoseFromVector(v)) - v).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(Pose, PoseErrorIsTranslationAndRotationVectorInBase) {
  Sampler sampler(11u);
  for (double angle_rad : {1e-10, 1e-4, 0.3, 2.0, 3.1}) {
    for (int n = 0; n < 100; ++n) {
      Eigen::Vector3d axis(sampler.Uniform(-1, 1), sampler.Uniform(-1, 1),
                           sampler.Uniform(-1, 1));
      axis.normalize();
      const Vector6d v(
          (Vector6d() << 0.01, -0.02, 0.4, sampler.Uniform(-1, 1), sampler.Uniform(-1, 1),
           sampler.Uniform(-1, 1))
              .finished());
      const Pose actual = PoseFromVector(v);
      Pose desired = actual;
      desired.p_BP_B_m += Eigen::Vector3d(0.001, -0.002, 0.003);
      // Rotation applied on the left = about an axis fixed in B.
      desired.R_BP = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix() * actual.R_BP;
      const Vector6d e = PoseError(desired, actual);
      EXPECT_LT((e.head<3>() - Eigen::Vector3d(0.001, -0.002, 0.003)).norm(), 1e-15);
      EXPECT_LT((e.tail<3>() - angle_rad * axis).norm(), 1e-12 + 1e-12 * angle_rad)
          << "angle " << angle_rad;
      EXPECT_LT(PoseError(actual, actual).norm(), 1e-15);
    }
  }
}

// ---------------------------------------------------------------------------------------
// Jacobian (eq 48)

// Central differences of IK, the pose perturbed by a translation in B or a rotation about a
// B axis (R <- Exp(h e_k) R, the convention of the twist [v; w] in B). With h = 1e-6 m/rad
// the truncation error is O(h^2 * d3l) ~ 1e-12 and the round-off error about
// eps * l / h ~ 1e-16 * 0.5 / 1e-6 ~ 1e-10, so 1e-8 is a tolerance a wrong column (an
// error of order 0.1) or a frame mix-up (b_i in P instead of B) cannot meet.
TEST(Kinematics, JacobianMatchesCentralDifferencesOfInverseKinematics) {
  const RigParams rig = MakeReferenceRig();
  const auto& samples = WorkspaceSamples();
  constexpr double kStep = 1e-6;
  constexpr double kTolerance = 1e-8;
  double worst = 0.0;
  for (std::size_t n = 0; n < samples.size(); n += 100) {  // 1000 poses
    const Pose& pose = samples[n].pose;
    Matrix6d J;
    LegJacobian(rig.geometry, pose, J);
    for (int k = 0; k < 6; ++k) {
      Pose plus = pose, minus = pose;
      if (k < 3) {
        plus.p_BP_B_m[k] += kStep;
        minus.p_BP_B_m[k] -= kStep;
      } else {
        const Eigen::Vector3d axis = Eigen::Vector3d::Unit(k - 3);
        plus.R_BP = Eigen::AngleAxisd(kStep, axis).toRotationMatrix() * pose.R_BP;
        minus.R_BP = Eigen::AngleAxisd(-kStep, axis).toRotationMatrix() * pose.R_BP;
      }
      LegArray<double> l_plus, l_minus;
      InverseKinematics(rig.geometry, plus, l_plus);
      InverseKinematics(rig.geometry, minus, l_minus);
      for (int i = 0; i < 6; ++i) {
        const double fd = (l_plus[i] - l_minus[i]) / (2.0 * kStep);
        worst = std::max(worst, std::abs(fd - J(i, k)));
      }
    }
  }
  EXPECT_LT(worst, kTolerance);
}

// The outer loop (Sec. 4.1) maps PoseError through J to leg corrections; to first order
// this must equal the IK difference, with a remainder quadratic in the error.
TEST(Kinematics, JacobianTimesPoseErrorPredictsLegLengthChange) {
  const RigParams rig = MakeReferenceRig();
  const auto& samples = WorkspaceSamples();
  Sampler sampler(3u);
  for (std::size_t n = 0; n < samples.size(); n += 1000) {
    const Pose& actual = samples[n].pose;
    Vector6d delta;
    for (int k = 0; k < 6; ++k) delta[k] = sampler.Uniform(-1e-3, 1e-3);
    Pose desired = actual;
    desired.p_BP_B_m += delta.head<3>();
    desired.R_BP = Eigen::AngleAxisd(delta.tail<3>().norm(), delta.tail<3>().normalized())
                       .toRotationMatrix() *
                   actual.R_BP;
    Matrix6d J;
    LegJacobian(rig.geometry, actual, J);
    LegArray<double> l_d, l_a;
    InverseKinematics(rig.geometry, desired, l_d);
    InverseKinematics(rig.geometry, actual, l_a);
    const Vector6d predicted = J * PoseError(desired, actual);
    for (int i = 0; i < 6; ++i) {
      // |delta| <= 1.7e-3; second-order remainder ~ |delta|^2 / l ~ 1e-5 m at most.
      EXPECT_NEAR(predicted[i], l_d[i] - l_a[i], 2e-5);
    }
  }
}

// ---------------------------------------------------------------------------------------
// Forward kinematics on 100,000 workspace poses

TEST(Kinematics, WorkspaceSampleIsLargeAndInsideTheStroke) {
  const RigParams rig = MakeReferenceRig();
  const auto& samples = WorkspaceSamples();
  ASSERT_EQ(static_cast<int>(samples.size()), kNumRandomPoses);
  for (const Sample& s : samples) ASSERT_TRUE(InsideStroke(rig.cylinder, s.length_m));
}

TEST(Kinematics, NewtonRaphsonFkFromHomeRecoversEveryWorkspacePose) {
  const RigParams rig = MakeReferenceRig();
  const Pose home = HomePose(rig);
  double worst_position_m = 0.0, worst_rotation_rad = 0.0;
  int worst_iterations = 0;
  for (const Sample& s : WorkspaceSamples()) {
    NewtonFkResult result;
    const KinStatus status = NewtonRaphsonFk(rig.geometry, s.length_m, home, {}, result);
    ASSERT_EQ(status, KinStatus::kOk) << ToString(status);
    worst_position_m = std::max(worst_position_m, (result.pose.p_BP_B_m - s.pose.p_BP_B_m).norm());
    worst_rotation_rad = std::max(worst_rotation_rad, RotationErrorRad(result.pose.R_BP, s.pose.R_BP));
    worst_iterations = std::max(worst_iterations, result.iterations);
  }
  EXPECT_LT(worst_position_m, 1e-9);
  EXPECT_LT(worst_rotation_rad, 1e-9);
  char text[64];
  std::snprintf(text, sizeof text, "%.3g", worst_position_m);
  RecordProperty("worst_position_m", text);
  std::snprintf(text, sizeof text, "%.3g", worst_rotation_rad);
  RecordProperty("worst_rotation_rad", text);
  RecordProperty("worst_iterations", worst_iterations);
}

TEST(Kinematics, NewtonRaphsonFkWarmStartNeedsFewIterations) {
  const RigParams rig = MakeReferenceRig();
  // Consecutive 5 ms samples of the combined trajectory (eq 49): x = 8 sin, y = 8 cos,
  // z = 8 sin cm at 1 Hz, warm-started from the previous solution.
  Pose previous = PoseFromVector((Vector6d() << 0, 0.08, 0.45, 0, 0, 0).finished());
  for (int k = 1; k <= 200; ++k) {
    const double t_s = 0.005 * k;
    const double s = std::sin(2 * kPi * t_s), c = std::cos(2 * kPi * t_s);
    const Pose truth = PoseFromVector((Vector6d() << 0.08 * s, 0.08 * c, 0.45 + 0.08 * s, 0, 0, 0).finished());
    LegArray<double> length_m;
    InverseKinematics(rig.geometry, truth, length_m);
    NewtonFkResult result;
    ASSERT_EQ(NewtonRaphsonFk(rig.geometry, length_m, previous, {}, result), KinStatus::kOk);
    EXPECT_LE(result.iterations, 4);
    EXPECT_LT(PoseError(truth, result.pose).norm(), 1e-12);
    previous = result.pose;
  }
}

TEST(Kinematics, GqfkWithExactRotationRecoversPosition) {
  const RigParams rig = MakeReferenceRig();
  const std::array<std::array<int, 3>, 2> triples{kGqfkDefaultLegs, std::array<int, 3>{1, 3, 5}};
  for (const auto& legs : triples) {
    double worst_m = 0.0;
    for (const Sample& s : WorkspaceSamples()) {
      Eigen::Vector3d p;
      ASSERT_EQ(GqfkPosition(rig.geometry, s.pose.R_BP, s.length_m, legs, p), KinStatus::kOk);
      worst_m = std::max(worst_m, (p - s.pose.p_BP_B_m).norm());
    }
    EXPECT_LT(worst_m, 1e-9) << "legs " << legs[0] << legs[1] << legs[2];
  }
}

TEST(Kinematics, GqfkLeastSquaresIsExactWithConsistentLengths) {
  const RigParams rig = MakeReferenceRig();
  double worst_m = 0.0;
  for (const Sample& s : WorkspaceSamples()) {
    GqfkLsqResult result;
    ASSERT_EQ(GqfkLeastSquares(rig.geometry, s.pose.R_BP, s.length_m, 0.005, result),
              KinStatus::kOk);
    ASSERT_EQ(result.excluded_leg, -1);
    worst_m = std::max(worst_m, (result.p_BP_B_m - s.pose.p_BP_B_m).norm());
  }
  EXPECT_LT(worst_m, 1e-9);
}

// One potentiometer off by 5 cm (either sign), cycling through every leg index: the
// position stays within 1 mm and the faulty leg is named.
TEST(Kinematics, GqfkLeastSquaresExcludesOneBadLeg) {
  const RigParams rig = MakeReferenceRig();
  const auto& samples = WorkspaceSamples();
  double worst_m = 0.0;
  std::array<int, kNumLegs> named{};
  for (std::size_t n = 0; n < samples.size(); ++n) {
    const int bad_leg = static_cast<int>(n % kNumLegs);
    const double error_m = ((n / kNumLegs) % 2 == 0) ? 0.05 : -0.05;
    LegArray<double> length_m = samples[n].length_m;
    length_m[bad_leg] += error_m;
    GqfkLsqResult result;
    ASSERT_EQ(GqfkLeastSquares(rig.geometry, samples[n].pose.R_BP, length_m, 0.005, result),
              KinStatus::kOk) << "sample " << n;
    ASSERT_EQ(result.excluded_leg, bad_leg) << "sample " << n;
    ++named[bad_leg];
    EXPECT_NEAR(result.residual_m[bad_leg], error_m, 1e-9);
    worst_m = std::max(worst_m, (result.p_BP_B_m - samples[n].pose.p_BP_B_m).norm());
  }
  EXPECT_LT(worst_m, 1e-3);
  char text[64];
  std::snprintf(text, sizeof text, "%.3g", worst_m);
  RecordProperty("worst_position_m", text);
  for (int count : named) EXPECT_GT(count, kNumRandomPoses / 7);
}

// Two bad legs cannot be explained by excluding one: the solver must not claim success.
TEST(Kinematics, GqfkLeastSquaresReportsTwoBadLegs) {
  const RigParams rig = MakeReferenceRig();
  const auto& samples = WorkspaceSamples();
  for (std::size_t n = 0; n < samples.size(); n += 100) {
    LegArray<double> length_m = samples[n].length_m;
    const int first = static_cast<int>(n % kNumLegs);
    length_m[first] += 0.05;
    length_m[(first + 3) % kNumLegs] -= 0.05;
    GqfkLsqResult result;
    EXPECT_NE(GqfkLeastSquares(rig.geometry, samples[n].pose.R_BP, length_m, 0.005, result),
              KinStatus::kOk) << "sample " << n;
    EXPECT_TRUE(result.p_BP_B_m.allFinite());
  }
}

// ---------------------------------------------------------------------------------------
// Invalid inputs: a status, never NaN

TEST(Kinematics, InvalidLengthsGiveStatusAndFiniteOutputs) {
  const RigParams rig = MakeReferenceRig();
  const Pose home = HomePose(rig);
  LegArray<double> good_m;
  InverseKinematics(rig.geometry, home, good_m);
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  const double kInf = std::numeric_limits<double>::infinity();
  for (double bad : {kNaN, kInf, -0.5, 0.0}) {
    for (std::size_t leg = 0; leg < kNumLegs; ++leg) {
      LegArray<double> length_m = good_m;
      length_m[leg] = bad;
      Eigen::Vector3d p;
      const bool in_default_triple = leg % 2 == 0;
      const KinStatus gqfk = GqfkPosition(rig.geometry, home.R_BP, length_m, kGqfkDefaultLegs, p);
      EXPECT_EQ(gqfk, in_default_triple ? KinStatus::kInvalidInput : KinStatus::kOk);
      EXPECT_TRUE(p.allFinite());
      GqfkLsqResult lsq;
      EXPECT_EQ(GqfkLeastSquares(rig.geometry, home.R_BP, length_m, 0.005, lsq),
                KinStatus::kInvalidInput);
      EXPECT_TRUE(lsq.p_BP_B_m.allFinite());
      NewtonFkResult nr;
      EXPECT_EQ(NewtonRaphsonFk(rig.geometry, length_m, home, {}, nr), KinStatus::kInvalidInput);
      EXPECT_TRUE(nr.pose.p_BP_B_m.allFinite());
      EXPECT_TRUE(nr.pose.R_BP.allFinite());
    }
  }
}

// Legs of 0.1 m: no pose exists, since platform joints 1 and 2 are 0.383 m apart while
// base joints 1 and 2 are 0.122 m apart (triangle inequality needs l1 + l2 >= 0.26 m).
// Leg 1 of 5 m with all others nominal: one sphere far outside the others.
TEST(Kinematics, ImpossibleLengthsGiveStatusAndFiniteOutputs) {
  const RigParams rig = MakeReferenceRig();
  const Pose home = HomePose(rig);
  LegArray<double> short_m;
  short_m.fill(0.1);
  LegArray<double> one_long_m;
  InverseKinematics(rig.geometry, home, one_long_m);
  one_long_m[0] = 5.0;
  for (const auto& length_m : {short_m, one_long_m}) {
    Eigen::Vector3d p;
    EXPECT_NE(GqfkPosition(rig.geometry, home.R_BP, length_m, kGqfkDefaultLegs, p),
              KinStatus::kOk);
    EXPECT_TRUE(p.allFinite());
    GqfkLsqResult lsq;
    const KinStatus lsq_status = GqfkLeastSquares(rig.geometry, home.R_BP, length_m, 0.005, lsq);
    if (length_m[1] == 0.1) {
      EXPECT_NE(lsq_status, KinStatus::kOk);
    } else {
      // One impossible leg is exactly the fault the six-leg variant tolerates: it is named
      // and the other five give the home position.
      EXPECT_EQ(lsq_status, KinStatus::kOk);
      EXPECT_EQ(lsq.excluded_leg, 0);
      EXPECT_LT((lsq.p_BP_B_m - home.p_BP_B_m).norm(), 1e-9);
    }
    EXPECT_TRUE(lsq.p_BP_B_m.allFinite());
    for (double r : lsq.residual_m) EXPECT_TRUE(std::isfinite(r));
    NewtonFkResult nr;
    EXPECT_NE(NewtonRaphsonFk(rig.geometry, length_m, home, {}, nr), KinStatus::kOk);
    EXPECT_TRUE(nr.pose.p_BP_B_m.allFinite());
    EXPECT_TRUE(nr.pose.R_BP.allFinite());
    EXPECT_TRUE(std::isfinite(nr.max_residual_m));
    EXPECT_GT(nr.max_residual_m, 1e-3);
  }
}

TEST(Kinematics, InvalidRotationLegTripleOrGuessIsRejected) {
  const RigParams rig = MakeReferenceRig();
  const Pose home = HomePose(rig);
  LegArray<double> length_m;
  InverseKinematics(rig.geometry, home, length_m);
  Eigen::Matrix3d nan_R = Eigen::Matrix3d::Identity();
  nan_R(1, 2) = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Matrix3d scaled_R = 1.01 * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d reflected_R = Eigen::Vector3d(1, 1, -1).asDiagonal();
  for (const Eigen::Matrix3d& R : {nan_R, scaled_R, reflected_R}) {
    Eigen::Vector3d p;
    EXPECT_EQ(GqfkPosition(rig.geometry, R, length_m, kGqfkDefaultLegs, p),
              KinStatus::kInvalidInput);
    EXPECT_TRUE(p.allFinite());
    GqfkLsqResult lsq;
    EXPECT_EQ(GqfkLeastSquares(rig.geometry, R, length_m, 0.005, lsq), KinStatus::kInvalidInput);
    Pose guess = home;
    guess.R_BP = R;
    NewtonFkResult nr;
    EXPECT_EQ(NewtonRaphsonFk(rig.geometry, length_m, guess, {}, nr), KinStatus::kInvalidInput);
    EXPECT_TRUE(nr.pose.R_BP.allFinite());
  }
  Eigen::Vector3d p;
  for (const std::array<int, 3>& legs :
       {std::array<int, 3>{0, 0, 2}, std::array<int, 3>{0, 2, 6}, std::array<int, 3>{-1, 2, 4}}) {
    EXPECT_EQ(GqfkPosition(rig.geometry, home.R_BP, length_m, legs, p), KinStatus::kInvalidInput);
  }
  GqfkLsqResult lsq;
  EXPECT_EQ(GqfkLeastSquares(rig.geometry, home.R_BP, length_m, 0.0, lsq),
            KinStatus::kInvalidInput);
  Pose nan_guess = home;
  nan_guess.p_BP_B_m.x() = std::numeric_limits<double>::quiet_NaN();
  NewtonFkResult nr;
  EXPECT_EQ(NewtonRaphsonFk(rig.geometry, length_m, nan_guess, {}, nr), KinStatus::kInvalidInput);
  EXPECT_TRUE(nr.pose.p_BP_B_m.allFinite());
}

TEST(Kinematics, GqfkReportsCollinearCentresAsDegenerate) {
  // A made-up geometry whose three sphere centres lie on a line.
  GeometryParams geometry = MakeReferenceRig().geometry;
  geometry.p_BA_B[0] = {0.0, 0.0, 0.0};
  geometry.p_BA_B[2] = {0.1, 0.0, 0.0};
  geometry.p_BA_B[4] = {0.2, 0.0, 0.0};
  for (int i : {0, 2, 4}) geometry.p_PB_P[i].setZero();
  LegArray<double> length_m;
  length_m.fill(0.5);
  Eigen::Vector3d p;
  EXPECT_EQ(GqfkPosition(geometry, Eigen::Matrix3d::Identity(), length_m, kGqfkDefaultLegs, p),
            KinStatus::kDegenerate);
  EXPECT_TRUE(p.allFinite());
}

TEST(Kinematics, StatusNamesAreDistinct) {
  std::set<std::string> names;
  for (KinStatus s : {KinStatus::kOk, KinStatus::kInvalidInput, KinStatus::kUnreachable,
                      KinStatus::kDegenerate, KinStatus::kNotConverged}) {
    names.insert(ToString(s));
  }
  EXPECT_EQ(names.size(), 5u);
}

}  // namespace
}  // namespace hexa
