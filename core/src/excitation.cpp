#include "hexa/core/excitation.hpp"
#include "hexa/core/math_constants.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hexa {
namespace {

void Require(bool ok, const char* field, double value, const char* limit) {
  if (ok) return;
  std::ostringstream m;
  m << "excitation: " << field << " = " << value << " must be " << limit;
  throw std::invalid_argument(m.str());
}

}  // namespace

void ExcitationParams::Validate(const ValveParams& valve, const CylinderParams& cyl) const {
  Require(std::isfinite(start_s) && start_s >= 0.0, "start_s", start_s, "finite and >= 0");
  Require(std::isfinite(duration_s) && duration_s >= 0.0, "duration_s", duration_s, "finite and >= 0");
  Require(steps_fraction >= 0.0 && prbs_fraction >= 0.0 && steps_fraction + prbs_fraction <= 1.0,
          "steps_fraction + prbs_fraction", steps_fraction + prbs_fraction, "in [0, 1], parts >= 0");
  const double span = std::min(valve.null_voltage_v - valve.min_voltage_v,
                               valve.max_voltage_v - valve.null_voltage_v);
  Require(!step_amplitudes_v.empty(), "step_amplitudes_v (count)", 0, ">= 1");
  for (double a : step_amplitudes_v) {
    Require(a > 0.0 && a <= span, "step_amplitudes_v[]", a, "in (0, the valve's span from null]");
  }
  Require(step_hold_s > 0.0, "step_hold_s", step_hold_s, "> 0");
  Require(preset_m >= 0.0 && preset_m < guard_m, "preset_m", preset_m, "in [0, guard_m)");
  Require(preset_tolerance_m > 0.0, "preset_tolerance_m", preset_tolerance_m, "> 0");
  Require(preset_gain_v_m > 0.0 && preset_damping_v_s_m >= 0.0, "preset_gain_v_m", preset_gain_v_m,
          "> 0 (and preset_damping_v_s_m >= 0)");
  Require(preset_max_v > 0.0 && preset_max_v <= span, "preset_max_v", preset_max_v,
          "in (0, the valve's span from null]");
  Require(preset_timeout_s > 0.0, "preset_timeout_s", preset_timeout_s, "> 0");
  Require(!prbs_levels_v.empty(), "prbs_levels_v (count)", 0, ">= 1");
  for (double a : prbs_levels_v) {
    Require(a > 0.0 && a <= span, "prbs_levels_v[]", a, "in (0, the valve's span from null]");
  }
  Require(prbs_min_hold_s > 0.0 && prbs_max_hold_s >= prbs_min_hold_s, "prbs_max_hold_s",
          prbs_max_hold_s, ">= prbs_min_hold_s > 0");
  Require(chirp_amplitude_v > 0.0 && chirp_amplitude_v <= span, "chirp_amplitude_v",
          chirp_amplitude_v, "in (0, the valve's span from null]");
  Require(chirp_start_hz > 0.0 && chirp_end_hz >= chirp_start_hz, "chirp_end_hz", chirp_end_hz,
          ">= chirp_start_hz > 0");
  Require(guard_m > 0.0 && guard_m < 0.5 * cyl.stroke_m, "guard_m", guard_m,
          "in (0, half the stroke)");
  Require(release_m >= 0.0 && release_m < guard_m, "release_m", release_m, "in [0, guard_m)");
  Require(guard_gain_v_m > 0.0, "guard_gain_v_m", guard_gain_v_m, "> 0");
  Require(guard_lead_s >= 0.0, "guard_lead_s", guard_lead_s, ">= 0");
  Require(release_speed_m_s > 0.0, "release_speed_m_s", release_speed_m_s, "> 0");
  Require(guard_damping_v_s_m >= 0.0, "guard_damping_v_s_m", guard_damping_v_s_m, ">= 0");
  Require(speed_filter_s >= 0.0, "speed_filter_s", speed_filter_s, ">= 0");
  Require(guard_max_v > 0.0 && guard_max_v <= span, "guard_max_v", guard_max_v,
          "in (0, the valve's span from null]");
}

ExcitationPlan PlanIdentificationExperiment(const std::vector<int>& legs, double per_leg_s,
                                            std::uint64_t seed, double lead_in_s, double gap_s) {
  ExcitationPlan plan;
  double t = lead_in_s;
  for (int leg : legs) {
    if (leg < 1 || leg > static_cast<int>(kNumLegs)) {
      throw std::invalid_argument("excitation plan: leg " + std::to_string(leg) + " outside [1, 6]");
    }
    ExcitationParams& p = plan.legs[static_cast<std::size_t>(leg - 1)];
    p.start_s = t;
    p.duration_s = per_leg_s;
    p.seed = seed * 10 + static_cast<std::uint64_t>(leg);
    t += per_leg_s + gap_s;
  }
  plan.total_duration_s = t;
  return plan;
}

ExcitationGenerator::ExcitationGenerator(const ExcitationParams& params, const ValveParams& valve,
                                         const CylinderParams& cylinder)
    : params_(params), valve_(valve), mid_m_(cylinder.mid_stroke_length_m) {
  params_.Validate(valve, cylinder);
  // Eq 42: X_spool = a u + b, X_spool > 0 extends; a < 0 means lower voltages extend.
  extend_sign_ = valve.spool_gain_m_v < 0.0 ? -1.0 : 1.0;
  // The pseudo-random part, drawn once from the seed (portable: own uniform draws).
  std::mt19937_64 rng(params_.seed);
  auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const double length = params_.prbs_fraction * params_.duration_s;
  const std::size_t levels = params_.prbs_levels_v.size();
  for (double t = 0.0; t < length;) {
    const auto pick = std::min(levels - 1, static_cast<std::size_t>(uniform() * static_cast<double>(levels)));
    const double sign = uniform() < 0.5 ? -1.0 : 1.0;
    prbs_switch_s_.push_back(t);
    prbs_level_v_.push_back(sign * params_.prbs_levels_v[pick]);
    t += params_.prbs_min_hold_s + uniform() * (params_.prbs_max_hold_s - params_.prbs_min_hold_s);
  }
}

double ExcitationGenerator::StepsOffsetV(double t, double x) {
  const ExcitationParams& p = params_;
  // Step k: direction alternating (extend first), amplitudes cycled: E a0, R a0, E a1, ...
  const double direction = step_index_ % 2 == 0 ? 1.0 : -1.0;  // +1: extend (x grows)
  if (presetting_) {
    // Bring the piston to the far side first: x = -direction * preset_m.
    const double target = -direction * p.preset_m;
    if ((std::abs(x - target) < p.preset_tolerance_m && std::abs(speed_m_s_) < 0.15) ||
        t - phase_start_s_ > p.preset_timeout_s) {
      presetting_ = false;
      phase_start_s_ = t;
    } else {
      const double push = p.preset_gain_v_m * (target - x) - p.preset_damping_v_s_m * speed_m_s_;
      return extend_sign_ * std::clamp(push, -p.preset_max_v, p.preset_max_v);
    }
  }
  if (t - phase_start_s_ > p.step_hold_s) {  // the guard did not stop it: next step anyway
    ++step_index_;
    presetting_ = true;
    phase_start_s_ = t;
    return 0.0;
  }
  const double amplitude = p.step_amplitudes_v[(step_index_ / 2) % p.step_amplitudes_v.size()];
  return direction * extend_sign_ * amplitude;
}

double ExcitationGenerator::SequenceOffsetV(double t) const {
  const ExcitationParams& p = params_;
  const double steps_end = p.steps_fraction * p.duration_s;
  const double prbs_end = steps_end + p.prbs_fraction * p.duration_s;
  if (t < prbs_end && !prbs_switch_s_.empty()) {
    const double tp = t - steps_end;
    const auto it = std::upper_bound(prbs_switch_s_.begin(), prbs_switch_s_.end(), tp);
    const std::size_t k = it == prbs_switch_s_.begin() ? 0 : static_cast<std::size_t>(it - prbs_switch_s_.begin()) - 1;
    return prbs_level_v_[k];
  }
  // Linear chirp: phase = 2 pi (f0 tc + (f1 - f0) tc^2 / (2 T)).
  const double tc = t - prbs_end;
  const double chirp_length = std::max(p.duration_s - prbs_end, 1e-9);
  const double phase = 2.0 * kPi * (p.chirp_start_hz * tc +
                                    0.5 * (p.chirp_end_hz - p.chirp_start_hz) * tc * tc / chirp_length);
  return p.chirp_amplitude_v * std::sin(phase);
}

double ExcitationGenerator::Update(double time_s, double length_m) {
  const ExcitationParams& p = params_;
  const double x = length_m - mid_m_;
  if (!std::isfinite(x)) return valve_.null_voltage_v;
  // Speed from the measured lengths (first-order filtered difference).
  if (has_last_ && time_s > last_time_s_) {
    const double dt = time_s - last_time_s_;
    const double raw = (x - last_x_m_) / dt;
    speed_m_s_ += (raw - speed_m_s_) * dt / (p.speed_filter_s + dt);
  }
  has_last_ = true;
  last_x_m_ = x;
  last_time_s_ = time_s;
  const double t = time_s - p.start_s;
  const bool steps = t < p.steps_fraction * p.duration_s;
  const double predicted = x + speed_m_s_ * p.guard_lead_s;
  if (std::abs(predicted) > p.guard_m || std::abs(x) > p.guard_m) {
    if (!guarding_ && steps && !presetting_) {  // the step has run its course: next one
      ++step_index_;
      presetting_ = true;
    }
    guarding_ = true;
  } else if (guarding_ && std::abs(x) < p.release_m && std::abs(speed_m_s_) < p.release_speed_m_s) {
    guarding_ = false;
    phase_start_s_ = t;
  }
  double offset_v = 0.0;
  if (guarding_) {
    // Back towards mid-stroke, braking the motion: a PD law on x (extend sign for x < 0).
    const double push = -(p.guard_gain_v_m * x + p.guard_damping_v_s_m * speed_m_s_);  // > 0: extend
    offset_v = extend_sign_ * std::clamp(push, -p.guard_max_v, p.guard_max_v);
  } else if (steps) {
    offset_v = StepsOffsetV(t, x);
  } else {
    offset_v = SequenceOffsetV(t);
  }
  return std::clamp(valve_.null_voltage_v + offset_v, valve_.min_voltage_v, valve_.max_voltage_v);
}

}  // namespace hexa
