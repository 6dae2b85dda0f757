// Feasibility of a trajectory on a rig, checked before motion (docs/design.md, "Safety").
//
// The whole trajectory is sampled (1 ms by default); at every sample each leg's length
// (eq 46), speed and acceleration (exact derivatives of eq 46 along the trajectory's twist
// and twist rate) must stay inside the leg envelope:
//   length in [mid - stroke/2 + margin, mid + stroke/2 - margin]
//   |speed| <= min(SupervisorParams.max_leg_speed_m_s, valve-limited speed)
//   |acceleration| <= min(SupervisorParams.max_leg_acceleration_m_s2, force-limited accel.)
// The valve- and force-limited values come from DeriveValveEnvelope (docs/task_space.md).
// The worst violation is reported (stroke before speed before acceleration; the largest
// relative excess within a kind), naming the leg (1-based), the time and the excess:
//   "leg 3 at t=2.450 s: length 0.6412 m exceeds the stroke limit 0.6184 m by 23.8 mm"
#pragma once

#include <string>

#include "hexa/core/control_params.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {

// Physical limits of one leg from its valve and cylinder (no controller derating).
struct ValveEnvelope {
  double choked_mass_flow_kg_s = 0.0;    // eq 4 (choked branch), fully open valve, supply
  double extend_speed_m_s = 0.0;         // min(inflow into cap side, choked exhaust of rod side)
  double retract_speed_m_s = 0.0;        // min(inflow into rod side, choked exhaust of cap side)
  double extend_force_n = 0.0;           // Ps A1 - Pa A2 - Pa Ar - static friction - weight share
  double retract_force_n = 0.0;          // Ps A2 + Pa Ar - Pa A1 - static friction + weight share
  double effective_mass_kg = 0.0;        // piston + rod + platform share (mass / 6)
  double max_speed_m_s = 0.0;            // min of the two directions
  double max_acceleration_m_s2 = 0.0;    // min of the two directions
};
ValveEnvelope DeriveValveEnvelope(const RigParams& rig);

struct LegEnvelope {
  double min_length_m = 0.0;
  double max_length_m = 0.0;
  double max_speed_m_s = 0.0;
  double max_acceleration_m_s2 = 0.0;
};
// Stroke with margin; speed/acceleration = min(configured, valve-derived).
LegEnvelope MakeLegEnvelope(const RigParams& rig, const SupervisorParams& params);

// kSoftLimit: a pose outside the rig file's soft limits (soft_limits.hpp: the pose box, the
// joints' deflections), which every setpoint must respect.
enum class FeasibilityViolation { kNone, kStroke, kSpeed, kAcceleration, kNotFinite, kTooLong, kSoftLimit };

// Longest trajectory (blend + motion + stop) CheckFeasibility samples; longer ones are
// infeasible (kTooLong) without sampling. At the default 1 ms period that is 2e6 samples,
// 0.3-1.3 us each on this machine (docs/robustness.md): the check stays under ~3 s. A CSV
// trajectory may span 1800 s (config/csv_trajectory.hpp) and the rig's blend and stop at most
// 60 s each (docs/config.md), so every accepted input fits.
inline constexpr double kMaxTrajectoryDuration_s = 2000.0;
inline constexpr long kMaxFeasibilitySamples = 2'000'000;

struct FeasibilityReport {
  bool feasible = true;
  FeasibilityViolation violation = FeasibilityViolation::kNone;
  int leg = 0;              // 1-based leg of the worst violation, 0 if none
  double time_s = 0.0;      // trajectory time of the worst violation
  double value = 0.0;       // offending length / speed / acceleration (SI)
  double limit = 0.0;       // the limit it broke
  std::string message;      // empty when feasible
  LegEnvelope envelope;
  // Extremes over the whole trajectory, per leg.
  LegArray<double> min_length_m{};
  LegArray<double> max_length_m{};
  LegArray<double> max_abs_speed_m_s{};
  LegArray<double> max_abs_acceleration_m_s2{};
  long samples = 0;
};

// Leg lengths, speeds and accelerations of a desired sample (eq 46 and its derivatives):
// d = p + R b - a, l = |d|, l_dot = s . d_dot, l_ddot = s . d_ddot + (|d_dot|^2 - l_dot^2)/l.
void LegKinematicsOf(const GeometryParams& geometry, const TrajectorySample& sample,
                     LegArray<double>& length_m, LegArray<double>& speed_m_s,
                     LegArray<double>& acceleration_m_s2);

// Throws std::invalid_argument for an invalid trajectory or sample_period_s <= 0.
FeasibilityReport CheckFeasibility(const RigParams& rig, const SupervisorParams& params,
                                   const Trajectory& trajectory, double sample_period_s = 1e-3);

}  // namespace hexa
