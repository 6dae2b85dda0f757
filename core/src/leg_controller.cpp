#include "hexa/core/leg_controller.hpp"

#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hexa {
namespace {

// No control law ran this tick (hold, open-loop excitation): its outputs read 0.
void ClearLawOutputs(LegControllerOutput& out) {
  out.desired_velocity_m_s = 0.0;
  out.feedforward_force_n = 0.0;
  out.sliding_surface_m_s = 0.0;
  out.velocity_m_s = 0.0;
  out.desired_force_n = 0.0;
  out.force_error_n = 0.0;
  out.desired_force_rate_n_s = 0.0;
}

// Supply below half the nominal gauge pressure: the flow model (eq 4, 5) no longer describes
// the valve (docs/faults.md).
double MinSupplyPressure_pa(const AirParams& air) {
  return air.atmosphere_pressure_pa + 0.5 * (air.supply_pressure_pa - air.atmosphere_pressure_pa);
}

BsSmcConfig MakeBsSmcConfig(const LegControllerConfig& c) {
  BsSmcConfig b;
  b.params = c.params.bssmc;
  b.differentiator = c.params.differentiator;
  b.model = c.model;
  b.period_s = c.period_s;
  return b;
}

PiConfig MakePiConfig(const LegControllerConfig& c) {
  PiConfig p;
  p.params = c.params.pi;
  p.differentiator = c.params.differentiator;
  p.valve = c.model.valve;
  p.cylinder = c.model.cylinder;
  p.atmosphere_pressure_pa = c.model.air.atmosphere_pressure_pa;
  p.period_s = c.period_s;
  return p;
}

}  // namespace

const char* ToString(LegControlStatus status) {
  switch (status) {
    case LegControlStatus::kOk: return "ok";
    case LegControlStatus::kHoldNoSetpoint: return "hold_no_setpoint";
    case LegControlStatus::kHoldStaleSetpoint: return "hold_stale_setpoint";
    case LegControlStatus::kHoldBadInput: return "hold_bad_input";
    case LegControlStatus::kHoldSupervisor: return "hold_supervisor";
  }
  return "unknown";
}

LegControllerConfig LegControllerConfig::FromRig(const RigParams& rig, const LegControllerParams& params,
                                                 LegControllerKind kind) {
  LegControllerConfig c;
  c.kind = kind;
  c.params = params;
  c.model = NominalLegModel::FromRig(rig);
  c.min_supply_pressure_pa = MinSupplyPressure_pa(c.model.air);
  return c;
}

LegControllerConfig LegControllerConfig::FromModel(const ControllerModel& model,
                                                   std::size_t leg_index, LegControllerKind kind) {
  const LegControllerModel& leg = model.legs.at(leg_index);
  LegControllerConfig c;
  c.kind = kind;
  c.params = leg.params;
  c.model = leg.model;
  c.potentiometer = leg.potentiometer;
  c.min_supply_pressure_pa = MinSupplyPressure_pa(c.model.air);
  return c;
}

const char* ToString(LegInputFault fault) {
  switch (fault) {
    case LegInputFault::kNone: return "none";
    case LegInputFault::kTime: return "time";
    case LegInputFault::kLength: return "length";
    case LegInputFault::kCapPressure: return "cap pressure";
    case LegInputFault::kRodPressure: return "rod pressure";
    case LegInputFault::kSupplyPressure: return "supply pressure";
    case LegInputFault::kSupplyLow: return "supply pressure low";
    case LegInputFault::kSetpoint: return "setpoint";
  }
  return "unknown";
}

void LegControllerConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckLegControllerParams(c, params);
  c.Positive("period_s", period_s, "control period");
  c.NonNegative("length_margin_m", length_margin_m, "length margin");
  c.NonNegative("min_pressure_pa", min_pressure_pa, "pressure");
  if (c.Finite("max_pressure_pa", max_pressure_pa) && !(max_pressure_pa > min_pressure_pa)) {
    c.Fail("max_pressure_pa", "plausible pressure range is empty", FormatParam(max_pressure_pa),
           "> min_pressure_pa (" + FormatParam(min_pressure_pa) + ")");
  }
  if (c.Finite("min_supply_pressure_pa", min_supply_pressure_pa) &&
      !(min_supply_pressure_pa >= 0.0 && min_supply_pressure_pa < max_pressure_pa)) {
    c.Fail("min_supply_pressure_pa", "the lowest usable supply must lie below the plausible pressures",
           FormatParam(min_supply_pressure_pa), "[0, max_pressure_pa (" + FormatParam(max_pressure_pa) + "))");
  }
  c.Positive("max_setpoint_speed_m_s", max_setpoint_speed_m_s, "speed");
  c.Positive("max_setpoint_acceleration_m_s2", max_setpoint_acceleration_m_s2, "acceleration");
  c.NonNegative("max_correction_m", max_correction_m, "correction bound");
  c.Positive("max_feedforward_force_n", max_feedforward_force_n, "feed-forward force bound");
  c.Positive("max_feedforward_force_rate_n_s", max_feedforward_force_rate_n_s,
             "feed-forward force rate bound");
  CheckPotentiometerCalibrationParams(c, potentiometer, "potentiometer");
  ThrowIfIssues(issues, "LegControllerConfig");
  MakeBsSmcConfig(*this).Validate();
  MakePiConfig(*this).Validate();
  if (kind == LegControllerKind::kExcitation) excitation.Validate(model.valve, model.cylinder);
}

LegController::LegController(const LegControllerConfig& config)
    : config_((config.Validate(), config)),
      bssmc_(MakeBsSmcConfig(config)),
      pi_(MakePiConfig(config)),
      last_desired_length_m_(config.model.cylinder.mid_stroke_length_m) {
  potentiometer_calibrated_ =
      config_.potentiometer.offset_m != 0.0 || config_.potentiometer.gain != 1.0;
  if (config_.kind == LegControllerKind::kExcitation) {
    excitation_.emplace(config_.excitation, config_.model.valve, config_.model.cylinder);
  }
  if (config_.params.coupled.enabled && config_.kind == LegControllerKind::kBsSmc)
    coupling_.emplace(config_.params.coupled, config_.coupling_row, config_.leg_index, config_.period_s);
}

void AssignCouplingRow(const RigParams& supervisor_rig, std::size_t leg_index,
                       LegControllerConfig& config) {
  config.leg_index = leg_index;
  if (!config.params.coupled.enabled) return;
  config.coupling_row = CouplingRowAtHome(supervisor_rig, leg_index,
                                          config.params.bssmc.effective_mass_kg,
                                          config.params.coupled.raise_only);
}

void LegController::Interpolate(const LegControllerInput& in, double& length_m, double& velocity_m_s,
                                double& acceleration_m_s2) {
  if (in.hold) {  // supervisor hold: keep the commanded length at rest
    length_m = in.setpoint_length_m + in.correction_m;
    velocity_m_s = 0.0;
    acceleration_m_s2 = 0.0;
    return;
  }
  // Constant-acceleration extrapolation over the ticks inside the 5 ms setpoint period.
  const double dt = std::max(0.0, in.time_s - in.setpoint_time_s);
  length_m = in.setpoint_length_m + in.setpoint_velocity_m_s * dt +
             0.5 * in.setpoint_acceleration_m_s2 * dt * dt + in.correction_m;
  velocity_m_s = in.setpoint_velocity_m_s + in.setpoint_acceleration_m_s2 * dt;
  acceleration_m_s2 = in.setpoint_acceleration_m_s2;
}

bool LegController::LengthPlausible(double length_m) const {
  const CylinderParams& c = config_.model.cylinder;
  const double half = 0.5 * c.stroke_m + config_.length_margin_m;
  return std::isfinite(length_m) && std::abs(length_m - c.mid_stroke_length_m) <= half;
}

LegInputFault LegController::CheckSensors(const LegControllerInput& in, double& value) const {
  auto pressure_ok = [&](double p) {
    return std::isfinite(p) && p >= config_.min_pressure_pa && p <= config_.max_pressure_pa;
  };
  if (!std::isfinite(in.time_s)) return value = in.time_s, LegInputFault::kTime;
  if (!LengthPlausible(in.length_m)) return value = in.length_m, LegInputFault::kLength;
  if (!pressure_ok(in.cap_pressure_pa)) return value = in.cap_pressure_pa, LegInputFault::kCapPressure;
  if (!pressure_ok(in.rod_pressure_pa)) return value = in.rod_pressure_pa, LegInputFault::kRodPressure;
  if (!pressure_ok(in.supply_pressure_pa))
    return value = in.supply_pressure_pa, LegInputFault::kSupplyPressure;
  if (in.supply_pressure_pa < config_.min_supply_pressure_pa)
    return value = in.supply_pressure_pa, LegInputFault::kSupplyLow;
  return LegInputFault::kNone;
}

bool LegController::Hold(LegControlStatus status, LegControllerOutput& out, LegInputFault fault,
                         double value) {
  out.input_fault = fault;
  out.input_fault_value = value;
  if (active_) {  // histories would be stale when control resumes
    bssmc_.Reset();
    pi_.Reset();
    active_ = false;
  }
  out.valve_v = config_.model.valve.null_voltage_v;
  out.status = status;
  out.desired_length_m = last_desired_length_m_;
  ClearLawOutputs(out);
  return false;
}

void LegController::Update(const LegControllerInput& raw, LegControllerOutput& out) {
  out.feedback = FeedbackPart{};
  out.coupled = false;
  if (!Prepare(raw, out)) {
    if (coupling_) coupling_->Reset();
    return;
  }
  if (config_.kind == LegControllerKind::kPi) {
    RunPi(out);
  } else if (coupling_) {  // BS-SMC with the coupled feedback (coupled_legs.hpp)
    const BsSmcFeedback own = bssmc_.Begin(pending_);
    BsSmcFeedback applied;
    out.coupled = coupling_->Apply(own, raw.tick, raw.relayed, applied);
    BsSmcOutput o;
    if (out.coupled) {
      bssmc_.Finish(pending_, applied, o);
    } else {
      bssmc_.FinishOwn(pending_, o);  // the decoupled law, bit for bit
    }
    FinishBsSmc(o, out);
    out.feedback = FeedbackPart{std::isfinite(own.force_n) && std::isfinite(own.rate_n_s),
                                own.force_n, own.rate_n_s};
  } else {  // BS-SMC, also outside an excitation window
    BsSmcOutput o;
    bssmc_.Update(pending_, o);
    FinishBsSmc(o, out);
  }
}

void LegController::Update(const LegControllerInput& raw, LegControllerOutput& out,
                           double feedback_velocity_m_s) {
  if (!Prepare(raw, out)) return;
  if (config_.kind == LegControllerKind::kPi) {
    RunPi(out);
    return;
  }
  pending_.has_feedback_velocity = true;
  pending_.feedback_velocity_m_s = feedback_velocity_m_s;
  BsSmcOutput o;
  bssmc_.Update(pending_, o);
  FinishBsSmc(o, out);
}

std::optional<BsSmcFeedback> LegController::BeginCoupled(const LegControllerInput& raw,
                                                         LegControllerOutput& out,
                                                         std::optional<double> observer_force_n,
                                                         bool observer_velocity) {
  if (!Prepare(raw, out)) return std::nullopt;
  if (config_.kind == LegControllerKind::kPi) {
    RunPi(out);
    return std::nullopt;
  }
  if (observer_force_n) {
    pending_.has_observer_force = true;
    pending_.observer_force_n = *observer_force_n;
  }
  pending_.feedback_velocity_from_observer = observer_velocity;
  return bssmc_.Begin(pending_);
}

void LegController::FinishCoupled(const BsSmcFeedback& applied, LegControllerOutput& out) {
  BsSmcOutput o;
  bssmc_.Finish(pending_, applied, o);
  FinishBsSmc(o, out);
}

bool LegController::Prepare(const LegControllerInput& raw, LegControllerOutput& out) {
  // Kinematic calibration of the potentiometer (rig overlay): the reading of piston
  // position x is offset + gain x; the law works on the corrected length.
  LegControllerInput calibrated;
  const LegControllerInput* input = &raw;
  if (potentiometer_calibrated_) {
    calibrated = raw;
    const double mid = config_.model.cylinder.mid_stroke_length_m;
    calibrated.length_m =
        mid + (raw.length_m - mid - config_.potentiometer.offset_m) / config_.potentiometer.gain;
    input = &calibrated;
  }
  const LegControllerInput& in = *input;
  out.tick = in.tick;
  out.setpoint_tick = in.setpoint_tick;
  out.open_loop = false;
  out.guarding = false;
  double bad_value = 0.0;
  if (const LegInputFault f = CheckSensors(in, bad_value); f != LegInputFault::kNone)
    return Hold(LegControlStatus::kHoldBadInput, out, f, bad_value);
  if (excitation_ && config_.excitation.Active(in.time_s)) {
    // Identification: open-loop excitation with its position guard (excitation.hpp). The
    // closed-loop law restarts from fresh histories when the window ends.
    if (active_) {
      bssmc_.Reset();
      pi_.Reset();
      active_ = false;
    }
    out.valve_v = excitation_->Update(in.time_s, in.length_m);
    out.status = LegControlStatus::kOk;
    out.open_loop = true;
    out.guarding = excitation_->guarding();
    out.desired_length_m = in.length_m;
    ClearLawOutputs(out);
    return false;
  }
  if (!in.has_setpoint) return Hold(LegControlStatus::kHoldNoSetpoint, out);
  const double age_s = in.time_s - in.setpoint_time_s;
  if (!std::isfinite(in.setpoint_time_s) || !std::isfinite(age_s)) {
    return Hold(LegControlStatus::kHoldBadInput, out, LegInputFault::kSetpoint, in.setpoint_time_s);
  }
  if (age_s > config_.params.setpoint_timeout_s)
    return Hold(LegControlStatus::kHoldStaleSetpoint, out, LegInputFault::kNone, age_s);
  // A setpoint stamped more than half a period in the future is inconsistent.
  if (age_s < -0.5 * config_.period_s)
    return Hold(LegControlStatus::kHoldBadInput, out, LegInputFault::kSetpoint, age_s);
  if (!std::isfinite(in.setpoint_velocity_m_s) || !std::isfinite(in.setpoint_acceleration_m_s2) ||
      !std::isfinite(in.correction_m) ||
      std::abs(in.setpoint_velocity_m_s) > config_.max_setpoint_speed_m_s ||
      std::abs(in.setpoint_acceleration_m_s2) > config_.max_setpoint_acceleration_m_s2 ||
      std::abs(in.correction_m) > config_.max_correction_m) {
    return Hold(LegControlStatus::kHoldBadInput, out, LegInputFault::kSetpoint,
                in.setpoint_velocity_m_s);
  }
  if (in.feedforward_valid &&
      (!std::isfinite(in.feedforward_force_n) || !std::isfinite(in.feedforward_force_rate_n_s) ||
       std::abs(in.feedforward_force_n) > config_.max_feedforward_force_n ||
       std::abs(in.feedforward_force_rate_n_s) > config_.max_feedforward_force_rate_n_s)) {
    return Hold(LegControlStatus::kHoldBadInput, out);
  }
  // Feed-forward force at this tick: first-order hold over the setpoint period (none in a
  // supervisor hold: the force of a held setpoint is already the static load).
  double ff_n = 0.0;
  if (in.feedforward_valid) {
    const double dt = in.hold ? 0.0 : std::max(0.0, in.time_s - in.setpoint_time_s);
    ff_n = in.feedforward_force_n + in.feedforward_force_rate_n_s * dt;
  }
  double ld_m = 0.0, vd_m_s = 0.0, ad_m_s2 = 0.0;
  Interpolate(in, ld_m, vd_m_s, ad_m_s2);
  if (!LengthPlausible(ld_m) || !std::isfinite(vd_m_s))
    return Hold(LegControlStatus::kHoldBadInput, out, LegInputFault::kSetpoint, ld_m);

  active_ = true;
  out.input_fault = LegInputFault::kNone;
  out.input_fault_value = 0.0;
  last_desired_length_m_ = ld_m;
  out.status = in.hold ? LegControlStatus::kHoldSupervisor : LegControlStatus::kOk;
  out.desired_length_m = ld_m;
  out.desired_velocity_m_s = vd_m_s;
  out.feedforward_force_n = ff_n;
  BsSmcInput& b = pending_;
  b = BsSmcInput{};
  b.length_m = in.length_m;
  b.cap_pressure_pa = in.cap_pressure_pa;
  b.rod_pressure_pa = in.rod_pressure_pa;
  b.supply_pressure_pa = in.supply_pressure_pa;
  b.desired_length_m = ld_m;
  b.desired_velocity_m_s = vd_m_s;
  b.desired_acceleration_m_s2 = ad_m_s2;
  b.has_feedforward = in.feedforward_valid;
  b.feedforward_force_n = ff_n;
  b.tick = in.tick;
  return true;
}

void LegController::FinishBsSmc(const BsSmcOutput& o, LegControllerOutput& out) {
  out.valve_v = o.valve_v;
  out.sliding_surface_m_s = std::isfinite(o.sliding_surface_m_s) ? o.sliding_surface_m_s : 0.0;
  out.velocity_m_s = std::isfinite(o.velocity_m_s) ? o.velocity_m_s : 0.0;
  out.desired_force_n = std::isfinite(o.desired_force_n) ? o.desired_force_n : 0.0;
  out.force_error_n = std::isfinite(o.force_error_n) ? o.force_error_n : 0.0;
  out.desired_force_rate_n_s = std::isfinite(o.desired_force_rate_n_s) ? o.desired_force_rate_n_s : 0.0;
  out.friction_scale = o.friction_scale;
  Defend(out);
}

void LegController::RunPi(LegControllerOutput& out) {
  const BsSmcInput& b = pending_;
  PiInput p;
  p.length_m = b.length_m;
  p.desired_length_m = b.desired_length_m;
  p.desired_velocity_m_s = b.desired_velocity_m_s;
  p.has_feedforward = b.has_feedforward;
  p.feedforward_force_n = b.feedforward_force_n;
  p.cap_pressure_pa = b.cap_pressure_pa;
  p.rod_pressure_pa = b.rod_pressure_pa;
  PiOutput o;
  pi_.Update(p, o);
  out.valve_v = o.valve_v;
  out.sliding_surface_m_s = 0.0;
  out.velocity_m_s = std::isfinite(o.velocity_m_s) ? o.velocity_m_s : 0.0;
  out.desired_force_n = 0.0;
  out.force_error_n = 0.0;
  out.desired_force_rate_n_s = 0.0;
  Defend(out);
}

void LegController::Defend(LegControllerOutput& out) {
  // Last line of defence: never emit a non-finite or out-of-range voltage.
  const ValveParams& v = config_.model.valve;
  if (!std::isfinite(out.valve_v)) {
    out.valve_v = v.null_voltage_v;
    out.status = LegControlStatus::kHoldBadInput;
    out.input_fault = LegInputFault::kSetpoint;
    bssmc_.Reset();
    pi_.Reset();
    active_ = false;
  }
  out.valve_v = std::clamp(out.valve_v, v.min_voltage_v, v.max_voltage_v);
}

}  // namespace hexa
