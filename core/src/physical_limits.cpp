// Limits derived from physics (see physical_limits.hpp, docs/rig_checks.md "Physical limits").
#include "hexa/core/physical_limits.hpp"
#include "hexa/core/math_constants.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <complex>
#include <sstream>

#include "hexa/core/feasibility.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/pneumatics.hpp"

namespace hexa {
namespace {

constexpr double kUniversalGasConstant_j_mol_k = 8.314462618;
// Second virial coefficient of air near room temperature (about -8 cm3/mol at 290-300 K):
// Z = pV/(nRT) = 1 + B p / (R_u T) to first order.
constexpr double kAirSecondVirial_m3_mol = -8.0e-6;
constexpr double kIdealGasTolerance = 0.01;  // |Z - 1| the chamber model may neglect

std::string D(double v) { return FormatDerived(v); }

std::string Ms(double seconds) { return D(seconds * 1e3) + " ms"; }

// Stability function of the plant's default integrator, SSPRK3 (docs/plant.md): one step of
// y' = lambda y multiplies y by R(lambda h).
std::complex<double> Ssprk3Amplification(std::complex<double> z) {
  return 1.0 + z + z * z / 2.0 + z * z * z / 6.0;
}

// Largest step for which SSPRK3 keeps both modes of m x'' + c x' + k x = 0 bounded: along
// each eigenvalue's direction, the distance r to the boundary of |R(z)| <= 1, over |lambda|.
// `fastest` receives the eigenvalue that sets it.
double StableSsprk3Step(double m, double c, double k, std::complex<double>& fastest) {
  const std::complex<double> disc = std::sqrt(std::complex<double>(c * c - 4.0 * m * k, 0.0));
  double stable_s = INFINITY;
  for (const std::complex<double> lambda : {(-c + disc) / (2.0 * m), (-c - disc) / (2.0 * m)}) {
    const double size = std::abs(lambda);
    if (!(size > 0.0)) continue;
    const std::complex<double> direction = lambda / size;
    double r = 0.0;
    while (r < 10.0 && std::abs(Ssprk3Amplification((r + 1e-3) * direction)) <= 1.0) r += 1e-3;
    if (r / size < stable_s) {
      stable_s = r / size;
      fastest = lambda;
    }
  }
  return stable_s;
}

std::string Complex(std::complex<double> z) {
  return D(z.real()) + (z.imag() >= 0 ? " + " : " - ") + D(std::abs(z.imag())) + "i";
}

struct NamedProfile {
  std::string name;
  DisturbanceProfile profile;
};

std::vector<NamedProfile> ProfilesOrNominal(const std::map<std::string, DisturbanceProfile>& profiles) {
  std::vector<NamedProfile> out;
  for (const auto& [name, p] : profiles) out.push_back({name, p});
  if (out.empty()) {
    DisturbanceProfile nominal;
    nominal.friction_scale = nominal.polytropic_scale = nominal.payload_scale = 1.0;
    nominal.supply_ripple_amplitude_pa = 0.0;
    out.push_back({"nominal", nominal});
  }
  return out;
}

double MaxPolytropic(const PolytropicSet& g) {
  return std::max({g.extend.inflow, g.extend.outflow, g.extend.volume, g.retract.inflow,
                   g.retract.outflow, g.retract.volume});
}

// Leg Jacobian (eq 48) at the home pose of the nominal geometry; false if singular.
bool HomeJacobian(const GeometryParams& geometry, Matrix6d& J) {
  Pose pose;
  pose.p_BP_B_m = geometry.home_position_m;
  LegJacobian(geometry, pose, J);
  if (!J.allFinite()) return false;
  const Eigen::FullPivLU<Matrix6d> lu(J);
  return lu.isInvertible();
}

}  // namespace

std::vector<PhysicalLimit> DerivePlantLimits(const RigParams& rig,
                                             const std::map<std::string, DisturbanceProfile>& profile_map,
                                             double step_s, bool include_mechanical_modes) {
  std::vector<PhysicalLimit> limits;
  const AirParams& air = rig.air;
  const CylinderParams& cyl = rig.cylinder;
  const std::vector<NamedProfile> profiles = ProfilesOrNominal(profile_map);
  double ripple_max_pa = 0.0, polytropic_scale_max = 0.0, friction_scale_max = 0.0;
  double payload_scale_min = INFINITY;
  for (const auto& p : profiles) {
    ripple_max_pa = std::max(ripple_max_pa, p.profile.supply_ripple_amplitude_pa);
    polytropic_scale_max = std::max(polytropic_scale_max, p.profile.polytropic_scale);
    friction_scale_max = std::max(friction_scale_max, p.profile.friction_scale);
    payload_scale_min = std::min(payload_scale_min, p.profile.payload_scale);
  }
  const double supply_max_pa = air.supply_pressure_pa + ripple_max_pa;

  {  // Supply pressure: ideal gas.
    PhysicalLimit l;
    l.field = "air.supply_pressure_pa";
    l.quantity = "highest supply pressure (supply + largest ripple)";
    l.value = supply_max_pa;
    l.limit = kIdealGasTolerance * kUniversalGasConstant_j_mol_k * air.temperature_k /
              std::abs(kAirSecondVirial_m3_mol);
    l.unit = "Pa";
    l.reason = std::string("the chamber and orifice models (eq 4, 7) treat air as an ideal gas; air deviates "
               "from pV = mRT by |B| P / (R_u T), with the second virial coefficient B = -8e-6 "
               "m3/mol near room temperature: 1 % at this pressure (T = ") +
               D(air.temperature_k) + " K)";
    limits.push_back(l);
  }

  Matrix6d J;
  const bool have_jacobian = HomeJacobian(rig.geometry, J);
  if (have_jacobian) {  // The legs hold the platform at home, for every profile.
    // Statics of eq 48: J^T f = W. Leg forces per newton of weight: u = J^-T e_z.
    Vector6d e_z = Vector6d::Zero();
    e_z[2] = 1.0;
    const Vector6d u = J.transpose().fullPivLu().solve(e_z);
    const double u_max = u.maxCoeff();
    const double g = rig.platform.gravity_m_s2;
    const double pa = air.atmosphere_pressure_pa;
    if (u_max > 0.0) {
      PhysicalLimit worst;
      bool first = true;
      for (const auto& p : profiles) {
        const DisturbanceProfile& d = p.profile;
        const double supply_pa = air.supply_pressure_pa - d.supply_ripple_amplitude_pa;
        const double friction_n = rig.friction.extend.static_n * d.friction_scale;
        const double push_n = supply_pa * cyl.cap_area_m2 - pa * cyl.annulus_area_m2 -
                              pa * cyl.rod_area_m2 - friction_n;
        const double legs_weight_kg = static_cast<double>(kNumLegs) * cyl.moving_mass_kg;
        const double max_mass_kg = (push_n / (u_max * g) - legs_weight_kg) / d.payload_scale;
        PhysicalLimit l;
        l.field = "platform.mass_kg";
        l.quantity = "platform mass";
        l.value = rig.platform.mass_kg;
        l.limit = max_mass_kg;
        l.unit = "kg";
        l.reason = std::string("the legs must hold the platform at home: by the statics of eq 48 (J^T f = "
                   "weight) the most loaded leg carries ") + D(u_max) +
                   std::string(" of the weight (platform x payload_scale + six moving masses); with profile '") +
                   p.name + std::string("' (payload x") + D(d.payload_scale) + std::string(", friction x") +
                   D(d.friction_scale) + std::string(", supply ripple ") + D(d.supply_ripple_amplitude_pa) +
                   std::string(" Pa) a cylinder pushes at most (P_s - ripple) A1 - P_a (A2 + Ar) - static "
                   "friction = ") + D(push_n) + " N";
        if (first || l.limit < worst.limit) worst = l;
        first = false;
      }
      limits.push_back(worst);
    }
  }

  {  // Spool lag against the integrator step.
    PhysicalLimit l;
    l.field = "valve.spool_time_constant_s";
    l.quantity = "spool time constant";
    l.value = rig.valve.spool_time_constant_s;
    l.limit = step_s / kPlantRealRateStepLimit;
    l.upper = false;
    l.unit = "s";
    l.reason = std::string("the plant integrates the spool lag dX/dt = (X_target - X) / tau explicitly with a "
               "step of ") + Ms(step_s) + std::string(" (2 steps per 1 ms tick); the decay is stable and "
               "monotone only for step / tau <= ") + D(kPlantRealRateStepLimit) +
               " (the bound the plant's step control keeps for the pressures); real proportional "
               "valves have 2-20 ms";
    limits.push_back(l);
  }

  const double gamma_max = MaxPolytropic(rig.polytropic) * polytropic_scale_max;
  {  // Pressure ODE at the dead volume, valve fully open: the step control's range.
    const OrificeFlowModel orifice(air, rig.valve.discharge_coefficient);
    const double slope = orifice.MaxPressureSlopeKgSPa(rig.valve.max_orifice_area_m2);
    const double rate_1_s = air.gas_constant_j_kg_k * air.temperature_k * gamma_max * slope /
                            cyl.dead_volume_m3;
    PhysicalLimit l;
    l.field = "cylinder.dead_volume_m3";
    l.quantity = "pressure time constant of a chamber at its dead volume, valve fully open";
    l.value = 1.0 / rate_1_s;
    l.limit = kPlantTick_s / kPlantMaxSubsteps / kPlantRealRateStepLimit;
    l.upper = false;
    l.unit = "s";
    l.reason = std::string("the pressure of eq 7 relaxes with time constant V0 / (R T gamma |dm/dP|) "
               "(|dm/dP| of eq 4 at its steepest, the laminar band); the plant refines its step "
               "to step x rate <= ") + D(kPlantRealRateStepLimit) + std::string(" but splits a 1 ms tick into at "
               "most ") + std::to_string(kPlantMaxSubsteps) + " substeps";
    limits.push_back(l);
  }

  if (include_mechanical_modes && have_jacobian) {
    // Lightest effective leg mass: 1 / the largest eigenvalue mu of J^T J against the plant's
    // mass matrix (platform x smallest payload + moving masses, docs/plant.md).
    Matrix6d M = Matrix6d::Zero();
    const double s = std::isfinite(payload_scale_min) ? payload_scale_min : 1.0;
    for (int a = 0; a < 3; ++a) M(a, a) = rig.platform.mass_kg * s;
    for (int a = 0; a < 3; ++a) M(3 + a, 3 + a) = rig.platform.inertia_diag_kg_m2[a] * s;
    const Matrix6d JtJ = J.transpose() * J;
    M += cyl.moving_mass_kg * JtJ;
    const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix6d> eig(JtJ, M, Eigen::EigenvaluesOnly);
    const double m_eff_kg = 1.0 / eig.eigenvalues().maxCoeff();
    const std::string mass_text = "the lightest effective leg mass " + D(m_eff_kg) +
                                  " kg (platform.mass_kg, inertia and cylinder.moving_mass_kg "
                                  "through eq 48)";
    // A chamber may be compressed to 0.1 of its dead volume in an end stop (leg_model.cpp).
    const double k_pneu = gamma_max * supply_max_pa *
                          (cyl.cap_area_m2 * cyl.cap_area_m2 + cyl.annulus_area_m2 * cyl.annulus_area_m2) /
                          (0.1 * cyl.dead_volume_m3);
    const double c_viscous = std::max(rig.friction.extend.viscous_n_s_m, rig.friction.retract.viscous_n_s_m) *
                             friction_scale_max;
    const std::string bound_text =
        " must stay bounded under the plant's explicit SSPRK3 step (|R(lambda h)| <= 1), or the "
        "plant's state grows without bound";
    {  // End-stop contact: end-stop spring + compressed pneumatic spring. The end-stop damping
       // is left out: that force only pushes (leg_model.cpp), it cannot pull the integration
       // into oscillation (measured: finite up to 10 x the reference damping).
      const double k = cyl.end_stop_stiffness_n_m + k_pneu;
      std::complex<double> fastest;
      const double stable_s = StableSsprk3Step(m_eff_kg, 0.0, k, fastest);
      PhysicalLimit l;
      l.field = "cylinder.end_stop_stiffness_n_m";
      l.quantity = "plant step against the end-stop contact mode";
      l.value = step_s;
      l.limit = stable_s;
      l.unit = "s";
      l.reason = "a leg in its end stop is a spring on " + mass_text + ": stiffness " + D(k) +
                 " N/m (end stop " + D(cyl.end_stop_stiffness_n_m) + " + pneumatic spring " + D(k_pneu) +
                 " at 0.1 dead volume); its eigenvalue " + Complex(fastest) + " 1/s" + bound_text;
      limits.push_back(l);
    }
    {  // LuGre presliding: bristle spring and damping plus viscous friction.
      const double k = rig.friction.bristle_stiffness_n_m, c = rig.friction.bristle_damping_n_s_m + c_viscous;
      std::complex<double> fastest;
      const double stable_s = StableSsprk3Step(m_eff_kg, c, k, fastest);
      PhysicalLimit l;
      l.field = "friction.bristle_stiffness_n_m";
      l.quantity = "plant step against the LuGre presliding mode";
      l.value = step_s;
      l.limit = stable_s;
      l.unit = "s";
      l.reason = "a sticking leg rests on its LuGre bristles: a spring-damper on " + mass_text +
                 ", stiffness " + D(k) + " N/m (sigma0), damping " + D(c) + " N s/m (sigma1 + viscous); "
                 "its fastest eigenvalue " + Complex(fastest) + " 1/s" + bound_text;
      limits.push_back(l);
    }
  }
  return limits;
}

std::vector<PhysicalLimit> DeriveControllerLimits(const RigParams& rig,
                                                  const LegControllerParams& params) {
  std::vector<PhysicalLimit> limits;
  const double tau_spool = rig.valve.spool_time_constant_s;
  const double tau_filter = params.bssmc.spool_filter_time_constant_s;
  const double lag_diff = params.differentiator.centre_lag_samples * kPlantTick_s;
  const double tau_position = tau_spool + tau_filter + lag_diff + kPlantTick_s;
  const double tau_force = tau_spool + tau_filter + kPlantTick_s;
  const std::string chain = std::string("spool lag ") + Ms(tau_spool) + std::string(" (valve.spool_time_constant_s) + the "
                            "controller's spool filter ") + Ms(tau_filter) + " + ";
  {
    PhysicalLimit l;
    l.field = "leg_controller.bssmc.lambda_1_s";
    l.quantity = "sliding surface slope lambda_1";
    l.value = params.bssmc.lambda_1_s;
    l.limit = kPi / (2.0 * tau_position);
    l.unit = "1/s";
    l.reason = std::string("the sliding surface S = e' + lambda_1 e (eq 19) makes a leg cancel its position "
               "error at the rate lambda_1, but the valve chain acts only after its lags: ") + chain +
               std::string("differentiator centre lag ") + Ms(lag_diff) + std::string(" + one 1 ms tick = ") + Ms(tau_position) +
               "; a first-order loop e' = -lambda e(t - tau) is stable only for lambda tau < pi/2 "
               "(faster slopes saturate the valves and make the legs oscillate)";
    limits.push_back(l);
  }
  {
    PhysicalLimit l;
    l.field = "leg_controller.bssmc.backstepping_beta_1_s";
    l.quantity = "backstepping gain beta_1";
    l.value = params.bssmc.backstepping_beta_1_s;
    l.limit = kPi / (2.0 * tau_force);
    l.unit = "1/s";
    l.reason = std::string("the backstepping step (eq 35-38) drives the force error z at the rate beta_1 "
               "through the valve: ") + chain + std::string("one 1 ms tick = ") + Ms(tau_force) +
               " of lag; stable only for beta_1 tau < pi/2";
    limits.push_back(l);
  }
  const CylinderParams& cyl = rig.cylinder;
  const double pa = rig.air.atmosphere_pressure_pa;
  const double force_max_n = rig.air.supply_pressure_pa * cyl.cap_area_m2 -
                             pa * cyl.annulus_area_m2 - pa * cyl.rod_area_m2;
  const std::string force_reason = std::string("the largest net force a cylinder can produce, supply on the cap "
                                   "side and atmosphere on the rod side, is P_s A1 - P_a (A2 + Ar) = ") +
                                   D(force_max_n) + " N";
  {
    PhysicalLimit l;
    l.field = "leg_controller.bssmc.switching_gain_n";
    l.quantity = "switching gain K";
    l.value = params.bssmc.switching_gain_n;
    l.limit = force_max_n;
    l.unit = "N";
    l.reason = std::string("the switching term K tanh(xi S) (eq 22, 30, 45) asks for a force; ") + force_reason +
               ", beyond it the valve saturates at every sign change of S (chattering at full opening)";
    limits.push_back(l);
  }
  {
    PhysicalLimit l;
    l.field = "leg_controller.bssmc.gravity_load_n";
    l.quantity = "|gravity load| compensated per leg";
    l.value = std::abs(params.bssmc.gravity_load_n);
    l.limit = force_max_n;
    l.unit = "N";
    l.reason = std::string("a leg cannot compensate a load it cannot hold: ") + force_reason;
    limits.push_back(l);
  }
  {
    const ValveParams& v = rig.valve;
    const double quantum_m = cyl.stroke_m / std::ldexp(1.0, rig.sensors.length_bits);
    const double half_range_v = std::min(v.null_voltage_v - v.min_voltage_v, v.max_voltage_v - v.null_voltage_v);
    PhysicalLimit l;
    l.field = "leg_controller.pi.proportional_v_m";
    l.quantity = "PI proportional gain";
    l.value = params.pi.proportional_v_m;
    l.limit = half_range_v / quantum_m;
    l.unit = "V/m";
    l.reason = std::string("one quantisation step of the potentiometer (stroke / 2^length_bits = ") +
               D(quantum_m * 1e6) + std::string(" um) must not swing the valve from null to fully open (") +
               D(half_range_v) + " V): the PI law would be bang-bang on sensor noise";
    limits.push_back(l);
  }
  return limits;
}

void CheckPhysicalLimits(ParamChecker& c, const std::vector<PhysicalLimit>& limits) {
  for (const PhysicalLimit& l : limits) {
    if (l.ok()) continue;
    const std::string unit = l.unit.empty() ? "" : " " + l.unit;
    c.Fail(l.field,
           l.quantity + (l.upper ? " exceeds" : " is below") + " its physical limit: " + l.reason,
           FormatDerived(l.value) + unit, (l.upper ? "<= " : ">= ") + FormatDerived(l.limit) + unit);
  }
}

void CheckProfileAgainstRig(ParamChecker& c, const RigParams& rig, const DisturbanceProfile& p,
                            const std::string& path) {
  const AirParams& air = rig.air;
  if (std::isfinite(p.supply_ripple_amplitude_pa) && std::isfinite(air.supply_pressure_pa) &&
      std::isfinite(air.atmosphere_pressure_pa)) {
    const double headroom_pa = air.supply_pressure_pa - air.atmosphere_pressure_pa;
    if (!(p.supply_ripple_amplitude_pa < headroom_pa)) {
      c.Fail(path + ".supply_ripple_amplitude_pa",
             "supply ripple must be non-negative and keep the supply above the atmosphere",
             FormatParam(p.supply_ripple_amplitude_pa),
             std::string("[0, supply - atmosphere) = [0, ") + FormatParam(headroom_pa) + ")");
    }
  }
  // The plant scales every polytropic coefficient by the profile's factor: each must stay in
  // the range the leg model accepts.
  const PolytropicSet& g = rig.polytropic;
  const double lo = std::min({g.extend.inflow, g.extend.outflow, g.extend.volume,
                              g.retract.inflow, g.retract.outflow, g.retract.volume});
  const double hi = MaxPolytropic(g);
  if (std::isfinite(p.polytropic_scale) && p.polytropic_scale > 0.0 && lo >= 1.0 && hi <= 2.0 &&
      !(p.polytropic_scale * lo >= 1.0 && p.polytropic_scale * hi <= 2.0)) {
    c.Fail(path + ".polytropic_scale",
           std::string("scaled polytropic coefficients leave [1, 2] (the rig's range ") + FormatParam(lo) + std::string("..") +
               FormatParam(hi) + ")",
           FormatParam(p.polytropic_scale),
           std::string("[") + FormatDerived(1.0 / lo) + std::string(", ") + FormatDerived(2.0 / hi) + "]");
  }
}

void CheckSystemRules(ParamChecker& c, const RigParams& rig, const LegControllerParams& leg,
                      const SupervisorParams& sup,
                      const std::map<std::string, DisturbanceProfile>& profiles) {
  const CylinderParams& cyl = rig.cylinder;
  if (std::isfinite(sup.stroke_margin_m) && std::isfinite(cyl.stroke_m) &&
      sup.stroke_margin_m >= 0.0 && !(sup.stroke_margin_m < 0.5 * cyl.stroke_m)) {
    c.Fail("supervisor.stroke_margin_m", "stroke margin must leave a usable stroke",
           FormatParam(sup.stroke_margin_m),
           std::string("[0, cylinder.stroke_m / 2) = [0, ") + FormatParam(0.5 * cyl.stroke_m) + ")");
  }
  if (std::isfinite(leg.setpoint_timeout_s) && std::isfinite(sup.period_s) &&
      leg.setpoint_timeout_s > 0.0 && !(leg.setpoint_timeout_s >= sup.period_s)) {
    // Setpoints arrive once per supervisor period: a shorter timeout holds every cycle.
    c.Fail("leg_controller.setpoint_timeout_s", "setpoint timeout shorter than the setpoint period",
           FormatParam(leg.setpoint_timeout_s),
           std::string(">= supervisor.period_s (") + FormatParam(sup.period_s) + ")");
  }
  for (const auto& [name, profile] : profiles) {
    CheckProfileAgainstRig(c, rig, profile, "disturbance_profile[name=" + name + "]");
  }
}

std::string ExplainLimits(const std::vector<PhysicalLimit>& limits) {
  std::ostringstream o;
  for (const PhysicalLimit& l : limits) {
    const std::string unit = l.unit.empty() ? "" : " " + l.unit;
    o << (l.ok() ? "ok        " : "VIOLATED  ") << l.quantity << " [" << l.field << "]: "
      << FormatDerived(l.value) << unit << ", limit " << (l.upper ? "<= " : ">= ")
      << FormatDerived(l.limit) << unit;
    if (l.ok() && l.value != 0.0 && l.limit != 0.0) {
      const double margin = l.upper ? l.limit / l.value : l.value / l.limit;
      o << " (margin x" << FormatDerived(std::round(margin * 100.0) / 100.0) << ")";
    }
    o << "\n          " << l.reason << "\n";
  }
  return o.str();
}

}  // namespace hexa
