// Platform pose and the rotation convention used throughout the system.
//
// Orientation angles (roll, pitch, yaw) = rotations about the fixed base axes x, y, z,
// applied in that order: R_BP = Rz(yaw) * Ry(pitch) * Rx(roll). These are the paper's
// alpha, beta, gamma (Sec. 4.2). Twists are [v_BP_B; w_BP_B]: linear velocity of the
// platform origin and angular velocity, both expressed in B.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hexa {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct Pose {
  Eigen::Vector3d p_BP_B_m = Eigen::Vector3d::Zero();       // platform origin in B
  Eigen::Matrix3d R_BP = Eigen::Matrix3d::Identity();       // platform orientation in B
};

Eigen::Matrix3d RotationFromRollPitchYaw(const Eigen::Vector3d& rpy_rad);
// Inverse of RotationFromRollPitchYaw for |pitch| < 90 deg.
Eigen::Vector3d RollPitchYawFromRotation(const Eigen::Matrix3d& R);

// Pose from [x y z roll pitch yaw] (m, rad) and back.
Pose PoseFromVector(const Vector6d& xyz_rpy);
Vector6d VectorFromPose(const Pose& pose);

// Small-angle pose error (desired - actual): [p_d - p; rotation vector of R_d * R^T],
// expressed in B. This is the task-space error fed to the Jacobian outer loop (Sec. 4.1).
Vector6d PoseError(const Pose& desired, const Pose& actual);

}  // namespace hexa
