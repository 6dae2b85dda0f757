// Rotation convention and pose helpers (see pose.hpp): R_BP = Rz(yaw) * Ry(pitch) * Rx(roll),
// angles about the fixed base axes applied in the order x, y, z (paper Sec. 4.2 alpha, beta,
// gamma).
#include "hexa/core/pose.hpp"

#include <cmath>

namespace hexa {

Eigen::Matrix3d RotationFromRollPitchYaw(const Eigen::Vector3d& rpy_rad) {
  const double cr = std::cos(rpy_rad.x()), sr = std::sin(rpy_rad.x());
  const double cp = std::cos(rpy_rad.y()), sp = std::sin(rpy_rad.y());
  const double cy = std::cos(rpy_rad.z()), sy = std::sin(rpy_rad.z());
  // Written out rather than composed from AngleAxis so that the convention is explicit and
  // the cost is a handful of multiplications.
  Eigen::Matrix3d R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return R;
}

Eigen::Vector3d RollPitchYawFromRotation(const Eigen::Matrix3d& R) {
  // R(2,0) = -sin(pitch); cos(pitch) >= 0 for |pitch| <= 90 deg, so hypot() is the
  // well-conditioned choice for it (asin(-R(2,0)) loses accuracy near +-90 deg).
  const double pitch_rad = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  const double roll_rad = std::atan2(R(2, 1), R(2, 2));
  const double yaw_rad = std::atan2(R(1, 0), R(0, 0));
  return {roll_rad, pitch_rad, yaw_rad};
}

Pose PoseFromVector(const Vector6d& xyz_rpy) {
  Pose pose;
  pose.p_BP_B_m = xyz_rpy.head<3>();
  pose.R_BP = RotationFromRollPitchYaw(xyz_rpy.tail<3>());
  return pose;
}

Vector6d VectorFromPose(const Pose& pose) {
  Vector6d v;
  v.head<3>() = pose.p_BP_B_m;
  v.tail<3>() = RollPitchYawFromRotation(pose.R_BP);
  return v;
}

Vector6d PoseError(const Pose& desired, const Pose& actual) {
  Vector6d e;
  e.head<3>() = desired.p_BP_B_m - actual.p_BP_B_m;
  // Rotation vector of R_d R^T (the rotation that takes the actual orientation to the
  // desired one, expressed in B), via the quaternion: 2 atan2(|v|, w) is accurate for small
  // and large angles alike, unlike acos((trace - 1) / 2).
  Eigen::Quaterniond q(desired.R_BP * actual.R_BP.transpose());
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // shortest rotation, angle in [0, pi]
  const double sin_half = q.vec().norm();
  if (sin_half < 1e-300) {
    e.tail<3>() = 2.0 * q.vec();
  } else {
    const double angle_rad = 2.0 * std::atan2(sin_half, q.w());
    e.tail<3>() = q.vec() * (angle_rad / sin_half);
  }
  return e;
}

}  // namespace hexa
