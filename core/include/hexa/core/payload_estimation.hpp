// The platform's payload from a recorded session's moves (docs/calibration.md "Payload"): the
// scale s of the platform's mass and inertia (DisturbanceProfile::payload_scale in the plant)
// that the leg forces measured by the chamber pressures imply, with the calibrated geometry.
//
// Per leg i and sample k, with the leg sliding (|l_dot| >= min_speed, away from the end stops):
//
//   F_p = P1 A1 - P2 A2 - P_atm A_r                                    (pneumatic force, eq 8)
//   F_p - f_fixed = s f_scaled + F_f,d(|l_dot|)                        (eq 8 solved for the load)
//   F_f,d(v) ~ c0_d + c1_d v + c2_d v^2,  d = direction of l_dot       (eq 3 at v << v_s)
//
// f_fixed and f_scaled from PlatformInverseDynamics (the platform's equations with the rig's
// mass and inertia, s = 1): the leg's weight and the platform's weight and inertia forces at
// the measured lengths and their derivatives. The friction of each leg and direction is
// unknown (the plant's differs from the rig file's) and is fitted with it: s comes from how
// the platform's weight share of the leg changes from pose to pose within one stroke
// direction, not from the force's level. Still windows are left out: at rest the static
// friction (~100 N) can hold any force and the weight share is ~12 N per leg.
//
// Each leg gives its own s_i (normal equations of [f_scaled, friction regressors], s_i from
// the Schur complement, information I_i); the estimate is the information-weighted mean and
// its standard error the weighted scatter of the six legs' s_i (independent: each leg has its
// own friction and sensor noise). Pure: no clock, no I/O.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hexa/core/calibration.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct PayloadEstimatorConfig {
  double period_s = 0.001;                 // of the recorded samples (one per tick)
  // l_dot and l_ddot: central differences over +-30 ms and +-80 ms. The platform's heavy modes
  // (x, y through near-vertical legs) make f_scaled sensitive to l_ddot's noise, which biases s
  // low (errors in the regressor); on the 2 s calibration moves the windows' own error is small.
  int velocity_half_window_ticks = 30;
  int acceleration_half_window_ticks = 80;
  int stride_ticks = 10;                   // one sample per 10 ms
  // Sliding well clear of stick: below ~0.04 m/s the LuGre transients after a start and the
  // Stribeck curve's low-speed end leave ~10 N the quadratic does not follow, and s came out
  // 10-25 % low (measured: docs/measurements/payload.md).
  double min_speed_m_s = 0.05;
  double stroke_margin_m = 0.01;           // away from the end stops
  int min_samples_per_direction = 200;     // a direction with fewer is left out of a leg's fit
  double max_scale_std = 0.03;             // PayloadEstimate::precise: standard error at most this

  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

// Leg readings per tick as recorded (potentiometer reading, absolute chamber pressures).
class PayloadRecord {
 public:
  void Add(std::uint64_t tick, std::size_t leg, double reading_m, double cap_pressure_pa,
           double rod_pressure_pa);
  std::size_t size() const;

  struct Sample {
    std::uint64_t tick;
    double reading_m, cap_pressure_pa, rod_pressure_pa;
  };
  const LegArray<std::vector<Sample>>& legs() const { return legs_; }

 private:
  LegArray<std::vector<Sample>> legs_{};
};

struct PayloadLegEstimate {
  double scale = 0.0;          // s_i
  double information = 0.0;    // I_i = Schur complement of f_scaled (N^2 per unit s^2)
  std::size_t samples = 0;     // sliding samples used
  double residual_rms_n = 0.0; // force residual of the leg's fit
};

struct PayloadEstimate {
  bool ok = false;
  bool precise = false;           // ok and scale_std <= config.max_scale_std: fit to be used
  std::string message;            // why not, when !ok
  double scale = 0.0;             // s against `rig.platform` (1 = the rig's platform)
  double scale_std = 0.0;         // standard error (six legs' weighted scatter)
  double mass_kg = 0.0;           // s * rig.platform.mass_kg
  Eigen::Vector3d inertia_diag_kg_m2 = Eigen::Vector3d::Zero();  // s * rig's
  LegArray<PayloadLegEstimate> legs{};
  std::size_t failed_kinematics = 0;  // samples whose forward kinematics failed (left out)
};

// `rig`: the controllers' model (its platform is the s = 1 reference); `calibration`: the
// kinematic calibration that corrects the readings and places the joints.
PayloadEstimate EstimatePayload(const RigParams& rig, const KinematicCalibration& calibration,
                                const PayloadRecord& record, const PayloadEstimatorConfig& config);

}  // namespace hexa
