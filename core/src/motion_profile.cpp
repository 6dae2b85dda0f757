// Jerk-limited jog and pose-goal profiles (see motion_profile.hpp, docs/operate.md).
#include "hexa/core/motion_profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

void CheckAxisLimits(ParamChecker& c, const std::string& path, const AxisLimits& l) {
  c.Positive(path + ".max_speed", l.max_speed, "speed limit");
  c.Positive(path + ".max_acceleration", l.max_acceleration, "acceleration limit");
  c.Positive(path + ".max_jerk", l.max_jerk, "jerk limit");
}

double Ratio(double limit, double length) {
  return length > 0.0 ? limit / length : std::numeric_limits<double>::infinity();
}


// Velocity gained while the acceleration x is ramped to zero in steps of at most J dt (the
// last one partial), integrated by the trapezoid rule as StepJerkLimitedVelocity does:
// |x| = m J dt + r, 0 <= r < J dt: the accelerations x, x -+ J dt, ..., r, 0 give
// dt ((m + 1)(|x| + r) / 2 - |x| / 2). Continuous and increasing in x; for a whole number of
// steps it is x |x| / (2 J), the continuous braking of the header.
double DiscreteBrakingVelocity(double x, double jerk_step, double dt_s) {
  const double magnitude = std::abs(x);
  const double m = std::floor(magnitude / jerk_step);
  const double r = magnitude - m * jerk_step;
  const double gained = dt_s * ((m + 1.0) * (magnitude + r) / 2.0 - magnitude / 2.0);
  return x < 0.0 ? -gained : gained;
}

}  // namespace

void StepJerkLimitedVelocity(double target_velocity, const AxisLimits& limits, double dt_s,
                             AxisMotionState& state) noexcept {
  if (!(dt_s > 0.0)) return;
  const double V = limits.max_speed, A = limits.max_acceleration, J = limits.max_jerk;
  const double target = std::clamp(target_velocity, -V, V);
  const double a = state.acceleration;
  const double jerk_step = J * dt_s;
  // f(x): the velocity error left if x is taken for this step and then ramped to zero at the
  // jerk limit. f increases with x; its root within the reachable range is the next
  // acceleration (bisection: f is only piecewise quadratic).
  const auto f = [&](double x) {
    return state.velocity + 0.5 * (a + x) * dt_s + DiscreteBrakingVelocity(x, jerk_step, dt_s) -
           target;
  };
  double lo = std::max(-A, a - jerk_step);
  double hi = std::min(A, a + jerk_step);
  double next;
  if (f(lo) >= 0.0) {
    next = lo;
  } else if (f(hi) <= 0.0) {
    next = hi;
  } else {
    for (int i = 0; i < 60 && hi - lo > 1e-15 * std::max(1.0, A); ++i) {
      const double mid = 0.5 * (lo + hi);
      (f(mid) < 0.0 ? lo : hi) = mid;
    }
    next = 0.5 * (lo + hi);
  }
  state.velocity += 0.5 * (a + next) * dt_s;
  state.acceleration = next;
  // Landed: what is left is rounding, which further steps would chase with tiny jerks.
  if (std::abs(next) <= 1e-12 * A && std::abs(state.velocity - target) <= 1e-12 * V) {
    state.velocity = target;
    state.acceleration = 0.0;
  }
}

void JogProfileConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckAxisLimits(c, "jog.linear", linear);
  CheckAxisLimits(c, "jog.angular", angular);
  c.InClosed("jog.deadman_timeout_s", deadman_timeout_s, 0.005, 2.0, "dead-man timeout");
  c.Positive("jog.still_speed", still_speed, "still threshold");
  ThrowIfIssues(issues, "jog profile");
}

const char* ToString(JogStatus status) {
  switch (status) {
    case JogStatus::kStill: return "still";
    case JogStatus::kMoving: return "moving";
    case JogStatus::kDeadmanStop: return "dead-man stop";
    case JogStatus::kRejected: return "rejected";
    case JogStatus::kLimitBrake: return "braking for a limit";
  }
  return "unknown";
}

JogProfile::JogProfile(const JogProfileConfig& config) : config_(config) { config_.Validate(); }

void JogProfile::Reset() noexcept {
  for (AxisMotionState& axis : axis_) axis = AxisMotionState{};
  target_.setZero();
  have_command_ = false;
}

void JogProfile::StartFrom(const Vector6d& twist_C_B, const Vector6d& acceleration_C_B) noexcept {
  Reset();
  for (int k = 0; k < 6; ++k) {
    const AxisLimits& l = k < 3 ? config_.linear : config_.angular;
    const double v = std::isfinite(twist_C_B[k]) ? twist_C_B[k] : 0.0;
    const double a = std::isfinite(acceleration_C_B[k]) ? acceleration_C_B[k] : 0.0;
    axis_[k].velocity = std::clamp(v, -l.max_speed, l.max_speed);
    axis_[k].acceleration = std::clamp(a, -l.max_acceleration, l.max_acceleration);
  }
}

bool JogProfile::still() const noexcept {
  for (int k = 0; k < 6; ++k) {
    if (std::abs(axis_[k].velocity) > config_.still_speed || axis_[k].acceleration != 0.0) {
      return false;
    }
  }
  return true;
}

void JogProfile::Update(const JogInput& input, JogOutput& output) noexcept {
  bool rejected = false;
  if (input.command_received) {
    if (input.twist_jog.allFinite() && input.R_B_jog.allFinite() && std::isfinite(input.time_s)) {
      target_ = TwistInBase(input.twist_jog, input.R_B_jog);
      last_command_time_s_ = input.time_s;
      have_command_ = true;
    } else {
      rejected = true;  // a bad command counts as no command: the dead-man runs on
    }
  }
  const double since = have_command_ ? input.time_s - last_command_time_s_ : 0.0;
  const bool deadman = have_command_ && !(since <= config_.deadman_timeout_s);
  if (deadman || !have_command_) target_.setZero();
  // The command is kept: once the limit is no longer ahead (the operator reversed), it resumes.
  const Vector6d target = input.brake ? Vector6d::Zero() : target_;
  const double dt = std::isfinite(input.dt_s) && input.dt_s > 0.0 ? input.dt_s : 0.0;
  for (int k = 0; k < 6; ++k) {
    StepJerkLimitedVelocity(target[k], k < 3 ? config_.linear : config_.angular, dt, axis_[k]);
    output.twist_C_B[k] = axis_[k].velocity;
    output.acceleration_C_B[k] = axis_[k].acceleration;
  }
  output.target_C_B = target;
  output.since_command_s = since;
  if (rejected) {
    output.status = JogStatus::kRejected;
  } else if (input.brake && !target_.isZero()) {
    output.status = JogStatus::kLimitBrake;
  } else if (still() && target_.isZero()) {
    output.status = JogStatus::kStill;
  } else {
    output.status = deadman ? JogStatus::kDeadmanStop : JogStatus::kMoving;
  }
}

Vector6d JogProfile::StoppingDisplacement() const noexcept {
  Vector6d d;
  for (int k = 0; k < 6; ++k) {
    const AxisLimits& l = k < 3 ? config_.linear : config_.angular;
    const double v = axis_[k].velocity, a = axis_[k].acceleration, J = l.max_jerk;
    // Ramp the acceleration to zero: t = |a| / J.
    const double t = std::abs(a) / J;
    const double jerk = a > 0.0 ? -J : J;
    const double d1 = v * t + a * t * t / 2.0 + jerk * t * t * t / 6.0;
    const double v1 = v + a * t + jerk * t * t / 2.0;
    // Time-optimal stop from v1 at rest acceleration.
    const double speed = std::abs(v1), A = l.max_acceleration;
    const double T = speed >= A * A / J ? speed / A + A / J : 2.0 * std::sqrt(speed / J);
    d[k] = d1 + v1 * T / 2.0;
  }
  return d;
}

DoubleSProfile PlanDoubleS(double distance, const AxisLimits& limits) noexcept {
  DoubleSProfile p;
  p.distance = distance;
  const double h = distance, V = limits.max_speed, A = limits.max_acceleration,
               J = limits.max_jerk;
  if (!(h > 0.0)) return p;
  // Reaching V? (B&M eq 3.19 with q0 = q1 = 0 speeds.)
  double Tj, Ta;
  if (V * J >= A * A) {
    Tj = A / J;
    Ta = Tj + V / A;
  } else {
    Tj = std::sqrt(V / J);
    Ta = 2.0 * Tj;
  }
  double Tv = h / V - Ta;
  if (Tv <= 0.0) {
    Tv = 0.0;
    if (h >= 2.0 * A * A * A / (J * J)) {  // A is reached
      Tj = A / J;
      Ta = 0.5 * Tj + std::sqrt(0.25 * Tj * Tj + h / A);
    } else {
      Tj = std::cbrt(h / (2.0 * J));
      Ta = 2.0 * Tj;
    }
  }
  p.jerk_time_s = Tj;
  p.acceleration_time_s = Ta;
  p.cruise_time_s = Tv;
  p.peak_acceleration = J * Tj;
  p.peak_speed = p.peak_acceleration * (Ta - Tj);
  return p;
}

namespace {

// Acceleration phase from rest, tau in [0, Ta].
void AccelerationPhase(const DoubleSProfile& p, double tau, double& q, double& v, double& a) {
  const double Tj = p.jerk_time_s, Ta = p.acceleration_time_s;
  const double alim = p.peak_acceleration, vlim = p.peak_speed;
  const double J = Tj > 0.0 ? alim / Tj : 0.0;
  if (tau < Tj) {
    q = J * tau * tau * tau / 6.0;
    v = 0.5 * J * tau * tau;
    a = J * tau;
  } else if (tau < Ta - Tj) {
    q = alim / 6.0 * (3.0 * tau * tau - 3.0 * Tj * tau + Tj * Tj);
    v = alim * (tau - 0.5 * Tj);
    a = alim;
  } else {
    const double r = Ta - tau;
    q = 0.5 * vlim * Ta - vlim * r + J * r * r * r / 6.0;
    v = vlim - 0.5 * J * r * r;
    a = J * r;
  }
}

}  // namespace

void EvaluateDoubleS(const DoubleSProfile& p, double t_s, double& position, double& velocity,
                     double& acceleration) noexcept {
  const double T = p.duration_s();
  if (!(p.distance > 0.0) || !(t_s < T)) {
    position = t_s > 0.0 ? p.distance : 0.0;
    velocity = acceleration = 0.0;
    return;
  }
  const double t = std::max(t_s, 0.0);
  const double Ta = p.acceleration_time_s;
  if (t <= Ta) {
    AccelerationPhase(p, t, position, velocity, acceleration);
  } else if (t <= Ta + p.cruise_time_s) {
    position = 0.5 * p.peak_speed * Ta + p.peak_speed * (t - Ta);
    velocity = p.peak_speed;
    acceleration = 0.0;
  } else {  // deceleration: the acceleration phase mirrored in time
    AccelerationPhase(p, T - t, position, velocity, acceleration);
    position = p.distance - position;
    acceleration = -acceleration;
  }
}

bool PoseGoalProfile::Plan(const Pose& X_BC_start, const Pose& X_BC_goal, const AxisLimits& linear,
                           const AxisLimits& angular) noexcept {
  profile_ = DoubleSProfile{};
  const bool finite = X_BC_start.p_BP_B_m.allFinite() && X_BC_start.R_BP.allFinite() &&
                      X_BC_goal.p_BP_B_m.allFinite() && X_BC_goal.R_BP.allFinite();
  const auto positive = [](const AxisLimits& l) {
    return l.max_speed > 0.0 && l.max_acceleration > 0.0 && l.max_jerk > 0.0;
  };
  if (!finite || !positive(linear) || !positive(angular)) return false;
  start_ = X_BC_start;
  displacement_m_ = X_BC_goal.p_BP_B_m - X_BC_start.p_BP_B_m;
  rotation_rad_ = PoseError(X_BC_goal, X_BC_start).tail<3>();
  const double d = displacement_m_.norm(), r = rotation_rad_.norm();
  // Limits of s: the tighter of the linear and the angular one (d s/dt |Delta| <= V, ...).
  AxisLimits s_limits;
  s_limits.max_speed = std::min(Ratio(linear.max_speed, d), Ratio(angular.max_speed, r));
  s_limits.max_acceleration =
      std::min(Ratio(linear.max_acceleration, d), Ratio(angular.max_acceleration, r));
  s_limits.max_jerk = std::min(Ratio(linear.max_jerk, d), Ratio(angular.max_jerk, r));
  if (d > 0.0 || r > 0.0) profile_ = PlanDoubleS(1.0, s_limits);
  return true;
}

void PoseGoalProfile::Evaluate(double t_s, PoseGoalSample& sample) const noexcept {
  double s = 1.0, s_dot = 0.0, s_ddot = 0.0;
  if (profile_.distance > 0.0) EvaluateDoubleS(profile_, t_s, s, s_dot, s_ddot);
  sample.X_BC.p_BP_B_m = start_.p_BP_B_m + s * displacement_m_;
  sample.X_BC.R_BP = RotationFromVector(s * rotation_rad_) * start_.R_BP;
  sample.twist_C_B.head<3>() = s_dot * displacement_m_;
  sample.twist_C_B.tail<3>() = s_dot * rotation_rad_;
  sample.acceleration_C_B.head<3>() = s_ddot * displacement_m_;
  sample.acceleration_C_B.tail<3>() = s_ddot * rotation_rad_;
  sample.done = !(t_s < duration_s());
}

}  // namespace hexa
