// Platform pose estimate for the outer loop (paper Sec. 4.1): orientation from the IMU, position
// from the measured leg lengths with that orientation, by GQFK (eq 47, three legs) or, beyond
// the paper, by least squares over all six legs (tolerant of one bad leg).
#pragma once

#include <array>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct PoseEstimatorConfig {
  bool least_squares = false;                     // SupervisorParams.least_squares_estimator
  double outlier_threshold_m = 0.003;             // LSQ: leg residual beyond -> excluded
  std::array<int, 3> gqfk_legs = kGqfkDefaultLegs;  // 0-based legs used by eq 47
  double max_quaternion_norm_error = 0.01;        // |norm - 1| beyond -> invalid IMU sample
};

struct PoseEstimatorInput {
  LegArray<double> length_m{};                          // measured leg lengths
  std::array<double, 4> orientation_wxyz{1.0, 0.0, 0.0, 0.0};  // IMU R_BP as a quaternion
};

struct PoseEstimatorOutput {
  KinStatus status = KinStatus::kInvalidInput;
  Pose pose;                            // valid when status == kOk
  Vector6d xyz_rpy = Vector6d::Zero();  // same, as [x y z roll pitch yaw]
  int excluded_leg = -1;                // LSQ: 0-based leg judged faulty, -1 none
  double rms_residual_m = 0.0;          // LSQ: leg-length residual over the legs used
};

class PoseEstimator {
 public:
  PoseEstimator(const GeometryParams& geometry, const PoseEstimatorConfig& config);
  // Neither throws nor allocates. On failure the output keeps the previous pose fields
  // untouched except status.
  void Update(const PoseEstimatorInput& input, PoseEstimatorOutput& output) const noexcept;
  const PoseEstimatorConfig& config() const { return config_; }

 private:
  GeometryParams geometry_;
  PoseEstimatorConfig config_;
};

}  // namespace hexa
