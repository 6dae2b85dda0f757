// Open-loop valve excitation of one leg for identification (paper Sec. 3.1, docs/
// identification.md "Experiment"): inside the leg's window the valve voltage follows, in
// turn, long steps of growing amplitude across the stroke (each run starts near the far end:
// a proportional-derivative preset brings the piston there first, so that the step has the
// whole usable stroke to accelerate in and reaches high speed), a multi-level pseudo-random
// sequence and a linear chirp, in both stroke directions and from slow to fast motion. A position guard
// takes over whenever the piston comes within `guard_m` of mid-stroke's limits (before an end
// stop) and drives it back towards mid-stroke with a proportional law, then hands back to the
// sequence. The guard looks ahead: it takes over when the position predicted `guard_lead_s`
// ahead at the present speed (a filtered difference of the measured lengths) passes
// `guard_m`, and brakes with a proportional-derivative law. Outside the window the leg
// controller runs its normal law.
//
// Deterministic: the sequence is a function of the seed and the time since the window
// started (drawn at construction); the guard is a function of the measured position. No
// clock, no allocation in Update.
#pragma once

#include <cstdint>
#include <vector>

#include "hexa/core/rig.hpp"

namespace hexa {

struct ExcitationParams {
  double start_s = 0.0;     // simulated time the leg's window opens
  double duration_s = 0.0;  // 0 = never excited
  std::uint64_t seed = 1;
  // Share of the window of each part, in order (the rest of the window is the chirp).
  double steps_fraction = 0.4;
  double prbs_fraction = 0.4;
  // Steps: amplitudes (V from null) cycled through, extend and retract alternating; each
  // step runs from the preset position until the guard takes over (or step_hold_s).
  std::vector<double> step_amplitudes_v{0.8, 1.5, 2.5, 3.5, 5.0};
  double step_hold_s = 1.0;
  double preset_m = 0.07;          // |x| the preset brings the piston to, opposite the step
  double preset_tolerance_m = 0.01;
  double preset_gain_v_m = 25.0;   // preset PD law (volts per metre, per m/s)
  double preset_damping_v_s_m = 6.0;
  double preset_max_v = 1.5;
  double preset_timeout_s = 1.5;
  // Multi-level pseudo-random sequence: a level from prbs_levels_v (either sign, uniformly)
  // held for a time uniform in [prbs_min_hold_s, prbs_max_hold_s].
  std::vector<double> prbs_levels_v{0.3, 0.6, 1.0, 1.6, 2.5, 3.5, 5.0};
  double prbs_min_hold_s = 0.05;
  double prbs_max_hold_s = 0.4;
  // Chirp: amplitude and linear frequency sweep.
  double chirp_amplitude_v = 1.5;
  double chirp_start_hz = 0.3;
  double chirp_end_hz = 4.0;
  // Position guard (piston position x from mid-stroke, eq 64).
  double guard_m = 0.09;         // |x + v lead| beyond this -> return towards mid-stroke
  double guard_lead_s = 0.04;    // look-ahead of the guard
  double release_m = 0.03;       // hand back to the sequence once |x| is below this ...
  double release_speed_m_s = 0.3;  // ... and the leg slower than this
  double guard_gain_v_m = 30.0;  // return law: volts per metre of x ...
  double guard_damping_v_s_m = 4.0;  // ... plus volts per m/s of velocity
  double guard_max_v = 4.0;      // bound of the return command (V from null)
  double speed_filter_s = 0.005; // time constant of the guard's speed estimate

  bool enabled() const { return duration_s > 0.0; }
  bool Active(double time_s) const {
    return enabled() && time_s >= start_s && time_s < start_s + duration_s;
  }
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate(const ValveParams& valve, const CylinderParams& cylinder) const;
};

// The identification experiment's schedule (docs/identification.md, "Experiment"): the legs
// in `legs` (1..6) are excited one after the other, each for `per_leg_s`, after `lead_in_s`
// of closed-loop hold and with `gap_s` of hold between legs (the leg returns to its setpoint
// and the platform settles); seeds seed * 10 + leg. The same plan for the DDS session
// (hexa_session --experiment identify) and the in-process one (hexa_sim --experiment).
struct ExcitationPlan {
  LegArray<ExcitationParams> legs{};
  double total_duration_s = 0.0;
};
ExcitationPlan PlanIdentificationExperiment(const std::vector<int>& legs, double per_leg_s,
                                            std::uint64_t seed, double lead_in_s = 1.0,
                                            double gap_s = 1.5);

class ExcitationGenerator {
 public:
  // Validates (throws) and draws the pseudo-random sequence.
  ExcitationGenerator(const ExcitationParams& params, const ValveParams& valve,
                      const CylinderParams& cylinder);

  // Valve voltage at simulated time `time_s` (inside the window) for the measured leg length.
  // Never throws or allocates; always in the valve's range.
  double Update(double time_s, double length_m);
  bool guarding() const { return guarding_; }
  const ExcitationParams& params() const { return params_; }

 private:
  double SequenceOffsetV(double t_s) const;  // signed volts from null (negative = extend)
  double StepsOffsetV(double t_s, double x_m);  // the steps phase (stateful)

  ExcitationParams params_;
  ValveParams valve_;
  double mid_m_ = 0.0;
  double extend_sign_ = -1.0;  // sign of (u - null) that extends (eq 42: a < 0)
  std::vector<double> prbs_switch_s_;  // start times of the pseudo-random levels
  std::vector<double> prbs_level_v_;   // signed
  bool guarding_ = false;
  // Steps phase: index of the step, whether its preset is still running, when it began.
  std::size_t step_index_ = 0;
  bool presetting_ = true;
  double phase_start_s_ = 0.0;
  bool has_last_ = false;
  double last_x_m_ = 0.0, last_time_s_ = 0.0, speed_m_s_ = 0.0;
};

}  // namespace hexa
