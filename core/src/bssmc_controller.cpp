#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/math_constants.hpp"

#include "hexa/core/friction.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/pneumatics.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hexa {
namespace {

DifferentiatorConfig DiffConfig(const BsSmcConfig& c) {
  DifferentiatorConfig d;
  d.params = c.differentiator;
  d.sample_period_s = c.period_s;
  return d;
}

// 1 - exp(-(v / v_ref)^2): 0 at rest, 1 well above v_ref. The speed schedule of the feedback
// rate and the speed weight w of the friction adaptation.
double RisingSpeedWeight(double velocity_m_s, double reference_m_s) {
  const double r = velocity_m_s / reference_m_s;
  return 1.0 - std::exp(-r * r);
}

LegObserverConfig ObserverConfig(const BsSmcConfig& c) {
  LegObserverConfig o;
  o.period_s = c.period_s;
  o.mass_kg = c.params.observer_mass_kg;
  o.length_sigma_m = c.params.observer_length_sigma_m;
  o.force_sigma_n = c.params.observer_force_sigma_n;
  o.disturbance_rate_m_s3 = c.params.observer_disturbance_rate_m_s3;
  return o;
}

}  // namespace

NominalLegModel NominalLegModel::FromRig(const RigParams& rig) {
  NominalLegModel m;
  m.air = rig.air;
  m.cylinder = rig.cylinder;
  m.valve = rig.valve;
  m.friction = rig.friction;
  m.polytropic = rig.polytropic;
  return m;
}

void BsSmcConfig::Validate() const {
  // The gains and the controller's nominal model with the rig file's rules (param_checks.hpp).
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckBsSmcParams(c, params);
  CheckAirParams(c, model.air);
  CheckCylinderParams(c, model.cylinder);
  CheckValveParams(c, model.valve);
  CheckFrictionParams(c, model.friction);
  CheckPolytropicSet(c, model.polytropic);
  c.Positive("period_s", period_s, "control period");
  if (period_s > 0.0) {
    c.InClosed("params.dither_frequency_hz", params.dither_frequency_hz, 0.0, 0.25 / period_s,
               "dither frequency (at least 4 control periods per cycle)");
  }
  ThrowIfIssues(issues, "BsSmcConfig");
  DiffConfig(*this).Validate();
}

BsSmcController::BsSmcController(const BsSmcConfig& config)
    : config_((config.Validate(), config)),
      orifice_(config.model.air, config.model.valve.discharge_coefficient,
               kDefaultLaminarPressureRatio),
      velocity_diff_(DiffConfig(config)),
      force_diff_(DiffConfig(config)),
      observer_(ObserverConfig(config)) {}

void BsSmcController::Reset() {
  velocity_diff_.Reset();
  force_diff_.Reset();
  observer_.Reset();
  filtered_spool_m_ = 0.0;
  integral_force_n_ = 0.0;
  feedback_primed_ = false;
  previous_feedback_n_ = 0.0;
  feedback_rate_n_s_ = 0.0;
}

double BsSmcController::SpoolFractionForArea(double area_fraction) const {
  // eq 43 inverted: A_v / A_max = (X / X_max)^2. Near null the square root has an infinite
  // slope; inside the band r < r0 it is replaced by its chord r / sqrt(r0) (same value at r0).
  const double r = std::min(std::max(area_fraction, 0.0), 1.0);
  const double r0 = config_.params.null_band_area_fraction;
  if (r < r0) return r / std::sqrt(r0);
  return std::sqrt(r);
}

double BsSmcController::FrictionEstimateN(double velocity_m_s) const {
  // Eq 14's bracket: F_c sgn(v) + (F_s - F_c) exp(-(v/v_s)^2) sgn(v), per stroke direction
  // (Table 8 as magnitudes), sgn smoothed to tanh(v / v_eps) so that the estimate is
  // continuous through a reversal (docs/controller.md).
  const double magnitude =
      StribeckLevelN(FrictionForDirection(config_.model.friction, velocity_m_s), velocity_m_s);
  return config_.params.friction_estimate_scale * magnitude *
         std::tanh(velocity_m_s / config_.params.friction_smoothing_velocity_m_s);
}

double BsSmcController::FeedbackRateFraction(double desired_velocity_m_s) const {
  const BsSmcParams& p = config_.params;
  if (p.feedback_rate_full_speed_m_s <= 0.0) return p.feedback_rate_fraction;
  return p.feedback_rate_fraction * RisingSpeedWeight(desired_velocity_m_s, p.feedback_rate_full_speed_m_s);
}

double BsSmcController::DitherForceN(std::uint64_t tick, double desired_velocity_m_s) const {
  const BsSmcParams& p = config_.params;
  if (p.dither_amplitude_n <= 0.0) return 0.0;
  // Period N ticks (f rounded to 1 / (N period_s), N >= 4 by validation); the phase from the
  // tick modulo N stays exact however long the run.
  const auto n = static_cast<std::uint64_t>(std::llround(1.0 / (p.dither_frequency_hz * config_.period_s)));
  const double phase = 2.0 * kPi * static_cast<double>(tick % n) / static_cast<double>(n);
  const double q = desired_velocity_m_s / p.dither_gate_speed_m_s;
  return p.dither_amplitude_n * std::sin(phase) * std::exp(-q * q);
}

void BsSmcController::Update(const BsSmcInput& in, BsSmcOutput& out) {
  Begin(in);
  Complete(in, nullptr, out);
}

void BsSmcController::Finish(const BsSmcInput& in, const BsSmcFeedback& applied, BsSmcOutput& out) {
  Complete(in, &applied, out);
}

void BsSmcController::FinishOwn(const BsSmcInput& in, BsSmcOutput& out) { Complete(in, nullptr, out); }

BsSmcFeedback BsSmcController::Begin(const BsSmcInput& in) {
  const BsSmcParams& p = config_.params;
  const NominalLegModel& m = config_.model;
  const CylinderParams& cyl = m.cylinder;
  const double mid_m = cyl.mid_stroke_length_m;

  // States (eq 15): x1 = x, x2 = v, x3 = P1, x4 = P2.
  const double x_m = in.length_m - mid_m;
  const double v_m_s = velocity_diff_.Update(x_m);  // eq 40 on the measured position
  const double xd_m = in.desired_length_m - mid_m;
  const double e_m = x_m - xd_m;
  const bool observer_used = p.feedback_rate_fraction > 0.0 && p.feedback_rate_from_observer;
  const double observer_force_n = in.has_observer_force
                                      ? in.observer_force_n
                                      : in.cap_pressure_pa * cyl.cap_area_m2 -
                                            in.rod_pressure_pa * cyl.annulus_area_m2 -
                                            m.air.atmosphere_pressure_pa * cyl.rod_area_m2;
  bool observer_updated = false;
  double v_feedback_m_s = v_m_s;
  if (in.feedback_velocity_from_observer && observer_used) {
    observer_.Update(x_m, observer_force_n);
    observer_updated = true;
    v_feedback_m_s = observer_.velocity_m_s();
  }
  if (in.has_feedback_velocity) v_feedback_m_s = in.feedback_velocity_m_s;
  const double edot_m_s = v_feedback_m_s - in.desired_velocity_m_s;
  const double s_m_s = edot_m_s + p.lambda_1_s * e_m;  // eq 19

  // Load model (eq 14, 18 with M kept): M x_ddot = phi_p - B x_dot + C, where
  // C = -Pa Ar - F_g - F_fric(v). Friction and viscous estimates are evaluated at the
  // desired velocity (feed-forward, see docs).
  const double vd = in.desired_velocity_m_s;
  const FrictionDirectionParams& fd = vd >= 0.0 ? m.friction.extend : m.friction.retract;
  double b_hat = p.viscous_estimate_scale * fd.viscous_n_s_m;  // eq 21
  // Friction estimate of eq 14 at v_d, plus the dither (not in the paper; control_params.hpp).
  double friction_n = FrictionEstimateN(vd);
  if (p.friction_adaptation_rate_1_n_m > 0.0) {
    // Friction scale adaptation at speed (not in the paper; control_params.hpp): the regressor
    // F_r = F_f(v_d) + B_hat v_d, weighted by w(v_d); theta_dot = -gamma w S F_r, projected.
    const double w = RisingSpeedWeight(vd, p.friction_adaptation_speed_m_s);
    const double regressor_n = friction_n + b_hat * vd;
    const double step = -p.friction_adaptation_rate_1_n_m * w * s_m_s * regressor_n * config_.period_s;
    if (std::isfinite(step)) {
      friction_scale_ = std::clamp(friction_scale_ + step, p.friction_adaptation_min_scale,
                                   p.friction_adaptation_max_scale);
    }
    const double k = 1.0 + (friction_scale_ - 1.0) * w;
    friction_n *= k;
    b_hat *= k;
  }
  friction_n += DitherForceN(in.tick, vd);
  double phi_hat = 0.0;
  if (in.has_feedforward) {
    // Known load: the platform inverse dynamics takes the place of M x_ddot_d and
    // of the lumped gravity constant F_g; M stays as the gain of the feedback M lambda e_dot.
    const double c_hat = -m.air.atmosphere_pressure_pa * cyl.rod_area_m2 - in.feedforward_force_n -
                         friction_n;  // eq 14
    phi_hat = -p.effective_mass_kg * p.lambda_1_s * edot_m_s + b_hat * vd - c_hat;  // eq 25
  } else {
    const double c_hat = -m.air.atmosphere_pressure_pa * cyl.rod_area_m2 - p.gravity_load_n -
                         friction_n;  // eq 14
    phi_hat = p.effective_mass_kg * (in.desired_acceleration_m_s2 - p.lambda_1_s * edot_m_s) +
              b_hat * vd - c_hat;  // eq 25
  }
  // Integral of S (not in the paper, control_params.hpp): removes the steady error that
  // static friction leaves against the bounded terms. The clamp is the anti-windup.
  if (std::isfinite(s_m_s)) {
    if (std::abs(in.desired_velocity_m_s) < p.integral_active_below_m_s) {
      if (std::abs(e_m) >= p.integral_deadband_m)
      integral_force_n_ += p.integral_gain_n_m * s_m_s * config_.period_s;
    } else {
      integral_force_n_ -= integral_force_n_ * config_.period_s /
                           (p.integral_leak_time_constant_s + config_.period_s);
    }
    integral_force_n_ = std::clamp(integral_force_n_, -p.integral_limit_n, p.integral_limit_n);
  }
  // phi_dot (eq 38): the paper differentiates phi numerically (eq 40). Only its model part
  // is differentiated here: the feedback part (lambda e_dot, K tanh(xi S)) is sensor noise
  // at 1 kHz and its derivative drove a 34 Hz limit cycle (docs/controller.md); beta z
  // corrects what the model part misses.
  const double phi_model = phi_hat + p.effective_mass_kg * p.lambda_1_s * edot_m_s;
  const double phi_dot_model = force_diff_.Update(phi_model);  // eq 40
  // This leg's feedback part f (eq 45's feedback terms with k_s S): its rate below; what a
  // coupled feedback mixes across the legs (Finish).
  const double feedback_n = -p.effective_mass_kg * p.lambda_1_s * edot_m_s -
                            p.switching_gain_n * std::tanh(p.boundary_layer_xi_s_m * s_m_s) -
                            p.reaching_proportional_n_s_m * s_m_s;
  // Optional band-limited rate of the feedback part (deviation from eq 38):
  // dirty derivative s / (tau s + 1) by backward Euler, y_k = (tau y_k-1 + u_k - u_k-1) / (tau + h).
  // Observer variant: the rate is analytic, from the leg observer's acceleration and
  // velocity, low-passed y_k = (tau y_k-1 + h r_k) / (tau + h).
  if (p.feedback_rate_fraction > 0.0) {
    const double tau = p.feedback_rate_time_constant_s;
    const double h = config_.period_s;
    if (p.feedback_rate_from_observer) {
      if (!observer_updated) observer_.Update(x_m, observer_force_n);
      const double eddot = observer_.acceleration_m_s2() - in.desired_acceleration_m_s2;
      const double sdot = eddot + p.lambda_1_s * (observer_.velocity_m_s() - in.desired_velocity_m_s);
      const double th = std::tanh(p.boundary_layer_xi_s_m * s_m_s);
      const double rate = -p.effective_mass_kg * p.lambda_1_s * eddot -
                          (p.switching_gain_n * p.boundary_layer_xi_s_m * (1.0 - th * th) +
                           p.reaching_proportional_n_s_m) * sdot;
      if (std::isfinite(rate)) feedback_rate_n_s_ = (tau * feedback_rate_n_s_ + h * rate) / (tau + h);
    } else {
      if (feedback_primed_ && std::isfinite(feedback_n)) {
        feedback_rate_n_s_ = (tau * feedback_rate_n_s_ + (feedback_n - previous_feedback_n_)) / (tau + h);
      }
      feedback_primed_ = std::isfinite(feedback_n);
      previous_feedback_n_ = feedback_n;
    }
  }
  stage_.x_m = x_m;
  stage_.v_m_s = v_m_s;
  stage_.s_m_s = s_m_s;
  stage_.phi_hat_n = phi_hat;
  stage_.phi_model_n = phi_model;
  stage_.phi_dot_model_n_s = phi_dot_model;
  return BsSmcFeedback{feedback_n, feedback_rate_n_s_};
}

void BsSmcController::Complete(const BsSmcInput& in, const BsSmcFeedback* applied,
                               BsSmcOutput& out) {
  const BsSmcParams& p = config_.params;
  const NominalLegModel& m = config_.model;
  const CylinderParams& cyl = m.cylinder;
  const double x_m = stage_.x_m;
  const double v_m_s = stage_.v_m_s;
  const double s_m_s = stage_.s_m_s;
  const double vd = in.desired_velocity_m_s;
  // eq 45, plus the proportional reaching term -k_s S and the integral term (not in the paper).
  // Coupled (docs/measurements/control_coupled_feedback.md "Coupled leg feedback"): the feedback part is the mix the
  // caller hands over instead of this leg's own.
  const double phi =
      applied ? stage_.phi_model_n + applied->force_n - integral_force_n_
              : stage_.phi_hat_n - p.switching_gain_n * std::tanh(p.boundary_layer_xi_s_m * s_m_s) -
                    p.reaching_proportional_n_s_m * s_m_s - integral_force_n_;
  double phi_dot = stage_.phi_dot_model_n_s;
  if (p.feedback_rate_fraction > 0.0) {
    phi_dot += FeedbackRateFraction(vd) * (applied ? applied->rate_n_s : feedback_rate_n_s_);
  }

  // Backstepping (eq 35, 38): drive z to zero at rate beta.
  const double p1 = in.cap_pressure_pa;
  const double p2 = in.rod_pressure_pa;
  const double z_n = p1 * cyl.cap_area_m2 - p2 * cyl.annulus_area_m2 - phi;  // eq 35
  const double force_rate_required = phi_dot - p.backstepping_beta_1_s * z_n;  // eq 38

  // Pressure dynamics (eq 7, 65) and volumes (eq 64): the plant's functions (pneumatics.hpp).
  // A1 P1' - A2 P2' is affine in the orifice area A_v for a given routing: the flows of eq 4
  // scale with A_v. `force_rate` evaluates it for flows per unit area (m1, m2) and volume
  // rates; the motion part (compression / expansion, gamma_k) is the one with zero flow.
  const double half = 0.5 * cyl.stroke_m;
  const double xc = std::clamp(x_m, -half, half);
  const double v1 = Chamber1VolumeM3(cyl, xc);
  const double v2 = Chamber2VolumeM3(cyl, xc);
  const double dv1 = cyl.cap_area_m2 * v_m_s;
  const double dv2 = -cyl.annulus_area_m2 * v_m_s;
  const double rt = m.air.gas_constant_j_kg_k * m.air.temperature_k;
  auto force_rate = [&](const PolytropicParams& g, double m1, double m2, double dvol1, double dvol2) {
    return cyl.cap_area_m2 * ChamberPressureRatePaS(rt, g, m1, p1, v1, dvol1) -
           cyl.annulus_area_m2 * ChamberPressureRatePaS(rt, g, m2, p2, v2, dvol2);
  };
  const PolytropicParams& motion = v_m_s >= 0.0 ? m.polytropic.extend : m.polytropic.retract;
  // Force rate caused by the motion alone (compression / expansion, gamma_k terms).
  const double motion_rate = force_rate(motion, 0.0, 0.0, dv1, dv2);
  // What the valve flow must contribute (eq 44's numerator, with the outflow kept).
  const double flow_rate_required = force_rate_required - motion_rate;

  const double ps = in.supply_pressure_pa;
  const double pa = m.air.atmosphere_pressure_pa;
  const ValveParams& valve = m.valve;
  // Eq 4 per unit orifice area in the routing's intended direction only (a chamber above
  // supply would flow back: that gains nothing and is not counted).
  auto unit_flow = [&](double upstream_pa, double downstream_pa) {
    return upstream_pa > downstream_pa ? orifice_.ForwardKgS(1.0, upstream_pa, downstream_pa) : 0.0;
  };
  double spool_m = 0.0;
  if (flow_rate_required >= 0.0) {
    // Extend routing (Table 4): supply -> chamber 1, chamber 2 -> exhaust. Spool > 0.
    const double gain =
        force_rate(m.polytropic.extend, unit_flow(ps, p1), -unit_flow(p2, pa), 0.0, 0.0);
    const double area = gain > 1e-12 ? flow_rate_required / gain : valve.max_orifice_area_m2;
    spool_m = valve.max_spool_m * SpoolFractionForArea(area / valve.max_orifice_area_m2);  // eq 43
  } else {
    // Retract routing (Table 5): supply -> chamber 2, chamber 1 -> exhaust. Spool < 0.
    const double gain =
        -force_rate(m.polytropic.retract, -unit_flow(p1, pa), unit_flow(ps, p2), 0.0, 0.0);
    const double area = gain > 1e-12 ? -flow_rate_required / gain : valve.max_orifice_area_m2;
    spool_m = -valve.max_spool_m * SpoolFractionForArea(area / valve.max_orifice_area_m2);
  }
  // Optional first-order low-pass on the spool command (backward Euler, stable for any time
  // constant): bounds the tick-to-tick spool motion the sensor noise still causes.
  if (p.spool_filter_time_constant_s > 0.0 && std::isfinite(spool_m)) {
    const double a = config_.period_s / (p.spool_filter_time_constant_s + config_.period_s);
    filtered_spool_m_ += a * (spool_m - filtered_spool_m_);
    spool_m = filtered_spool_m_;
  }
  double u_v = (spool_m - valve.spool_offset_m) / valve.spool_gain_m_v;  // eq 42 inverted (eq 44)
  const double u_clamped = std::clamp(u_v, valve.min_voltage_v, valve.max_voltage_v);

  out.saturated = u_clamped != u_v;
  out.valve_v = std::isfinite(u_v) ? u_clamped : valve.null_voltage_v;
  out.sliding_surface_m_s = s_m_s;
  out.velocity_m_s = v_m_s;
  out.feedback_rate_n_s = FeedbackRateFraction(vd) * feedback_rate_n_s_;
  out.friction_scale = friction_scale_;
  out.desired_force_n = phi;
  out.desired_force_rate_n_s = phi_dot;
  out.force_error_n = z_n;
  out.spool_m = spool_m;
  if (!std::isfinite(phi) || !std::isfinite(phi_dot)) {
    // A non-finite value would poison the differentiator rings for a whole window.
    Reset();
    out.valve_v = valve.null_voltage_v;
  }
}

}  // namespace hexa
