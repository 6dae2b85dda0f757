#include "hexa/core/platform_inverse_dynamics.hpp"

#include <Eigen/LU>

namespace hexa {

PlatformInverseDynamics::PlatformInverseDynamics(const RigParams& nominal) : rig_(nominal) {
  guess_.p_BP_B_m = rig_.geometry.home_position_m;
  guess_.R_BP.setIdentity();
}

KinStatus PlatformInverseDynamics::Decompose(const LegArray<double>& length,
                                             const LegArray<double>& l_dot,
                                             PlatformDynamicsTerms& out) {
  NewtonFkResult fk;
  const KinStatus status = NewtonRaphsonFk(rig_.geometry, length, guess_, NewtonFkConfig{}, fk);
  if (status != KinStatus::kOk) return status;
  guess_ = fk.pose;
  const Pose& pose = fk.pose;
  Matrix6d J;
  LegJacobian(rig_.geometry, pose, J);  // eq 48
  const Eigen::PartialPivLU<Matrix6d> lu(J);
  const Matrix6d J_inv = lu.inverse();
  const Matrix6d J_inv_T = J_inv.transpose();

  Vector6d ld;
  for (std::size_t i = 0; i < kNumLegs; ++i) ld[static_cast<int>(i)] = l_dot[i];
  const Vector6d twist = J_inv * ld;
  const Eigen::Vector3d v = twist.head<3>();
  const Eigen::Vector3d w = twist.tail<3>();
  // Velocity-product terms c_i of l_ddot = J twist_dot + c (the plant's formula).
  Vector6d c;
  const double g = rig_.platform.gravity_m_s2;
  const double m_leg = rig_.cylinder.moving_mass_kg;
  Eigen::Vector3d sum_r = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const Eigen::Vector3d r = pose.R_BP * rig_.geometry.p_PB_P[i];
    const Eigen::Vector3d leg = pose.p_BP_B_m + r - rig_.geometry.p_BA_B[i];
    const double l = leg.norm();
    const Eigen::Vector3d s = leg / l;
    const Eigen::Vector3d v_joint = v + w.cross(r);
    const double rate = s.dot(v_joint);
    c[static_cast<int>(i)] = s.dot(w) * w.dot(r) - s.dot(r) * w.squaredNorm() +
                             (v_joint - rate * s).squaredNorm() / l;
    sum_r += r;
  }
  // Platform mass and inertia (about the platform origin, its centre) per unit payload scale.
  const Eigen::Matrix3d inertia_B =
      pose.R_BP * rig_.platform.inertia_diag_kg_m2.asDiagonal() * pose.R_BP.transpose();
  const double m_p = rig_.platform.mass_kg;
  Matrix6d Mp = Matrix6d::Zero();
  Mp.topLeftCorner<3, 3>() = m_p * Eigen::Matrix3d::Identity();
  Mp.bottomRightCorner<3, 3>() = inertia_B;
  out.inertia_scaled = J_inv_T * Mp * J_inv;
  // twist_dot = J^-1 (l_ddot - c): the -c part, the platform's weight, the gyroscopic term.
  Vector6d scaled = -(Mp * (J_inv * c));
  scaled[2] += m_p * g;
  scaled.tail<3>() += w.cross(inertia_B * w);
  out.scaled_rest = J_inv_T * scaled;
  // The legs' weight at the platform joints (as the plant applies it).
  Vector6d fixed;
  fixed.head<3>() = Eigen::Vector3d(0.0, 0.0, kNumLegs * m_leg * g);
  fixed.tail<3>() = -sum_r.cross(Eigen::Vector3d(0.0, 0.0, -m_leg * g));
  out.fixed_rest = J_inv_T * fixed;
  out.leg_mass_kg = m_leg;
  out.pose = pose;
  return KinStatus::kOk;
}

KinStatus PlatformInverseDynamics::Evaluate(const LegArray<double>& length,
                                            const LegArray<double>& l_dot,
                                            const LegArray<double>& l_ddot, PlatformLoad& out) {
  PlatformDynamicsTerms t;
  const KinStatus status = Decompose(length, l_dot, t);
  if (status != KinStatus::kOk) return status;
  Vector6d ldd;
  for (std::size_t i = 0; i < kNumLegs; ++i) ldd[static_cast<int>(i)] = l_ddot[i];
  const Vector6d f_scaled = t.inertia_scaled * ldd + t.scaled_rest;
  const Vector6d f_fixed = t.leg_mass_kg * ldd + t.fixed_rest;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int ii = static_cast<int>(i);
    out.force_fixed_n[i] = f_fixed[ii];
    out.force_scaled_n[i] = f_scaled[ii];
    out.mass_fixed_kg[i] = t.leg_mass_kg;
    out.mass_scaled_kg[i] = t.inertia_scaled(ii, ii);
  }
  out.pose = t.pose;
  return KinStatus::kOk;
}

}  // namespace hexa
