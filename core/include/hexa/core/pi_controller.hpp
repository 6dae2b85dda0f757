// PI baseline (paper ref [11]): joint-space PI on the leg length error, with anti-windup.
//
//   e = l_d - l,  u = u_null + sign(a) (Kp e + I + Kv v_d + Kd (v_d - v)),
//   I = clamp(I + Ki e h, +-I_max), v from the eq 40 differentiator on the measured length.
//   Kv = Kd = 0 is ref [11]'s PI; the two extra terms are ours (docs/controller.md).
//
// sign(a) is the sign of the spool gain of eq 42 (a < 0 on the MPYE: a voltage below null
// extends), so positive gains push the leg towards the setpoint. Anti-windup: the integral
// is clamped, and it is not integrated while the output is saturated in the direction the
// error would push it further (conditional integration). Output saturated to 0-10 V.
#pragma once

#include "hexa/core/control_params.hpp"
#include "hexa/core/differentiator.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct PiConfig {
  PiParams params;
  DifferentiatorParams differentiator;  // for the rate-damping velocity
  ValveParams valve;
  CylinderParams cylinder;              // areas of the force feed-forward term
  double atmosphere_pressure_pa = 1.0e5;
  double period_s = 0.001;
  void Validate() const;  // throws std::invalid_argument naming field, value, limit
};

struct PiInput {
  double length_m = 0.0;
  double desired_length_m = 0.0;
  double desired_velocity_m_s = 0.0;
  // Force feed-forward: with has_feedforward the term
  // Kf (F_ff - (P1 A1 - P2 A2 - Pa A_r)) is added (PiParams::force_feedforward_v_n).
  bool has_feedforward = false;
  double feedforward_force_n = 0.0;
  double cap_pressure_pa = 1.0e5;
  double rod_pressure_pa = 1.0e5;
};

struct PiOutput {
  double valve_v = 5.0;
  double error_m = 0.0;       // l_d - l
  double integral_v = 0.0;    // integral term, volts (before the spool-sign)
  double velocity_m_s = 0.0;  // measured-length derivative (eq 40)
  bool saturated = false;
};

class PiController {
 public:
  explicit PiController(const PiConfig& config);
  void Reset();
  void Update(const PiInput& input, PiOutput& output);  // never throws or allocates
  const PiConfig& config() const { return config_; }

 private:
  PiConfig config_;
  GaussianDifferentiator velocity_diff_;
  double integral_v_ = 0.0;
};

}  // namespace hexa
