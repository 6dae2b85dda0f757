// Kinematics of the 6-6 Gough-Stewart platform (paper Sec. 4.1). Pure functions of the
// constant GeometryParams; no allocation; a status instead of NaN for bad inputs.
#pragma once

#include <array>

#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

enum class KinStatus {
  kOk = 0,
  kInvalidInput,   // non-finite or non-positive lengths, non-orthonormal rotation
  kUnreachable,    // spheres do not intersect / lengths inconsistent with any pose
  kDegenerate,     // singular configuration (collinear sphere centres, singular Jacobian)
  kNotConverged,   // iterative solver did not reach its tolerance
};
const char* ToString(KinStatus status);

// Eq 46: leg lengths of a pose; optionally the unit leg vectors s_i (base -> platform, in B).
void InverseKinematics(const GeometryParams& geometry, const Pose& pose,
                       LegArray<double>& length_m,
                       LegArray<Eigen::Vector3d>* unit_B = nullptr);

// Eq 48: leg-rate Jacobian, l_dot = J * [v_BP_B; w_BP_B]. Row i = [s_i^T, (R b_i x s_i)^T].
void LegJacobian(const GeometryParams& geometry, const Pose& pose, Matrix6d& J);

// Eq 47 (GQFK): platform position from its rotation and three leg lengths. The platform
// origin lies on the sphere of radius l_i about O_i = a_i - R b_i; of the two intersection
// points of three spheres the one above the base (larger z) is returned.
KinStatus GqfkPosition(const GeometryParams& geometry, const Eigen::Matrix3d& R_BP,
                       const LegArray<double>& length_m, const std::array<int, 3>& legs,
                       Eigen::Vector3d& p_BP_B_m);
inline constexpr std::array<int, 3> kGqfkDefaultLegs{0, 2, 4};  // legs 1, 3, 5

// Beyond the paper: least squares over all six spheres (linear after differencing the
// sphere equations, then Gauss-Newton), tolerant of one bad leg. If any residual exceeds
// `outlier_threshold_m`, the fit is repeated without each leg in turn; the leg whose removal
// leaves the most consistent five is reported in `excluded_leg` (if its own residual exceeds
// the threshold) and the five-leg solution is returned. kOk when the legs used agree within
// the threshold; kUnreachable when they do not (e.g. two bad legs), with a finite best
// effort in `p_BP_B_m`. docs/kinematics.md has the details.
struct GqfkLsqResult {
  Eigen::Vector3d p_BP_B_m = Eigen::Vector3d::Zero();
  LegArray<double> residual_m{};  // measured length - length implied by the solution
  int excluded_leg = -1;          // 0-based leg judged faulty, -1 if none
  double rms_residual_m = 0.0;    // over the legs used
};
KinStatus GqfkLeastSquares(const GeometryParams& geometry, const Eigen::Matrix3d& R_BP,
                           const LegArray<double>& length_m, double outlier_threshold_m,
                           GqfkLsqResult& result);

// Baseline: Newton-Raphson forward kinematics from six leg lengths (no IMU).
struct NewtonFkConfig {
  int max_iterations = 50;
  double tolerance_m = 1e-13;  // on the max leg-length residual
};
struct NewtonFkResult {
  Pose pose;
  int iterations = 0;
  double max_residual_m = 0.0;
};
KinStatus NewtonRaphsonFk(const GeometryParams& geometry, const LegArray<double>& length_m,
                          const Pose& initial_guess, const NewtonFkConfig& config,
                          NewtonFkResult& result);

}  // namespace hexa
