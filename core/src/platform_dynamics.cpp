#include "hexa/core/platform_dynamics.hpp"

#include <cmath>

#include <Eigen/LU>

namespace hexa {

PlatformInertialParams PlatformInertialParams::FromRig(const RigParams& rig) {
  PlatformInertialParams p;
  p.platform_mass_kg = rig.platform.mass_kg;
  p.platform_inertia_P_kg_m2 = rig.platform.inertia_diag_kg_m2.asDiagonal();
  p.leg_moving_mass_kg = rig.cylinder.moving_mass_kg;
  p.gravity_m_s2 = rig.platform.gravity_m_s2;
  return p;
}

KinStatus LegForcesForMotion(const GeometryParams& geometry, const PlatformInertialParams& inertial,
                             const PlatformMotion& motion, LegForceResult& result) {
  result = LegForceResult{};
  const Eigen::Matrix3d& R = motion.pose.R_BP;
  const Eigen::Vector3d& p = motion.pose.p_BP_B_m;
  if (!R.allFinite() || !p.allFinite() || !motion.twist_B.allFinite() ||
      !motion.twist_rate_B.allFinite()) {
    return KinStatus::kInvalidInput;
  }
  const Eigen::Vector3d v = motion.twist_B.head<3>();
  const Eigen::Vector3d w = motion.twist_B.tail<3>();
  const double g = inertial.gravity_m_s2;
  const double m_leg = inertial.leg_moving_mass_kg;

  // Platform wrench needed, about the platform origin, in B:
  //   M_p t_dot + [0; w x I_B w] - W_g, W_g = gravity of platform and leg masses (the leg
  //   masses' weight acts at their platform joints).
  const Eigen::Matrix3d inertia_B = R * inertial.platform_inertia_P_kg_m2 * R.transpose();
  Vector6d wrench;
  wrench.head<3>() = inertial.platform_mass_kg * motion.twist_rate_B.head<3>();
  wrench.tail<3>() = inertia_B * motion.twist_rate_B.tail<3>() + w.cross(inertia_B * w);
  wrench[2] += (inertial.platform_mass_kg + static_cast<double>(kNumLegs) * m_leg) * g;

  Matrix6d J;  // eq 48, row i = [s_i^T, (R b_i x s_i)^T]
  LegArray<double> c_m_s2{};
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const Eigen::Vector3d r = R * geometry.p_PB_P[i];
    const Eigen::Vector3d leg = p + r - geometry.p_BA_B[i];
    const double length = leg.norm();
    if (!(length > 0.0)) return KinStatus::kDegenerate;
    const Eigen::Vector3d s = leg / length;
    const int ii = static_cast<int>(i);
    J.block<1, 3>(ii, 0) = s.transpose();
    J.block<1, 3>(ii, 3) = r.cross(s).transpose();
    // Weight of the leg's moving mass at its platform joint: moment r x (0, 0, -m_leg g).
    wrench.tail<3>() -= r.cross(Eigen::Vector3d(0.0, 0.0, -m_leg * g));
    const Eigen::Vector3d v_joint = v + w.cross(r);
    const double l_dot = s.dot(v_joint);
    // Centripetal part of the leg acceleration (same expression as the plant).
    c_m_s2[i] = s.dot(w) * w.dot(r) - s.dot(r) * w.squaredNorm() +
                (v_joint - l_dot * s).squaredNorm() / length;
  }
  const Eigen::PartialPivLU<Matrix6d> lu(J.transpose());
  // A singular J^T (reciprocal condition number ~ 0) has no finite leg forces.
  const double rcond = lu.rcond();
  if (!std::isfinite(rcond) || rcond < 1e-10) return KinStatus::kDegenerate;
  const Vector6d f_platform = lu.solve(wrench);  // J^T f = wrench
  const Vector6d l_ddot = J * motion.twist_rate_B;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int ii = static_cast<int>(i);
    const double a = l_ddot[ii] + c_m_s2[i];
    result.leg_acceleration_m_s2[i] = a;
    result.force_n[i] = f_platform[ii] + m_leg * a;
  }
  for (double f : result.force_n) {
    if (!std::isfinite(f)) {
      result = LegForceResult{};
      return KinStatus::kDegenerate;
    }
  }
  return KinStatus::kOk;
}

KinStatus LegSpaceMassMatrix(const GeometryParams& geometry, const PlatformInertialParams& inertial,
                             const Pose& pose, Matrix6d& out) {
  out.setZero();
  if (!pose.R_BP.allFinite() || !pose.p_BP_B_m.allFinite()) return KinStatus::kInvalidInput;
  Matrix6d J;
  LegJacobian(geometry, pose, J);  // eq 48
  if (!J.allFinite()) return KinStatus::kDegenerate;
  const Eigen::PartialPivLU<Matrix6d> lu(J);
  const double rcond = lu.rcond();
  if (!std::isfinite(rcond) || rcond < 1e-10) return KinStatus::kDegenerate;
  const Matrix6d j_inv = lu.inverse();
  Matrix6d mp = Matrix6d::Zero();
  mp.topLeftCorner<3, 3>() = inertial.platform_mass_kg * Eigen::Matrix3d::Identity();
  mp.bottomRightCorner<3, 3>() =
      pose.R_BP * inertial.platform_inertia_P_kg_m2 * pose.R_BP.transpose();
  out = j_inv.transpose() * mp * j_inv;
  out.diagonal().array() += inertial.leg_moving_mass_kg;
  out = 0.5 * (out + out.transpose()).eval();  // exactly symmetric
  if (!out.allFinite()) {
    out.setZero();
    return KinStatus::kDegenerate;
  }
  return KinStatus::kOk;
}

}  // namespace hexa
