#include "hexa/core/platform_plant.hpp"
#include "hexa/core/math_constants.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/physical_limits.hpp"

namespace hexa {
namespace {

// State layout: p (0..2), q wxyz (3..6), v (7..9), w (10..12), then per leg
// P1, P2, spool, bristle (13 + 4 i ...).
constexpr int kP = 0, kQ = 3, kV = 7, kW = 10, kLeg0 = 13;

Eigen::Vector3d UniformInBall(std::mt19937_64& rng, double radius) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (;;) {  // rejection sampling, deterministic for a given rng state
    const Eigen::Vector3d u(unit(rng), unit(rng), unit(rng));
    if (u.squaredNorm() <= 1.0) return radius * u;
  }
}

Eigen::Quaterniond QuatOf(const PlatformPlant::StateVector& x) {
  return Eigen::Quaterniond(x[kQ], x[kQ + 1], x[kQ + 2], x[kQ + 3]);
}

}  // namespace

DisturbanceProfile MakeIdealDisturbanceProfile() {
  DisturbanceProfile p;
  p.sensor_noise = false;
  p.friction_scale = 1.0;
  p.polytropic_scale = 1.0;
  p.payload_scale = 1.0;
  p.supply_ripple_amplitude_pa = 0.0;
  p.supply_ripple_frequency_hz = 0.5;
  p.joint_position_error_max_m = 0.0;
  p.potentiometer_offset_max_m = 0.0;
  p.potentiometer_gain_error_max = 0.0;
  return p;
}

DisturbanceProfile MakeRealisticDisturbanceProfile() { return DisturbanceProfile{}; }

void PlatformPlantConfig::Validate() const {
  faults.Validate();  // the injected rig faults (plant_faults.hpp)
  // The rig and the profile with the rules the rig file is checked with, and the physical
  // limits without which the plant's state would not stay finite: ideal-gas supply, legs able
  // to hold the platform, spool lag and pressure ODE against this integrator step
  // (physical_limits.hpp; the mechanical-mode bound is the rig file's, at the nominal step).
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  if (c.Finite("integrator_step_s", integrator_step_s) &&
      !(integrator_step_s > 0.0 && integrator_step_s <= kPlantTick_s)) {
    c.Fail("integrator_step_s", "integrator step must be positive and at most the 1 ms tick",
           FormatParam(integrator_step_s), "(0, 0.001]");
  }
  if (c.Finite("stiffness_step_limit", stiffness_step_limit) &&
      !(stiffness_step_limit > 0.0 && stiffness_step_limit <= 2.5)) {
    c.Fail("stiffness_step_limit",
           "step x rate bound of the step control (RK4 / SSPRK3 are stable to 2.78 / 2.51)",
           FormatParam(stiffness_step_limit), "(0, 2.5]");
  }
  CheckRigParams(c, rig);
  CheckDisturbanceProfile(c, disturbance, "disturbance");
  CheckProfileAgainstRig(c, rig, disturbance, "disturbance");
  if (free_fall.enabled) {
    c.NonNegative("free_fall.load_kg", free_fall.load_kg, "free-fall load");
    c.NonNegative("free_fall.release_s", free_fall.release_s, "release time");
    if (c.Finite("free_fall.start_margin_m", free_fall.start_margin_m) &&
        !(free_fall.start_margin_m >= 0.0 && free_fall.start_margin_m < rig.cylinder.stroke_m)) {
      c.Fail("free_fall.start_margin_m", "the bench starts the rod inside its stroke",
             FormatParam(free_fall.start_margin_m), "[0, stroke)");
    }
  }
  if (issues.empty()) {
    CheckPhysicalLimits(c, DerivePlantLimits(rig, {{"plant", disturbance}}, integrator_step_s,
                                             /*include_mechanical_modes=*/false));
  }
  ThrowIfIssues(issues, "PlatformPlantConfig");
  LegModelParams leg = MakeLegModelParams(rig, disturbance.friction_scale,
                                          disturbance.polytropic_scale);
  leg.laminar_pressure_ratio = laminar_pressure_ratio;
  leg.lugre_damping_fade_velocity_m_s = lugre_damping_fade_velocity_m_s;
  leg.Validate();
}

GeometryParams TrueGeometry(const GeometryParams& nominal, const DisturbanceProfile& profile,
                            std::uint64_t seed) {
  GeometryParams g = nominal;
  std::mt19937_64 geometry_rng(DeriveSeed(seed, 3));
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    g.p_BA_B[i] += UniformInBall(geometry_rng, profile.joint_position_error_max_m);
    g.p_PB_P[i] += UniformInBall(geometry_rng, profile.joint_position_error_max_m);
  }
  return g;
}

PlatformPlant::PlatformPlant(const PlatformPlantConfig& config)
    : config_(config),
      sensors_(config.rig, config.disturbance, config.seed),
      tracker_(config.tracker, config.seed) {
  config_.Validate();
  const RigParams& rig = config_.rig;
  const DisturbanceProfile& dist = config_.disturbance;

  LegModelParams leg = MakeLegModelParams(rig, dist.friction_scale, dist.polytropic_scale);
  leg.laminar_pressure_ratio = config_.laminar_pressure_ratio;
  leg.lugre_damping_fade_velocity_m_s = config_.lugre_damping_fade_velocity_m_s;
  leg.friction_enabled = config_.friction_enabled;
  leg.chambers_sealed = config_.chambers_sealed;
  leg.friction_model = config_.friction_model;
  leg_model_ = LegModel(leg);

  // The plant's true geometry; the controllers keep the nominal one.
  true_geometry_ = TrueGeometry(rig.geometry, dist, config_.seed);

  platform_mass_kg_ = rig.platform.mass_kg * dist.payload_scale;
  platform_inertia_P_ = (rig.platform.inertia_diag_kg_m2 * dist.payload_scale).asDiagonal();
  leg_mass_kg_ = rig.cylinder.moving_mass_kg;
  gravity_m_s2_ = rig.platform.gravity_m_s2;
  if (config_.free_fall.enabled) {
    SingleLegConfig bench;
    bench.leg = leg;
    bench.leg.chambers_vented = true;
    bench.load_mass_kg = config_.free_fall.load_kg;
    bench.gravity_m_s2 = gravity_m_s2_;
    bench.mount = LegMount::kRodDown;
    bench_.assign(kNumLegs, SingleLegPlant(bench));
  }
  Reset();
}

double PlatformPlant::SupplyPressurePa(double time_s) const {
  const DisturbanceProfile& d = config_.disturbance;
  const double supply = config_.rig.air.supply_pressure_pa +
         d.supply_ripple_amplitude_pa * std::sin(2.0 * kPi * d.supply_ripple_frequency_hz * time_s);
  for (const PlantFault& f : config_.faults.faults) {
    if (f.kind != PlantFaultKind::kSupplyLoss || time_s < f.at_time_s) continue;
    // The supply line empties to the atmosphere (first order, docs/faults.md).
    const double pa = config_.rig.air.atmosphere_pressure_pa;
    return pa + (supply - pa) * std::exp(-(time_s - f.at_time_s) / config_.faults.supply_loss_time_constant_s);
  }
  return supply;
}

void PlatformPlant::ApplySensorFaults() {
  output_.imu.dropped_out = false;
  for (const PlantFault& f : config_.faults.faults) {
    if (time_s_ < f.at_time_s) continue;
    if (f.kind == PlantFaultKind::kImuDropout) {
      output_.imu.dropped_out = true;
      output_.imu.fresh = false;
      continue;
    }
    if (!PlantFaultHasLeg(f.kind)) continue;
    const std::size_t i = static_cast<std::size_t>(f.leg - 1);
    LegSensorReading& r = output_.legs[i];
    switch (f.kind) {
      case PlantFaultKind::kPotStuck:
        if (!stuck_latched_[i]) {
          stuck_latched_[i] = true;
          stuck_length_m_[i] = r.length_m;
        }
        r.length_m = stuck_length_m_[i];
        break;
      case PlantFaultKind::kPotDrift:
        r.length_m += config_.faults.pot_drift_m_s * (time_s_ - f.at_time_s);
        break;
      case PlantFaultKind::kPressureDead:
        r.chamber1_pressure_pa = 0.0;
        break;
      case PlantFaultKind::kImuDropout:
      case PlantFaultKind::kSupplyLoss:
        break;
    }
  }
}

void PlatformPlant::ResetBench() {
  const CylinderParams& cyl = config_.rig.cylinder;
  const double x0 = -0.5 * cyl.stroke_m + config_.free_fall.start_margin_m;
  for (SingleLegPlant& leg : bench_) leg.Reset(x0);
  output_ = PlatformPlantOutput{};
  output_.truth.applied_valve_v.fill(config_.rig.valve.null_voltage_v);
  PlatformTrueState& t = output_.truth;
  t.pose.p_BP_B_m = config_.rig.geometry.home_position_m;
  t.q_BP = Eigen::Quaterniond::Identity();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    t.piston_position_m[i] = bench_[i].position_m();
    t.piston_velocity_m_s[i] = bench_[i].velocity_m_s();
    t.length_m[i] = cyl.mid_stroke_length_m + bench_[i].position_m();
    t.legs[i] = bench_[i].state().leg;
  }
  t.supply_pressure_pa = config_.rig.air.supply_pressure_pa;
  t.time_s = time_s_;
  t.tick = tick_;
  SampleSensors();
}

PlantStatus PlatformPlant::StepBench(double dt_s) {
  if (time_s_ + 0.5 * dt_s >= config_.free_fall.release_s) {
    for (SingleLegPlant& leg : bench_) {
      const PlantStatus s = leg.Step(config_.rig.valve.null_voltage_v, dt_s);  // vented: valve idle
      if (s != PlantStatus::kOk) return output_.status = s;
    }
  }
  time_s_ += dt_s;
  ++tick_;
  PlatformTrueState& t = output_.truth;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    t.piston_position_m[i] = bench_[i].position_m();
    t.piston_velocity_m_s[i] = bench_[i].velocity_m_s();
    t.length_m[i] = config_.rig.cylinder.mid_stroke_length_m + bench_[i].position_m();
    t.legs[i] = bench_[i].state().leg;
  }
  t.time_s = time_s_;
  t.tick = tick_;
  SampleSensors();
  return output_.status = PlantStatus::kOk;
}

void PlatformPlant::Reset() {
  if (!bench_.empty()) {
    sensors_.Reset();
    time_s_ = 0.0;
    tick_ = 0;
    min_dissipation_w_ = 0.0;
    ResetBench();
    return;
  }
  sensors_.Reset();
  tracker_.Reset();
  stuck_latched_.fill(false);
  time_s_ = 0.0;
  tick_ = 0;
  min_dissipation_w_ = std::numeric_limits<double>::infinity();
  spool_target_m_.fill(0.0);

  // Home pose, at rest.
  Pose home;
  home.p_BP_B_m = config_.rig.geometry.home_position_m;
  home.R_BP.setIdentity();
  state_.setZero();
  state_.segment<3>(kP) = home.p_BP_B_m;
  state_[kQ] = 1.0;

  // Static balance at home: J^T f = -(gravity wrench), J of the TRUE geometry (eq 48).
  Matrix6d J;
  LegJacobian(true_geometry_, home, J);
  const double g = gravity_m_s2_;
  Vector6d gravity_wrench = Vector6d::Zero();
  gravity_wrench[2] = -(platform_mass_kg_ + kNumLegs * leg_mass_kg_) * g;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    // Leg moving mass weight acts at the platform joint (docs/plant.md).
    const Eigen::Vector3d r = true_geometry_.p_PB_P[i];
    gravity_wrench.segment<3>(3) += r.cross(Eigen::Vector3d(0, 0, -leg_mass_kg_ * g));
  }
  const Vector6d f = J.transpose().partialPivLu().solve(-gravity_wrench);
  const AirParams& air = config_.rig.air;
  const double p2 = config_.home_chamber2_pressure_pa > 0.0
                        ? config_.home_chamber2_pressure_pa
                        : 0.5 * (air.supply_pressure_pa + air.atmosphere_pressure_pa);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegPneumaticState s = leg_model_.Equilibrium(f[static_cast<int>(i)], p2);
    const int o = kLeg0 + 4 * static_cast<int>(i);
    state_[o] = s.chamber1_pressure_pa;
    state_[o + 1] = s.chamber2_pressure_pa;
    state_[o + 2] = s.spool_m;
    state_[o + 3] = s.bristle_m;
  }
  output_ = PlatformPlantOutput{};
  output_.truth.applied_valve_v.fill(config_.rig.valve.null_voltage_v);
  Derivative(state_, time_s_, rate_at_state_, true);
  FillTruth();
  SampleSensors();
}

namespace {

// Solves M x = b for the symmetric positive definite 6x6 mass matrix, given its lower
// triangle, by an unrolled Cholesky factorisation (M = L L^T). Eigen's generic LLT costs
// several times more for this fixed size (docs/measurements/plant.md, "Speed").
Vector6d SolveSpd6(double m[6][6], const Vector6d& b) {
  double inv_diag[6];
#pragma GCC unroll 6
  for (int j = 0; j < 6; ++j) {
    double d = m[j][j];
#pragma GCC unroll 6
    for (int k = 0; k < j; ++k) d -= m[j][k] * m[j][k];
    const double ljj = std::sqrt(d);
    inv_diag[j] = 1.0 / ljj;
    m[j][j] = ljj;
#pragma GCC unroll 6
    for (int i = j + 1; i < 6; ++i) {
      double a = m[i][j];
#pragma GCC unroll 6
      for (int k = 0; k < j; ++k) a -= m[i][k] * m[j][k];
      m[i][j] = a * inv_diag[j];
    }
  }
  double y[6];
#pragma GCC unroll 6
  for (int i = 0; i < 6; ++i) {  // L y = b
    double a = b[i];
#pragma GCC unroll 6
    for (int k = 0; k < i; ++k) a -= m[i][k] * y[k];
    y[i] = a * inv_diag[i];
  }
  Vector6d x;
#pragma GCC unroll 6
  for (int i = 5; i >= 0; --i) {  // L^T x = y
    double a = y[i];
#pragma GCC unroll 6
    for (int k = i + 1; k < 6; ++k) a -= m[k][i] * x[k];
    x[i] = a * inv_diag[i];
  }
  return x;
}

}  // namespace

void PlatformPlant::Derivative(const StateVector& x, double time_s, StateVector& dxdt,
                               bool record) {
  const Eigen::Quaterniond q = QuatOf(x).normalized();
  const Eigen::Matrix3d R_BP = q.toRotationMatrix();
  const Eigen::Vector3d p = x.segment<3>(kP);
  const Eigen::Vector3d v = x.segment<3>(kV);
  const Eigen::Vector3d w = x.segment<3>(kW);
  const double w_sq = w.squaredNorm();

  const double supply = SupplyPressurePa(time_s);
  const double g = gravity_m_s2_;
  const double mid = config_.rig.cylinder.mid_stroke_length_m;
  const double m_leg = leg_mass_kg_;

  // Generalised force on the twist [v; w] and mass matrix (docs/plant.md):
  //   (M_p + m_leg sum J_i^T J_i) twist_dot = sum J_i^T (f_i - m_leg c_i) + W_g - [0; w x I w]
  // Only the lower triangle of the symmetric M is assembled.
  const Eigen::Matrix3d inertia_B = R_BP * platform_inertia_P_ * R_BP.transpose();
  double M[6][6] = {};
  for (int a = 0; a < 3; ++a) {
    M[a][a] = platform_mass_kg_;
    for (int b = 0; b <= a; ++b) M[3 + a][3 + b] = inertia_B(a, b);
  }
  Vector6d rhs = Vector6d::Zero();
  rhs[2] = -(platform_mass_kg_ + kNumLegs * m_leg) * g;
  rhs.tail<3>() = -w.cross(inertia_B * w);
  Eigen::Vector3d sum_r = Eigen::Vector3d::Zero();

  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int ii = static_cast<int>(i);
    // eq 46: l_i = |p + R b_i - a_i| on the TRUE geometry, unit vector s_i.
    const Eigen::Vector3d r = R_BP * true_geometry_.p_PB_P[i];
    const Eigen::Vector3d leg = p + r - true_geometry_.p_BA_B[i];
    const double length = leg.norm();
    const Eigen::Vector3d s = leg / length;
    sum_r += r;
    double Ji[6];  // eq 48 row: [s^T, (r x s)^T]
    const Eigen::Vector3d r_x_s = r.cross(s);
    Ji[0] = s.x(); Ji[1] = s.y(); Ji[2] = s.z();
    Ji[3] = r_x_s.x(); Ji[4] = r_x_s.y(); Ji[5] = r_x_s.z();
    const Eigen::Vector3d v_joint = v + w.cross(r);
    const double l_dot = s.dot(v_joint);
    // l_ddot = J_i twist_dot + c_i, c_i = s.(w x (w x r)) + |v_joint, perpendicular|^2 / l,
    // with w x (w x r) = w (w.r) - r |w|^2.
    const double c = s.dot(w) * w.dot(r) - s.dot(r) * w_sq +
                     (v_joint - l_dot * s).squaredNorm() / length;

    const int o = kLeg0 + 4 * ii;
    const LegPneumaticState ls{x[o], x[o + 1], x[o + 2], x[o + 3]};
    LegPneumaticState rate;
    LegForces forces;
    const double xp = length - mid;
    leg_model_.Evaluate(ls, xp, l_dot, spool_target_m_[i], supply, rate, forces);
    dxdt[o] = rate.chamber1_pressure_pa;
    dxdt[o + 1] = rate.chamber2_pressure_pa;
    dxdt[o + 2] = rate.spool_m;
    dxdt[o + 3] = rate.bristle_m;
    min_dissipation_w_ = std::min(min_dissipation_w_, forces.friction_dissipation_w);

    const double f_axial = forces.total_n - m_leg * c;
#pragma GCC unroll 6
    for (int a = 0; a < 6; ++a) {
      rhs[a] += Ji[a] * f_axial;
      const double mj = m_leg * Ji[a];
#pragma GCC unroll 6
      for (int b = 0; b <= a; ++b) M[a][b] += mj * Ji[b];
    }

    if (record) {
      PlatformTrueState& t = output_.truth;
      t.length_m[i] = length;
      t.piston_position_m[i] = xp;
      t.piston_velocity_m_s[i] = l_dot;
      output_.leg_forces[i] = forces;
    }
  }
  // Weight of every leg's moving mass, applied at its platform joint.
  rhs.tail<3>() += sum_r.cross(Eigen::Vector3d(0, 0, -m_leg * g));
  const Vector6d twist_dot = SolveSpd6(M, rhs);

  dxdt.segment<3>(kP) = v;
  // q_dot = 1/2 [0, w] (x) q, w in B (spatial angular velocity).
  const Eigen::Quaterniond wq(0.0, w.x(), w.y(), w.z());
  const Eigen::Quaterniond qd = wq * QuatOf(x);
  dxdt[kQ] = 0.5 * qd.w();
  dxdt[kQ + 1] = 0.5 * qd.x();
  dxdt[kQ + 2] = 0.5 * qd.y();
  dxdt[kQ + 3] = 0.5 * qd.z();
  dxdt.segment<6>(kV) = twist_dot;
  if (record) output_.truth.supply_pressure_pa = supply;
}

void PlatformPlant::FillTruth() {
  PlatformTrueState& t = output_.truth;
  const Eigen::Quaterniond q = QuatOf(state_).normalized();
  t.q_BP = q;
  t.pose.p_BP_B_m = state_.segment<3>(kP);
  t.pose.R_BP = q.toRotationMatrix();
  t.twist_B = state_.segment<6>(kV);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int o = kLeg0 + 4 * static_cast<int>(i);
    t.legs[i] = LegPneumaticState{state_[o], state_[o + 1], state_[o + 2], state_[o + 3]};
  }
  t.time_s = time_s_;
  t.tick = tick_;
}

void PlatformPlant::SampleSensors() {
  SensorTruth st;
  st.piston_position_m = output_.truth.piston_position_m;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    st.chamber1_pressure_pa[i] = output_.truth.legs[i].chamber1_pressure_pa;
    st.chamber2_pressure_pa[i] = output_.truth.legs[i].chamber2_pressure_pa;
  }
  st.supply_pressure_pa = output_.truth.supply_pressure_pa;
  st.q_BP = output_.truth.q_BP;
  st.angular_rate_B_rad_s = output_.truth.twist_B.tail<3>();
  sensors_.Sample(st, time_s_, output_.legs, output_.imu);
  tracker_.Sample(output_.truth.pose.p_BP_B_m, output_.truth.q_BP, time_s_, output_.tracker);
  if (!config_.faults.faults.empty()) ApplySensorFaults();
}

PlantStatus PlatformPlant::Step(const LegArray<double>& valve_v, double dt_s) {
  if (!std::isfinite(dt_s) || dt_s < 0.0) return output_.status = PlantStatus::kInvalidInput;
  if (!bench_.empty()) return StepBench(dt_s);
  for (double u : valve_v) {
    if (!std::isfinite(u)) return output_.status = PlantStatus::kInvalidInput;
  }
  const ValveParams& valve = config_.rig.valve;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    spool_target_m_[i] = SpoolTargetM(valve, valve_v[i]);  // eq 42 (clamped 0-10 V)
  }
  const int n = SubstepCount(dt_s);
  const double h = dt_s / n;
  StateVector x = state_;
  StateVector k1, k2, k3, k4;
  double t = time_s_;
  for (int s = 0; s < n; ++s) {
    // SSPRK3 or classical RK4 (docs/plant.md "Integrator"); quaternion renormalised per
    // substep. k1 is the rate at the substep's start in both.
    if (s == 0) {
      // rate_at_state_ = Derivative(state_, time_s_) from the end of the last Step / Reset /
      // SetState, evaluated with the previous spool targets; only the spool rates depend on
      // the target (eq 42 lag), recomputed here exactly as LegModel::Evaluate does.
      k1 = rate_at_state_;
      const double tau = leg_model_.params().valve.spool_time_constant_s;
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        const int o = kLeg0 + 4 * static_cast<int>(i);
        k1[o + 2] = (spool_target_m_[i] - x[o + 2]) / tau;
      }
    } else {
      Derivative(x, t, k1, false);
    }
    if (config_.integrator == PlantIntegrator::kSsprk3) {
      // Shu-Osher SSPRK3: convex combinations of forward-Euler stages u1, u2.
      StateVector u = x + h * k1;                        // u1
      Derivative(u, t + h, k2, false);
      u = 0.75 * x + 0.25 * (u + h * k2);                // u2
      Derivative(u, t + 0.5 * h, k3, false);
      x = (1.0 / 3.0) * x + (2.0 / 3.0) * (u + h * k3);
    } else {
      Derivative(x + 0.5 * h * k1, t + 0.5 * h, k2, false);
      Derivative(x + 0.5 * h * k2, t + 0.5 * h, k3, false);
      Derivative(x + h * k3, t + h, k4, false);
      x += (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4);
    }
    x.segment<4>(kQ).normalize();
    t = time_s_ + (s + 1) * h;
  }
  if (!x.allFinite()) {
    // Keep the last good state; report. (Derivative evaluation above wrote nothing.)
    return output_.status = PlantStatus::kNonFiniteState;
  }
  state_ = x;
  time_s_ += dt_s;
  last_substep_count_ = n;
  ++tick_;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    output_.truth.applied_valve_v[i] =
        std::clamp(valve_v[i], valve.min_voltage_v, valve.max_voltage_v);
  }
  // Lengths, rates and forces at the new state; the rate is also the next step's first RK
  // stage (same state and time), so every tick costs 4 evaluations per substep, not 4 + 1.
  Derivative(state_, time_s_, rate_at_state_, true);
  FillTruth();
  SampleSensors();
  return output_.status = PlantStatus::kOk;
}

int PlatformPlant::SubstepCount(double dt_s) const {
  // Largest step allowed at the present state (docs/plant.md, "Integrator"): the nominal
  // step, reduced where the pressure ODE is stiff (wide-open valve, small chamber). Depends
  // on the state only, so lockstep runs stay bit-reproducible.
  double h_max = config_.integrator_step_s;
  const PlatformTrueState& t = output_.truth;  // lengths and rates at state_
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double xp = t.piston_position_m[i];
    const double v = t.piston_velocity_m_s[i];
    const double lambda = std::max(
        leg_model_.PressureStiffnessBound1S(t.legs[i], xp, v, spool_target_m_[i], dt_s),
        leg_model_.BristleRate1S(v));
    if (lambda * h_max > config_.stiffness_step_limit) {
      h_max = config_.stiffness_step_limit / lambda;
    }
  }
  const double n = std::ceil(dt_s / h_max - 1e-9);
  // At most 1000 substeps per call (h >= 1 us for a 1 ms tick): a bound, never reached
  // by the rig's parameters (the stiffest pressure mode is ~1e4 1/s).
  return static_cast<int>(std::clamp(n, 1.0, 1000.0));
}

void PlatformPlant::SetState(const PlatformTrueState& s) {
  state_.segment<3>(kP) = s.pose.p_BP_B_m;
  const Eigen::Quaterniond q = s.q_BP.normalized();
  state_[kQ] = q.w();
  state_[kQ + 1] = q.x();
  state_[kQ + 2] = q.y();
  state_[kQ + 3] = q.z();
  state_.segment<6>(kV) = s.twist_B;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int o = kLeg0 + 4 * static_cast<int>(i);
    state_[o] = s.legs[i].chamber1_pressure_pa;
    state_[o + 1] = s.legs[i].chamber2_pressure_pa;
    state_[o + 2] = s.legs[i].spool_m;
    state_[o + 3] = s.legs[i].bristle_m;
  }
  Derivative(state_, time_s_, rate_at_state_, true);
  FillTruth();
}

Vector6d PlatformPlant::twist_rate_B() const { return rate_at_state_.segment<6>(kV); }

double PlatformPlant::TotalEnergyJ() const {
  const PlatformTrueState& t = output_.truth;
  const Eigen::Vector3d v = t.twist_B.head<3>();
  const Eigen::Vector3d w = t.twist_B.tail<3>();
  const Eigen::Matrix3d inertia_B = t.pose.R_BP * platform_inertia_P_ * t.pose.R_BP.transpose();
  double e = 0.5 * platform_mass_kg_ * v.squaredNorm() + 0.5 * w.dot(inertia_B * w);
  e += platform_mass_kg_ * gravity_m_s2_ * t.pose.p_BP_B_m.z();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    e += 0.5 * leg_mass_kg_ * t.piston_velocity_m_s[i] * t.piston_velocity_m_s[i];
    const Eigen::Vector3d joint = t.pose.p_BP_B_m + t.pose.R_BP * true_geometry_.p_PB_P[i];
    e += leg_mass_kg_ * gravity_m_s2_ * joint.z();
    e += leg_model_.StoredEnergyJ(t.legs[i], t.piston_position_m[i]);
  }
  return e;
}

}  // namespace hexa
