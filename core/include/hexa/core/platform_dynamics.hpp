// Inverse dynamics of the platform: the axial force every leg must deliver so
// that the rigid platform, with the legs' moving masses, follows a desired motion.
//
// The model is the plant's (docs/plant.md): a rigid platform (mass m, inertia I_P about its
// origin) driven by six forces f_i along the legs; each leg's moving mass m_leg moves along
// its leg axis with the leg acceleration l_ddot_i and its weight acts at the platform joint.
// Newton-Euler of the platform, with J the leg Jacobian of eq 48 (l_dot = J t, t = [v; w]):
//
//   M_p t_dot + [0; w x I_B w] = sum_i J_i^T (f_i - m_leg l_ddot_i) + W_g
//   l_ddot_i = J_i t_dot + c_i,   c_i = s_i.(w x (w x r_i)) + |v_joint,perp|^2 / l_i
//
// so  f = m_leg l_ddot + J^-T (M_p t_dot + [0; w x I_B w] - W_g)          (eq 48 mapped: J^-T).
//
// f_i is the leg's total axial force on the platform side of the piston: pneumatic force
// (P1 A1 - P2 A2 - P_a A_r) plus friction. This is what the supervisor feeds forward to each
// leg (LegSetpoint.feedforward_force_n) and what the BS-SMC uses as the known load of
// eq 14/15. Pure: no allocation, no clock; a status instead of NaN.
#pragma once

#include "hexa/core/kinematics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// The inertial parameters the inverse dynamics uses (the controllers' nominal rig, or the
// plant's true one in tests).
struct PlatformInertialParams {
  double platform_mass_kg = 6.0;
  Eigen::Matrix3d platform_inertia_P_kg_m2 = Eigen::Vector3d(0.094, 0.094, 0.19).asDiagonal();
  double leg_moving_mass_kg = 0.25;
  double gravity_m_s2 = 9.81;

  static PlatformInertialParams FromRig(const RigParams& rig);
};

struct PlatformMotion {
  Pose pose;                                 // X_BP
  Vector6d twist_B = Vector6d::Zero();       // [v_BP_B; w_BP_B]
  Vector6d twist_rate_B = Vector6d::Zero();  // d/dt of twist_B: [a_BP_B; alpha_BP_B]
};

struct LegForceResult {
  LegArray<double> force_n{};                // f_i, > 0 pushes the platform away from the base
  LegArray<double> leg_acceleration_m_s2{};  // l_ddot_i of the motion
};

// kOk, or kInvalidInput (non-finite input), kDegenerate (singular Jacobian: no finite
// forces); the result is zero then.
KinStatus LegForcesForMotion(const GeometryParams& geometry, const PlatformInertialParams& inertial,
                             const PlatformMotion& motion, LegForceResult& result);

// Leg-space mass matrix at `pose` (coupled leg feedback; docs/measurements/control_coupled_feedback.md
// "Coupled leg feedback"): with the platform at rest (zero twist, so c = 0 above),
//   f - f(l_ddot = 0) = M_ls l_ddot,   M_ls = J^-T M_p J^-1 + m_leg I,
// M_p = diag(m I_3, R I_P R^T) about the platform origin, J the eq 48 Jacobian. Symmetric,
// positive definite. kOk, or kInvalidInput / kDegenerate as above (out is then zero).
KinStatus LegSpaceMassMatrix(const GeometryParams& geometry, const PlatformInertialParams& inertial,
                             const Pose& pose, Matrix6d& out);

}  // namespace hexa
