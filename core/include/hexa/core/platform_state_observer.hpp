// Platform state observer (NOT in the paper; docs/controller_additions.md "Platform state
// observer"): the platform's pose, twist and the six legs' velocities from the six potentiometers,
// the six legs' pneumatic forces (chamber pressures), the IMU orientation and the platform's
// rigid-body model (eq 48's leg-space mass matrix, the feed-forward's inverse dynamics).
//
// A modal steady-state Kalman filter in leg space. The rigid platform with its legs obeys
// (platform_dynamics.hpp)
//   M_ls(q) (l'' - c(q, t)) = F_p - f0(q, t) + F_d,
// F_p the six measured pneumatic forces, f0 the forces that hold the motion at zero
// acceleration (gravity, velocity terms), c the legs' acceleration at zero platform
// acceleration, F_d what the model does not know (friction, payload, model errors). M_ls at
// home is V diag(m_k) V^T (V orthonormal); in the mode coordinates eta = V^T (l - l_home)
// every mode k is a mass m_k:
//   eta_k'' = u_k + d_k,   u_k = V_k^T (c + M_ls(q)^-1 (F_p - f0)),   d_k' = w_k,
// measured by eta_k = V_k^T l_measured (independent potentiometer noise stays independent
// and of the same sigma under the orthonormal V). Each mode is the 3-state filter of
// leg_observer.hpp with mass m_k, its gain the steady-state Kalman gain for that mass. M_ls(q),
// f0 and c are evaluated at the previous estimate, so the coupling of the legs through the
// platform (the heavy x / y modes, the light roll / pitch ones) is in the model, not in the
// noise. Outputs: leg lengths and velocities V eta, V eta'; the pose from the IMU orientation and
// the filtered lengths (six-leg least squares, eq 47's geometry); the twist J(q)^-1 l'.
// Pure: Eigen only, no clock; Update() neither allocates nor throws.
#pragma once

#include <array>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/leg_observer.hpp"
#include "hexa/core/platform_dynamics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct PlatformStateObserverConfig {
  GeometryParams geometry;            // the controllers' (calibrated) geometry
  PlatformInertialParams inertial;    // the feed-forward's masses
  CylinderParams cylinder;            // areas of the pneumatic force
  double atmosphere_pressure_pa = 1.01325e5;
  double period_s = 0.001;
  double length_sigma_m = 0.05e-3;    // potentiometer noise (one sample)
  double force_sigma_n = 3.0;         // noise of one measured pneumatic force
  double disturbance_rate_m_s3 = 100.0;  // random walk of each mode's d, (m/s^2) / sqrt(s)
  static PlatformStateObserverConfig FromRig(const RigParams& rig);
  void Validate() const;  // throws std::invalid_argument naming the field, value and limit
};

struct PlatformStateObserverInput {
  LegArray<double> length_m{};            // measured (calibrated) leg lengths
  LegArray<double> cap_pressure_pa{};     // P1, absolute
  LegArray<double> rod_pressure_pa{};     // P2, absolute
  std::array<double, 4> orientation_wxyz{1.0, 0.0, 0.0, 0.0};  // IMU R_BP (newest sample)
};

struct PlatformStateObserverOutput {
  bool valid = false;                      // false until the first update with a finite input
  LegArray<double> length_m{};             // filtered leg lengths
  LegArray<double> velocity_m_s{};         // leg velocities l'
  Pose pose;                               // IMU orientation, position from the filtered lengths
  Vector6d twist_B = Vector6d::Zero();     // [v_BP_B; w_BP_B] = J^-1 l'
};

class PlatformStateObserver {
 public:
  explicit PlatformStateObserver(const PlatformStateObserverConfig& config);  // validates (throws)
  void Reset();
  void Update(const PlatformStateObserverInput& input, PlatformStateObserverOutput& output) noexcept;
  const Vector6d& mode_mass_kg() const { return mode_mass_kg_; }

 private:
  PlatformStateObserverConfig config_;
  Matrix6d modes_ = Matrix6d::Identity();  // V (columns)
  Vector6d mode_mass_kg_ = Vector6d::Ones();
  LegArray<double> home_length_m_{};
  std::array<LegObserver, 6> filters_;
  Pose pose_;
  Vector6d twist_B_ = Vector6d::Zero();
  bool primed_ = false;
};

}  // namespace hexa
