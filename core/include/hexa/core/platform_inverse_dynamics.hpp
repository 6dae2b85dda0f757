// Inverse dynamics of the platform for identification (docs/identification.md): from the
// six measured leg lengths and their first and second derivatives, the force each leg must
// exert along itself for that motion, and the inertia each leg sees, with the rig file's
// (nominal) geometry, platform mass and inertia and leg mass - the plant's equations
// (docs/plant.md) solved for the leg forces:
//
//   J^T f = M_p twist_dot + m_leg J^T l_ddot - W_g + [0; w x (I_B w)],
//   twist = J^-1 l_dot,  twist_dot = J^-1 (l_ddot - c),  c_i = l_ddot_i - J_i twist_dot,
//
// split into the part proportional to the payload scale s (platform mass and inertia,
// DisturbanceProfile::payload_scale in the plant) and the rest:
//   f_i = force_fixed_i + s force_scaled_i,   M_eff,i = mass_fixed_i + s mass_scaled_i
// with M_eff,i = m_leg + s (J^-T M_p1 J^-1)_ii the inertia of leg i when the others hold.
// The pose comes from Newton-Raphson forward kinematics (kinematics.hpp) from the lengths.
#pragma once

#include "hexa/core/kinematics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// The same equations split by what multiplies the leg accelerations (for smoothing
// consistently, docs/identification.md): f = f_fixed + s f_scaled with
//   f_fixed  = m_leg l_ddot + fixed_rest,   f_scaled = inertia_scaled l_ddot + scaled_rest
// where the rest holds the weights and the velocity-product terms (c, gyroscopic).
struct PlatformDynamicsTerms {
  Matrix6d inertia_scaled = Matrix6d::Zero();  // J^-T M_p1 J^-1 (rig file's platform, s = 1)
  Vector6d scaled_rest = Vector6d::Zero();
  Vector6d fixed_rest = Vector6d::Zero();
  double leg_mass_kg = 0.0;
  Pose pose;
};

struct PlatformLoad {
  LegArray<double> force_fixed_n{}, force_scaled_n{};
  LegArray<double> mass_fixed_kg{}, mass_scaled_kg{};
  Pose pose;  // from the lengths
};

class PlatformInverseDynamics {
 public:
  explicit PlatformInverseDynamics(const RigParams& nominal);

  // Uses (and updates) the previous pose as the forward-kinematics guess; the first call
  // starts from home. kOk or the forward kinematics' failure (outputs then unchanged).
  KinStatus Evaluate(const LegArray<double>& length_m, const LegArray<double>& velocity_m_s,
                     const LegArray<double>& accel_m_s2, PlatformLoad& out);
  // The terms without the accelerations, for given lengths and rates.
  KinStatus Decompose(const LegArray<double>& length_m, const LegArray<double>& velocity_m_s,
                      PlatformDynamicsTerms& out);

 private:
  RigParams rig_;
  Pose guess_;
};

}  // namespace hexa
