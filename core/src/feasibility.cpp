// Feasibility check of a trajectory against the leg envelope (see feasibility.hpp).
#include "hexa/core/feasibility.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "hexa/core/soft_limits.hpp"

namespace hexa {
namespace {

// Flow function of the choked branch of eq 4: m_dot = C_f A_v P_u / sqrt(T) * kChoked.
double ChokedFlowConstant(const AirParams& air) {
  const double k = air.heat_ratio;
  return std::sqrt(k / air.gas_constant_j_kg_k * std::pow(2.0 / (k + 1.0), (k + 1.0) / (k - 1.0)));
}

std::string Format(const char* fmt, int leg, double t, double a, double b, double c) {
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer), fmt, leg, t, a, b, c);
  return buffer;
}

}  // namespace

ValveEnvelope DeriveValveEnvelope(const RigParams& rig) {
  const AirParams& air = rig.air;
  const CylinderParams& cyl = rig.cylinder;
  const double k = air.heat_ratio;
  const double critical_ratio = std::pow(2.0 / (k + 1.0), k / (k - 1.0));  // eq 5, 0.528
  const double flow_constant = ChokedFlowConstant(air);
  const double cf_a = rig.valve.discharge_coefficient * rig.valve.max_orifice_area_m2;
  const double rt = air.gas_constant_j_kg_k * air.temperature_k;

  ValveEnvelope env;
  // Fully open valve, supply upstream: choked mass flow (eq 4, second branch).
  env.choked_mass_flow_kg_s = cf_a * air.supply_pressure_pa / std::sqrt(air.temperature_k) *
                              flow_constant;
  // Inflow side: the flow stays choked while the chamber is below Pc * Ps (eq 5); at that
  // highest choked chamber pressure the same mass flow is the smallest volume flow, so the
  // piston speed it allows, m_dot R T / (Pc Ps A), is the conservative inflow bound
  // (isothermal chamber at steady speed).
  const double chamber_pa = critical_ratio * air.supply_pressure_pa;
  const double inflow_volume_m3_s = env.choked_mass_flow_kg_s * rt / chamber_pa;
  // Exhaust side: while the exhausting chamber is above Pa / Pc the exhaust is choked and
  // its volume flow at chamber conditions, C_f A sqrt(T) kChoked R, does not depend on the
  // chamber pressure.
  const double exhaust_volume_m3_s =
      cf_a * std::sqrt(air.temperature_k) * flow_constant * air.gas_constant_j_kg_k;
  env.extend_speed_m_s = std::min(inflow_volume_m3_s / cyl.cap_area_m2,
                                  exhaust_volume_m3_s / cyl.annulus_area_m2);
  env.retract_speed_m_s = std::min(inflow_volume_m3_s / cyl.annulus_area_m2,
                                   exhaust_volume_m3_s / cyl.cap_area_m2);
  env.max_speed_m_s = std::min(env.extend_speed_m_s, env.retract_speed_m_s);

  // Largest net pneumatic force (supply on one side, atmosphere on the other; eq 1, 2),
  // less static friction (Table 8) and the leg's share of the platform weight, which the
  // leg lifts when extending and which helps it when retracting.
  const double weight_share_n = rig.platform.mass_kg * rig.platform.gravity_m_s2 / kNumLegs;
  const double pa = air.atmosphere_pressure_pa;
  env.extend_force_n = air.supply_pressure_pa * cyl.cap_area_m2 - pa * cyl.annulus_area_m2 -
                       pa * cyl.rod_area_m2 - rig.friction.extend.static_n - weight_share_n;
  env.retract_force_n = air.supply_pressure_pa * cyl.annulus_area_m2 + pa * cyl.rod_area_m2 -
                        pa * cyl.cap_area_m2 - rig.friction.retract.static_n + weight_share_n;
  env.effective_mass_kg = cyl.moving_mass_kg + rig.platform.mass_kg / kNumLegs;
  env.max_acceleration_m_s2 =
      std::max(0.0, std::min(env.extend_force_n, env.retract_force_n)) / env.effective_mass_kg;
  return env;
}

LegEnvelope MakeLegEnvelope(const RigParams& rig, const SupervisorParams& params) {
  const ValveEnvelope valve = DeriveValveEnvelope(rig);
  LegEnvelope env;
  const double half_stroke_m = 0.5 * rig.cylinder.stroke_m;
  env.min_length_m = rig.cylinder.mid_stroke_length_m - half_stroke_m + params.stroke_margin_m;
  env.max_length_m = rig.cylinder.mid_stroke_length_m + half_stroke_m - params.stroke_margin_m;
  env.max_speed_m_s = std::min(params.max_leg_speed_m_s, valve.max_speed_m_s);
  env.max_acceleration_m_s2 =
      std::min(params.max_leg_acceleration_m_s2, valve.max_acceleration_m_s2);
  return env;
}

void LegKinematicsOf(const GeometryParams& geometry, const TrajectorySample& sample,
                     LegArray<double>& length_m, LegArray<double>& speed_m_s,
                     LegArray<double>& acceleration_m_s2) {
  const Eigen::Vector3d& p = sample.pose.p_BP_B_m;
  const Eigen::Matrix3d& R = sample.pose.R_BP;
  const Eigen::Vector3d v = sample.twist_B.head<3>();
  const Eigen::Vector3d w = sample.twist_B.tail<3>();
  const Eigen::Vector3d a = sample.twist_rate_B.head<3>();
  const Eigen::Vector3d alpha = sample.twist_rate_B.tail<3>();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const Eigen::Vector3d r = R * geometry.p_PB_P[i];  // platform joint from P origin, in B
    const Eigen::Vector3d d = p + r - geometry.p_BA_B[i];  // eq 46: leg vector
    const Eigen::Vector3d d_dot = v + w.cross(r);
    const Eigen::Vector3d d_ddot = a + alpha.cross(r) + w.cross(w.cross(r));
    const double l = d.norm();
    const Eigen::Vector3d s = d / l;
    const double l_dot = s.dot(d_dot);
    length_m[i] = l;
    speed_m_s[i] = l_dot;
    acceleration_m_s2[i] = s.dot(d_ddot) + (d_dot.squaredNorm() - l_dot * l_dot) / l;
  }
}

FeasibilityReport CheckFeasibility(const RigParams& rig, const SupervisorParams& params,
                                   const Trajectory& trajectory, double sample_period_s) {
  if (!trajectory.valid()) throw std::invalid_argument("CheckFeasibility: empty trajectory");
  if (!(sample_period_s > 0.0) || !std::isfinite(sample_period_s)) {
    throw std::invalid_argument("CheckFeasibility: sample_period_s must be > 0");
  }
  FeasibilityReport report;
  report.envelope = MakeLegEnvelope(rig, params);
  const LegEnvelope& env = report.envelope;
  report.min_length_m.fill(INFINITY);
  report.max_length_m.fill(-INFINITY);
  report.max_abs_speed_m_s.fill(0.0);
  report.max_abs_acceleration_m_s2.fill(0.0);

  const double duration_s = trajectory.duration_s();
  // Bounded work (the supervisor prepares a start between its ticks): a trajectory longer than
  // kMaxTrajectoryDuration_s is rejected unchecked instead of being sampled for hours.
  if (!(duration_s <= kMaxTrajectoryDuration_s) ||
      !(duration_s / sample_period_s <= static_cast<double>(kMaxFeasibilitySamples))) {
    report.feasible = false;
    report.violation = FeasibilityViolation::kTooLong;
    report.value = duration_s;
    report.limit = std::min(kMaxTrajectoryDuration_s,
                            static_cast<double>(kMaxFeasibilitySamples) * sample_period_s);
    char buffer[200];
    std::snprintf(buffer, sizeof(buffer),
                  "trajectory lasts %.6g s (blend, motion and stop), more than the limit of "
                  "%.6g s that can be checked before motion",
                  duration_s, report.limit);
    report.message = buffer;
    return report;
  }
  const long n = static_cast<long>(std::ceil(duration_s / sample_period_s));
  TrajectorySample sample;
  LegArray<double> length_m{}, speed_m_s{}, accel_m_s2{};
  // The report names the worst violation over the whole trajectory: not-finite values
  // first, then the stroke, then speed, then acceleration; within a kind the largest
  // relative excess (stroke: excess / usable stroke; speed, acceleration: value / limit - 1),
  // the earliest sample on a tie.
  // Last, the soft limits' static checks (the pose box, the joints' deflections; the stroke
  // is the envelope's above), largest normalised excess first.
  auto rank = [](FeasibilityViolation v) {
    switch (v) {
      case FeasibilityViolation::kTooLong: return 6;
      case FeasibilityViolation::kNotFinite: return 5;
      case FeasibilityViolation::kStroke: return 4;
      case FeasibilityViolation::kSpeed: return 3;
      case FeasibilityViolation::kAcceleration: return 2;
      case FeasibilityViolation::kSoftLimit: return 1;
      case FeasibilityViolation::kNone: return 0;
    }
    return 0;
  };
  const SoftLimits soft_limits(rig, MakeSoftLimitsConfig(rig, params));
  PoseLimitCheck soft_violation;
  // A rest pose already outside them (the estimate after a reset from HOLD) may blend back in:
  // the blend is then not held to them, the motion is.
  const bool rest_outside =
      soft_limits.CheckPose(PoseFromVector(trajectory.start_xyz_rpy())).kind != SoftLimitKind::kNone;
  double worst_ratio = 0.0;
  LegArray<double> bad_length_m{}, bad_speed_m_s{}, bad_accel_m_s2{};
  const double usable_stroke_m = env.max_length_m - env.min_length_m;
  for (long k = 0; k <= n; ++k) {
    const double t = std::min(static_cast<double>(k) * sample_period_s, duration_s);
    trajectory.Evaluate(t, sample);
    LegKinematicsOf(rig.geometry, sample, length_m, speed_m_s, accel_m_s2);
    ++report.samples;
    const PoseLimitCheck pose_check = soft_limits.CheckPose(sample.pose);
    const bool held_to_soft_limits = !(rest_outside && sample.phase == TrajectoryPhase::kBlend);
    if (held_to_soft_limits && pose_check.kind != SoftLimitKind::kNone &&
        pose_check.kind != SoftLimitKind::kStroke &&
        pose_check.kind != SoftLimitKind::kNotFinite &&
        (rank(FeasibilityViolation::kSoftLimit) > rank(report.violation) ||
         (report.violation == FeasibilityViolation::kSoftLimit && pose_check.excess > worst_ratio))) {
      worst_ratio = pose_check.excess;
      report.feasible = false;
      report.violation = FeasibilityViolation::kSoftLimit;
      report.leg = pose_check.kind == SoftLimitKind::kPoseBox ? 0 : pose_check.index;
      report.time_s = t;
      report.value = pose_check.value;
      report.limit = pose_check.limit;
      soft_violation = pose_check;
    }
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double l = length_m[i], ld = speed_m_s[i], ldd = accel_m_s2[i];
      report.min_length_m[i] = std::min(report.min_length_m[i], l);
      report.max_length_m[i] = std::max(report.max_length_m[i], l);
      report.max_abs_speed_m_s[i] = std::max(report.max_abs_speed_m_s[i], std::abs(ld));
      report.max_abs_acceleration_m_s2[i] =
          std::max(report.max_abs_acceleration_m_s2[i], std::abs(ldd));
      auto consider = [&](FeasibilityViolation v, double ratio, double val, double lim) {
        const bool worse = rank(v) > rank(report.violation) ||
                           (rank(v) == rank(report.violation) && ratio > worst_ratio);
        if (!worse) return;
        worst_ratio = ratio;
        report.feasible = false;
        report.violation = v;
        report.leg = static_cast<int>(i) + 1;
        report.time_s = t;
        report.value = val;
        report.limit = lim;
        bad_length_m = length_m;
        bad_speed_m_s = speed_m_s;
        bad_accel_m_s2 = accel_m_s2;
      };
      if (!std::isfinite(l) || !std::isfinite(ld) || !std::isfinite(ldd)) {
        consider(FeasibilityViolation::kNotFinite, 0.0, l, 0.0);
        continue;
      }
      if (l > env.max_length_m) {
        consider(FeasibilityViolation::kStroke, (l - env.max_length_m) / usable_stroke_m, l,
                 env.max_length_m);
      }
      if (l < env.min_length_m) {
        consider(FeasibilityViolation::kStroke, (env.min_length_m - l) / usable_stroke_m, l,
                 env.min_length_m);
      }
      if (std::abs(ld) > env.max_speed_m_s) {
        consider(FeasibilityViolation::kSpeed, std::abs(ld) / env.max_speed_m_s - 1.0, ld,
                 env.max_speed_m_s);
      }
      if (std::abs(ldd) > env.max_acceleration_m_s2) {
        consider(FeasibilityViolation::kAcceleration,
                 std::abs(ldd) / env.max_acceleration_m_s2 - 1.0, ldd, env.max_acceleration_m_s2);
      }
    }
  }
  const int leg = report.leg;
  const double t = report.time_s, value = report.value, limit = report.limit;
  switch (report.violation) {
    case FeasibilityViolation::kStroke:
      report.message =
          value > limit
              ? Format("leg %d at t=%.3f s: length %.4f m exceeds the stroke limit %.4f m "
                       "by %.1f mm",
                       leg, t, value, limit, (value - limit) * 1e3)
              : Format("leg %d at t=%.3f s: length %.4f m is below the stroke limit %.4f m "
                       "by %.1f mm",
                       leg, t, value, limit, (limit - value) * 1e3);
      break;
    case FeasibilityViolation::kSpeed:
      report.message = Format(
          "leg %d at t=%.3f s: speed %.3f m/s exceeds the speed limit %.3f m/s by %.3f m/s", leg,
          t, std::abs(value), limit, std::abs(value) - limit);
      break;
    case FeasibilityViolation::kAcceleration:
      report.message = Format(
          "leg %d at t=%.3f s: acceleration %.2f m/s2 exceeds the limit %.2f m/s2 by %.2f m/s2",
          leg, t, std::abs(value), limit, std::abs(value) - limit);
      break;
    case FeasibilityViolation::kNotFinite:
      report.message = Format(
          "leg %d at t=%.3f s: length, speed or acceleration is not finite (%g, %g, %g)", leg, t,
          bad_length_m[leg - 1], bad_speed_m_s[leg - 1], bad_accel_m_s2[leg - 1]);
      break;
    case FeasibilityViolation::kSoftLimit: {
      static constexpr const char* kAxis[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
      char buffer[200];
      if (soft_violation.kind == SoftLimitKind::kPoseBox) {
        const int axis = soft_violation.index - 1;
        std::snprintf(buffer, sizeof(buffer),
                      "at t=%.3f s the pose leaves the soft limits' pose box: %s %.4f %s beyond "
                      "the limit %.4f (rig file supervisor.soft_limits)",
                      t, kAxis[axis], value, axis < 3 ? "m" : "rad", limit);
      } else {
        std::snprintf(buffer, sizeof(buffer),
                      "leg %d at t=%.3f s: %s %.4f rad beyond the soft limit %.4f rad (rig file "
                      "supervisor.soft_limits)",
                      leg, t, ToString(soft_violation.kind), value, limit);
      }
      report.message = buffer;
      break;
    }
    case FeasibilityViolation::kTooLong:
    case FeasibilityViolation::kNone: break;
  }
  return report;
}

}  // namespace hexa
