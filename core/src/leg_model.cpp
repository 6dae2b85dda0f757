#include "hexa/core/leg_model.hpp"

#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hexa {
namespace {

bool IsFinite(const LegPneumaticState& s) {
  return std::isfinite(s.chamber1_pressure_pa) && std::isfinite(s.chamber2_pressure_pa) &&
         std::isfinite(s.spool_m) && std::isfinite(s.bristle_m);
}

// Smallest volume the pressure equation divides by: beyond an end stop the piston may
// penetrate a little (spring-damper) and eq 64 would otherwise shrink below the dead
// volume without bound in a runaway state.
constexpr double kMinVolumeFraction = 0.1;

}  // namespace

const char* ToString(PlantStatus status) {
  switch (status) {
    case PlantStatus::kOk: return "ok";
    case PlantStatus::kInvalidInput: return "invalid input (non-finite)";
    case PlantStatus::kNonFiniteState: return "non-finite state (last good state kept)";
  }
  return "unknown";
}

void LegModelParams::Validate() const {
  // The rig structs with the rules the rig file is checked with (param_checks.hpp); the
  // polytropic coefficients here are already scaled by the disturbance profile.
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckAirParams(c, air);
  CheckCylinderParams(c, cylinder);
  CheckValveParams(c, valve);
  CheckFrictionParams(c, friction);
  CheckPolytropicSet(c, polytropic);
  if (!(laminar_pressure_ratio > 0.0 && laminar_pressure_ratio <= 1.0)) {
    c.Fail("laminar_pressure_ratio", "laminar band edge (pressure ratio)",
           FormatParam(laminar_pressure_ratio), "(0, 1]");
  }
  c.Positive("lugre_damping_fade_velocity_m_s", lugre_damping_fade_velocity_m_s, "fade velocity");
  c.Positive("polytropic_blend_velocity_m_s", polytropic_blend_velocity_m_s, "blend velocity");
  ThrowIfIssues(issues, "LegModelParams");
}

LegModelParams MakeLegModelParams(const RigParams& rig, double friction_scale,
                                  double polytropic_scale) {
  LegModelParams p;
  p.air = rig.air;
  p.cylinder = rig.cylinder;
  p.valve = rig.valve;
  p.friction = ScaleFriction(rig.friction, friction_scale);
  p.polytropic = rig.polytropic;
  for (PolytropicParams* g : {&p.polytropic.extend, &p.polytropic.retract}) {
    g->inflow *= polytropic_scale;
    g->outflow *= polytropic_scale;
    g->volume *= polytropic_scale;
  }
  return p;
}

LegModel::LegModel(const LegModelParams& params)
    : params_(params),
      orifice_(params.air, params.valve.discharge_coefficient, params.laminar_pressure_ratio),
      inv_stribeck_extend_s_m_(1.0 / params.friction.extend.stribeck_velocity_m_s),
      inv_stribeck_retract_s_m_(1.0 / params.friction.retract.stribeck_velocity_m_s),
      inv_fade_velocity_s_m_(1.0 / params.lugre_damping_fade_velocity_m_s),
      gas_rt_j_kg_(params.air.gas_constant_j_kg_k * params.air.temperature_k) {}

void LegModel::Evaluate(const LegPneumaticState& s, double x, double v,
                        double spool_target_m, double supply_pressure_pa,
                        LegPneumaticState& rate, LegForces& forces) const {
  const CylinderParams& cyl = params_.cylinder;
  const AirParams& air = params_.air;
  const double pa = air.atmosphere_pressure_pa;

  // Spool: first-order lag towards the eq 42 position.
  rate.spool_m = (spool_target_m - s.spool_m) / params_.valve.spool_time_constant_s;

  // Friction (LuGre, steady state = eq 3 with the Table 8 magnitudes of v's direction).
  LugreOutput lugre;
  if (params_.friction_enabled) {
    if (params_.friction_model == LegModelParams::FrictionModel::kLugre) {
      // EvaluateLugre (friction.hpp) with the reciprocals precomputed: the same LuGre
      // equations, two exp and one division per call.
      const bool extend = v >= 0.0;
      const FrictionDirectionParams& d = extend ? params_.friction.extend
                                                : params_.friction.retract;
      const double qs = v * (extend ? inv_stribeck_extend_s_m_ : inv_stribeck_retract_s_m_);
      const double g = d.coulomb_n + (d.static_n - d.coulomb_n) * std::exp(-qs * qs);
      const double sigma0 = params_.friction.bristle_stiffness_n_m;
      const double qd = v * inv_fade_velocity_s_m_;
      const double sigma1 = params_.friction.bristle_damping_n_s_m * std::exp(-qd * qd);
      lugre.bristle_rate_m_s = v - sigma0 * std::abs(v) * s.bristle_m / g;
      lugre.force_n = sigma0 * s.bristle_m + sigma1 * lugre.bristle_rate_m_s +
                      d.viscous_n_s_m * v;
      lugre.dissipation_w = lugre.force_n * v - sigma0 * s.bristle_m * lugre.bristle_rate_m_s;
    } else {
      lugre.force_n = StribeckFrictionN(params_.friction, v);  // eq 3
      lugre.dissipation_w = lugre.force_n * v;
    }
  }
  rate.bristle_m = lugre.bristle_rate_m_s;

  // End stops: a stiff spring-damper beyond either end of the stroke; it only pushes.
  const double half = 0.5 * cyl.stroke_m;
  double stop = 0.0;
  if (x > half) {
    stop = std::min(0.0, -cyl.end_stop_stiffness_n_m * (x - half) - cyl.end_stop_damping_n_s_m * v);
  } else if (x < -half) {
    stop = std::max(0.0, -cyl.end_stop_stiffness_n_m * (x + half) - cyl.end_stop_damping_n_s_m * v);
  }

  double p1 = s.chamber1_pressure_pa;
  double p2 = s.chamber2_pressure_pa;
  if (params_.chambers_vented) {
    p1 = pa;
    p2 = pa;
    rate.chamber1_pressure_pa = 0.0;
    rate.chamber2_pressure_pa = 0.0;
    forces.chamber1_mass_flow_kg_s = 0.0;
    forces.chamber2_mass_flow_kg_s = 0.0;
  } else {
    // Eq 64 volumes and their rates.
    const double v0_min = kMinVolumeFraction * cyl.dead_volume_m3;
    const double vol1 = std::max(Chamber1VolumeM3(cyl, x), v0_min);
    const double vol2 = std::max(Chamber2VolumeM3(cyl, x), v0_min);
    const double dvol1 = cyl.cap_area_m2 * v;
    const double dvol2 = -cyl.annulus_area_m2 * v;

    // Eq 4-6, 43 and Tables 4, 5.
    const double area = params_.chambers_sealed ? 0.0 : OrificeAreaM2(params_.valve, s.spool_m);
    const ChamberMassFlows flows =
        ValveMassFlows(orifice_, area, s.spool_m, supply_pressure_pa, pa, p1, p2);
    forces.chamber1_mass_flow_kg_s = flows.chamber1_kg_s;
    forces.chamber2_mass_flow_kg_s = flows.chamber2_kg_s;

    // Table 8 coefficients of the stroke direction, blended continuously across v = 0.
    const PolytropicParams& ge = params_.polytropic.extend;
    const PolytropicParams& gr = params_.polytropic.retract;
    const double vb = params_.polytropic_blend_velocity_m_s;
    const double w = 0.5 * (1.0 + v / std::sqrt(v * v + vb * vb));
    const double gamma_in = w * ge.inflow + (1.0 - w) * gr.inflow;
    const double gamma_out = w * ge.outflow + (1.0 - w) * gr.outflow;
    const double gamma_vol = w * ge.volume + (1.0 - w) * gr.volume;

    // Eq 7 / 65: P_i' = RT/V_i (gamma_i m_in - gamma_o m_out) - gamma_k P_i/V_i dV_i/dt.
    // (dV_i/dt is the true volume rate here; eq 7 writes +gamma_k P2/V2 V2' for chamber 2
    // with V2' meaning A2 x', see docs/plant.md.)
    const PolytropicParams gamma{gamma_in, gamma_out, gamma_vol};
    rate.chamber1_pressure_pa =
        ChamberPressureRatePaS(gas_rt_j_kg_, gamma, flows.chamber1_kg_s, p1, vol1, dvol1);
    rate.chamber2_pressure_pa =
        ChamberPressureRatePaS(gas_rt_j_kg_, gamma, flows.chamber2_kg_s, p2, vol2, dvol2);
  }

  // Eq 1, 2, 50: pneumatic force on the rod.
  forces.pneumatic_n = p1 * cyl.cap_area_m2 - p2 * cyl.annulus_area_m2 - pa * cyl.rod_area_m2;
  forces.friction_n = -lugre.force_n;
  forces.end_stop_n = stop;
  forces.total_n = forces.pneumatic_n + forces.friction_n + forces.end_stop_n;
  forces.friction_dissipation_w = lugre.dissipation_w;
}

double LegModel::BristleRate1S(double v) const {
  if (!params_.friction_enabled || params_.friction_model != LegModelParams::FrictionModel::kLugre) {
    return 0.0;
  }
  const bool extend = v >= 0.0;
  const FrictionDirectionParams& d = extend ? params_.friction.extend : params_.friction.retract;
  const double qs = v * (extend ? inv_stribeck_extend_s_m_ : inv_stribeck_retract_s_m_);
  const double g = d.coulomb_n + (d.static_n - d.coulomb_n) * std::exp(-qs * qs);
  return params_.friction.bristle_stiffness_n_m * std::abs(v) / g;
}

double LegModel::PressureStiffnessBound1S(const LegPneumaticState& s, double x, double v,
                                          double spool_target_m, double horizon_s) const {
  if (params_.chambers_vented || params_.chambers_sealed) return 0.0;
  const CylinderParams& cyl = params_.cylinder;
  // The spool moves monotonically towards its target (first-order lag): the largest
  // opening over the horizon is the larger of the two.
  const double area = OrificeAreaM2(params_.valve,
                                    std::max(std::abs(s.spool_m), std::abs(spool_target_m)));
  if (area <= 0.0) return 0.0;
  const double travel = std::abs(v) * horizon_s;
  const double v0_min = kMinVolumeFraction * cyl.dead_volume_m3;
  const double vol1 = std::max(Chamber1VolumeM3(cyl, x - travel), v0_min);
  const double vol2 = std::max(Chamber2VolumeM3(cyl, x + travel), v0_min);
  const PolytropicSet& g = params_.polytropic;
  const double gamma = std::max({g.extend.inflow, g.extend.outflow, g.retract.inflow,
                                 g.retract.outflow});
  return gas_rt_j_kg_ * gamma * orifice_.MaxPressureSlopeKgSPa(area) / std::min(vol1, vol2);
}

LegPneumaticState LegModel::Equilibrium(double axial_force_n,
                                        double chamber2_pressure_pa) const {
  const CylinderParams& cyl = params_.cylinder;
  LegPneumaticState s;
  s.chamber2_pressure_pa = chamber2_pressure_pa;
  s.chamber1_pressure_pa = (axial_force_n + chamber2_pressure_pa * cyl.annulus_area_m2 +
                            params_.air.atmosphere_pressure_pa * cyl.rod_area_m2) /
                           cyl.cap_area_m2;
  s.spool_m = 0.0;
  s.bristle_m = 0.0;
  return s;
}

double LegModel::StoredEnergyJ(const LegPneumaticState& s, double x) const {
  const CylinderParams& cyl = params_.cylinder;
  const double km1 = params_.air.heat_ratio - 1.0;
  const double pneumatic = (s.chamber1_pressure_pa * Chamber1VolumeM3(cyl, x) +
                            s.chamber2_pressure_pa * Chamber2VolumeM3(cyl, x)) / km1;
  const double atmosphere = params_.air.atmosphere_pressure_pa * cyl.rod_area_m2 * x;
  const double half = 0.5 * cyl.stroke_m;
  const double pen = x > half ? x - half : (x < -half ? x + half : 0.0);
  const double stop = 0.5 * cyl.end_stop_stiffness_n_m * pen * pen;
  const double bristle = 0.5 * params_.friction.bristle_stiffness_n_m * s.bristle_m * s.bristle_m;
  return pneumatic + atmosphere + stop + bristle;
}

// ---------------------------------------------------------------------------------------

void SingleLegConfig::Validate() const {
  leg.Validate();
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.NonNegative("load_mass_kg", load_mass_kg, "load mass");
  c.NonNegative("gravity_m_s2", gravity_m_s2, "gravity");
  if (c.Finite("integrator_step_s", integrator_step_s) &&
      !(integrator_step_s > 0.0 && integrator_step_s <= kPlantTick_s)) {
    c.Fail("integrator_step_s", "integrator step must be positive and at most the 1 ms tick",
           FormatParam(integrator_step_s), "(0, 0.001]");
  }
  ThrowIfIssues(issues, "SingleLegConfig");
}

SingleLegPlant::SingleLegPlant(const SingleLegConfig& config) : config_(config) {
  config_.Validate();
  model_ = LegModel(config_.leg);
  moving_mass_kg_ = config_.load_mass_kg + config_.leg.cylinder.moving_mass_kg;
  gravity_along_x_m_s2_ =
      config_.mount == LegMount::kRodUp ? -config_.gravity_m_s2 : config_.gravity_m_s2;
  Reset();
}

void SingleLegPlant::Reset(double position_m, double chamber2_pressure_pa) {
  const AirParams& air = config_.leg.air;
  const double p2 = chamber2_pressure_pa > 0.0
                        ? chamber2_pressure_pa
                        : 0.5 * (air.supply_pressure_pa + air.atmosphere_pressure_pa);
  // The rod must push -m g_x along +x to hold the load.
  SingleLegState s;
  s.position_m = position_m;
  s.velocity_m_s = 0.0;
  s.leg = model_.Equilibrium(-moving_mass_kg_ * gravity_along_x_m_s2_, p2);
  if (config_.leg.chambers_vented) {
    s.leg.chamber1_pressure_pa = air.atmosphere_pressure_pa;
    s.leg.chamber2_pressure_pa = air.atmosphere_pressure_pa;
  }
  ResetTo(s);
}

void SingleLegPlant::ResetTo(const SingleLegState& state) {
  state_ = state;
  time_s_ = 0.0;
  last_forces_ = LegForces{};
  min_dissipation_w_ = std::numeric_limits<double>::infinity();
}

void SingleLegPlant::Derivatives(const SingleLegState& s, double spool_target_m,
                                 Derivative& d, LegForces& forces) {
  model_.Evaluate(s.leg, s.position_m, s.velocity_m_s, spool_target_m,
                  config_.leg.air.supply_pressure_pa, d.leg, forces);
  d.position = s.velocity_m_s;
  // Eq 1, 2, 50: M x'' = F_leg + M g_x
  d.velocity = forces.total_n / moving_mass_kg_ + gravity_along_x_m_s2_;
  min_dissipation_w_ = std::min(min_dissipation_w_, forces.friction_dissipation_w);
}

namespace {
SingleLegState Advance(const SingleLegState& s, double h, const auto& d) {
  SingleLegState r;
  r.position_m = s.position_m + h * d.position;
  r.velocity_m_s = s.velocity_m_s + h * d.velocity;
  r.leg.chamber1_pressure_pa = s.leg.chamber1_pressure_pa + h * d.leg.chamber1_pressure_pa;
  r.leg.chamber2_pressure_pa = s.leg.chamber2_pressure_pa + h * d.leg.chamber2_pressure_pa;
  r.leg.spool_m = s.leg.spool_m + h * d.leg.spool_m;
  r.leg.bristle_m = s.leg.bristle_m + h * d.leg.bristle_m;
  return r;
}
}  // namespace

PlantStatus SingleLegPlant::Step(double valve_v, double dt_s) {
  if (!std::isfinite(valve_v) || !std::isfinite(dt_s) || dt_s < 0.0) {
    return PlantStatus::kInvalidInput;
  }
  if (dt_s == 0.0) return PlantStatus::kOk;
  const double target = SpoolTargetM(config_.leg.valve, valve_v);
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / config_.integrator_step_s - 1e-9)));
  const double h = dt_s / n;
  SingleLegState s = state_;
  Derivative k1, k2, k3, k4;
  LegForces f;
  for (int i = 0; i < n; ++i) {
    // Classical RK4 (docs/plant.md, "Integrator").
    Derivatives(s, target, k1, f);
    Derivatives(Advance(s, 0.5 * h, k1), target, k2, f);
    Derivatives(Advance(s, 0.5 * h, k2), target, k3, f);
    Derivatives(Advance(s, h, k3), target, k4, f);
    Derivative sum;
    sum.position = k1.position + 2.0 * (k2.position + k3.position) + k4.position;
    sum.velocity = k1.velocity + 2.0 * (k2.velocity + k3.velocity) + k4.velocity;
    sum.leg.chamber1_pressure_pa = k1.leg.chamber1_pressure_pa +
        2.0 * (k2.leg.chamber1_pressure_pa + k3.leg.chamber1_pressure_pa) + k4.leg.chamber1_pressure_pa;
    sum.leg.chamber2_pressure_pa = k1.leg.chamber2_pressure_pa +
        2.0 * (k2.leg.chamber2_pressure_pa + k3.leg.chamber2_pressure_pa) + k4.leg.chamber2_pressure_pa;
    sum.leg.spool_m = k1.leg.spool_m + 2.0 * (k2.leg.spool_m + k3.leg.spool_m) + k4.leg.spool_m;
    sum.leg.bristle_m = k1.leg.bristle_m + 2.0 * (k2.leg.bristle_m + k3.leg.bristle_m) + k4.leg.bristle_m;
    s = Advance(s, h / 6.0, sum);
  }
  if (!(std::isfinite(s.position_m) && std::isfinite(s.velocity_m_s) && IsFinite(s.leg))) {
    return PlantStatus::kNonFiniteState;
  }
  state_ = s;
  time_s_ += dt_s;
  Derivative d;
  Derivatives(state_, target, d, last_forces_);
  return PlantStatus::kOk;
}

double SingleLegPlant::TotalEnergyJ() const {
  const double kinetic = 0.5 * moving_mass_kg_ * state_.velocity_m_s * state_.velocity_m_s;
  const double gravity = -moving_mass_kg_ * gravity_along_x_m_s2_ * state_.position_m;
  return kinetic + gravity + model_.StoredEnergyJ(state_.leg, state_.position_m);
}

}  // namespace hexa
