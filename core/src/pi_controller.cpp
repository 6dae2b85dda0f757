#include "hexa/core/pi_controller.hpp"

#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hexa {
void PiConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckPiParams(c, params);
  CheckValveParams(c, valve);
  c.Positive("period_s", period_s, "control period");
  ThrowIfIssues(issues, "PiConfig");
}

namespace {
DifferentiatorConfig PiDiffConfig(const PiConfig& c) {
  DifferentiatorConfig d;
  d.params = c.differentiator;
  d.sample_period_s = c.period_s;
  return d;
}
}  // namespace

PiController::PiController(const PiConfig& config)
    : config_((config.Validate(), config)), velocity_diff_(PiDiffConfig(config)) {}

void PiController::Reset() {
  integral_v_ = 0.0;
  velocity_diff_.Reset();
}

void PiController::Update(const PiInput& in, PiOutput& out) {
  const PiParams& p = config_.params;
  const ValveParams& valve = config_.valve;
  const double direction = valve.spool_gain_m_v < 0.0 ? -1.0 : 1.0;  // sign(a), eq 42
  const double e_m = in.desired_length_m - in.length_m;
  if (!std::isfinite(e_m) || !std::isfinite(in.desired_velocity_m_s)) {
    Reset();  // a non-finite sample would poison the differentiator window
    out.valve_v = valve.null_voltage_v;
    out.error_m = e_m;
    out.integral_v = integral_v_;
    out.velocity_m_s = 0.0;
    out.saturated = false;
    return;
  }
  const double v_m_s = velocity_diff_.Update(in.length_m);  // eq 40
  // Velocity terms: the valve opening sets a flow, i.e. roughly a piston speed, so the
  // setpoint speed is fed forward and the velocity error is damped.
  double rate_v = p.velocity_feedforward_v_s_m * in.desired_velocity_m_s +
                  p.rate_damping_v_s_m * (in.desired_velocity_m_s - v_m_s);
  if (in.has_feedforward) {
    // Known load: drive the measured pneumatic force towards the feed-forward.
    const CylinderParams& c = config_.cylinder;
    const double force_n = in.cap_pressure_pa * c.cap_area_m2 - in.rod_pressure_pa * c.annulus_area_m2 -
                           config_.atmosphere_pressure_pa * c.rod_area_m2;
    const double term_v = p.force_feedforward_v_n * (in.feedforward_force_n - force_n);
    if (std::isfinite(term_v)) rate_v += term_v;
  }
  auto voltage = [&](double integral_v) {
    return valve.null_voltage_v + direction * (p.proportional_v_m * e_m + integral_v + rate_v);
  };
  const double candidate =
      std::clamp(integral_v_ + p.integral_v_m_s * e_m * config_.period_s, -p.integrator_limit_v,
                 p.integrator_limit_v);
  const double u_candidate = voltage(candidate);
  // Conditional integration: keep the old integral when the output is saturated and the
  // integration would push it further into saturation.
  const double du_v = direction * (candidate - integral_v_);
  const bool winds_up = (u_candidate > valve.max_voltage_v && du_v > 0.0) ||
                        (u_candidate < valve.min_voltage_v && du_v < 0.0);
  if (!winds_up) integral_v_ = candidate;
  const double u = voltage(integral_v_);
  const double u_clamped = std::clamp(u, valve.min_voltage_v, valve.max_voltage_v);
  out.valve_v = u_clamped;
  out.saturated = u_clamped != u;
  out.error_m = e_m;
  out.integral_v = integral_v_;
  out.velocity_m_s = v_m_s;
}

}  // namespace hexa
