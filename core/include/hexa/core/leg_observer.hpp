// Velocity / acceleration observer of one leg from its position and its pneumatic force
// (NOT in the paper; docs/controller_additions.md "Feedback rate in phi_dot and the leg observer").
//
// The paper's controller gets the piston velocity by differentiating the measured position
// (eq 40) and phi_dot by differentiating phi (eq 38, 40). The measured chamber pressures give
// the pneumatic force A1 P1 - A2 P2 - Pa Ar (eq 14's phi_p with the rod's atmosphere side)
// without any differentiation; this observer fuses it with the position:
//
//   states  q = [x, v, d]: piston position (eq 64), velocity, lumped acceleration disturbance
//   model   x' = v,  v' = u + d,  d' = w (random walk),   u = (A1 P1 - A2 P2 - Pa Ar) / m
//           i.e. eq 14's M x'' = phi_p - B x' + C with M -> m and -B x' + C (friction, gravity,
//           the other legs through the platform) lumped into m d.
//   measure y = x + n (potentiometer)
//
// Discretised exactly for a constant u + d over one period; steady-state Kalman gain from the
// Riccati recursion, computed once in the constructor. Update() neither allocates nor throws.
// Outputs: the a posteriori velocity and acceleration u_k + d_k (the newest force sample enters
// the acceleration without delay).
#pragma once

#include <Eigen/Core>

namespace hexa {

struct LegObserverConfig {
  double period_s = 0.001;
  double mass_kg = 1.0;                       // m of the model above
  double length_sigma_m = 0.05e-3;            // potentiometer noise (one sample)
  double force_sigma_n = 3.0;                 // noise of the measured pneumatic force
  double disturbance_rate_m_s3 = 100.0;       // random-walk intensity of d, (m/s^2) / sqrt(s)
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

class LegObserver {
 public:
  explicit LegObserver(const LegObserverConfig& config);  // validates (throws)

  void Reset();
  // One period: measured position (m) and pneumatic force (N). The first call after Reset()
  // only initialises the position.
  void Update(double position_m, double pneumatic_force_n);

  double position_m() const { return q_[0]; }
  double velocity_m_s() const { return q_[1]; }
  double acceleration_m_s2() const { return acceleration_m_s2_; }
  double disturbance_m_s2() const { return q_[2]; }
  const Eigen::Vector3d& gain() const { return gain_; }

 private:
  LegObserverConfig config_;
  Eigen::Matrix3d a_;
  Eigen::Vector3d b_;
  Eigen::Vector3d gain_;
  Eigen::Vector3d q_ = Eigen::Vector3d::Zero();
  double previous_input_m_s2_ = 0.0;
  double acceleration_m_s2_ = 0.0;
  bool primed_ = false;
};

}  // namespace hexa
