// Pose estimator: IMU orientation + GQFK (eq 47) or six-leg least squares.
#include "hexa/core/pose_estimator.hpp"

#include <cmath>
#include <stdexcept>

namespace hexa {

PoseEstimator::PoseEstimator(const GeometryParams& geometry, const PoseEstimatorConfig& config)
    : geometry_(geometry), config_(config) {
  for (int leg : config_.gqfk_legs) {
    if (leg < 0 || leg >= static_cast<int>(kNumLegs)) {
      throw std::invalid_argument("PoseEstimatorConfig.gqfk_legs: leg index " +
                                  std::to_string(leg) + " outside 0..5");
    }
  }
  if (!(config_.outlier_threshold_m > 0.0)) {
    throw std::invalid_argument("PoseEstimatorConfig.outlier_threshold_m must be > 0");
  }
}

void PoseEstimator::Update(const PoseEstimatorInput& input,
                           PoseEstimatorOutput& output) const noexcept {
  const auto& w = input.orientation_wxyz;
  Eigen::Quaterniond q(w[0], w[1], w[2], w[3]);
  const double norm = q.norm();
  if (!std::isfinite(norm) || std::abs(norm - 1.0) > config_.max_quaternion_norm_error) {
    output.status = KinStatus::kInvalidInput;
    return;
  }
  q.normalize();
  const Eigen::Matrix3d R_BP = q.toRotationMatrix();
  Eigen::Vector3d p_BP_B_m;
  KinStatus status;
  if (config_.least_squares) {
    GqfkLsqResult lsq;
    status = GqfkLeastSquares(geometry_, R_BP, input.length_m, config_.outlier_threshold_m, lsq);
    p_BP_B_m = lsq.p_BP_B_m;
    output.excluded_leg = lsq.excluded_leg;
    output.rms_residual_m = lsq.rms_residual_m;
  } else {
    status = GqfkPosition(geometry_, R_BP, input.length_m, config_.gqfk_legs, p_BP_B_m);  // eq 47
    output.excluded_leg = -1;
    output.rms_residual_m = 0.0;
  }
  output.status = status;
  if (status != KinStatus::kOk) return;
  output.pose.p_BP_B_m = p_BP_B_m;
  output.pose.R_BP = R_BP;
  output.xyz_rpy = VectorFromPose(output.pose);
}

}  // namespace hexa
