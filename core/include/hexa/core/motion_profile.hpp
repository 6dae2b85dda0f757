// Jerk-limited motion for the operator modes (docs/operate.md "Jog" and "Pose goals").
// Time is an argument; nothing allocates; Update/Evaluate never throw.
//
// JerkLimitedVelocity: one axis' velocity follows a target velocity with |v| <= V,
// |a| <= A, |j| <= J. Each step picks the next acceleration a' (within a +- J dt, +-A) so
// that, if a' were then ramped to zero at the jerk limit (in steps of J dt, the last one
// partial), the velocity would end exactly at the target:
//   v + (a + a') dt / 2 + B(a') = v_target,  B(x) ~ x |x| / (2 J) (exact discrete form in the
// source), solved by bisection within the reachable range (a +- J dt, +-A). The velocity
// integrates the acceleration's linear ramp exactly (trapezoid). The target is reached with
// zero acceleration, no limit cycle.
//
// JogProfile: a twist of the pivot frame [v_C; w] (user_frames.hpp) follows the operator's
// jog command axis by axis in B; no command for longer than the dead-man timeout -> target
// zero, a smooth stop at the same limits.
//
// PoseGoalProfile: from rest at X0 to rest at X1 along the path of soft_limits.hpp
// (pivot point on a straight line, rotation about one axis), the path parameter s in [0, 1]
// following the time-optimal rest-to-rest double-S profile of Biagiotti & Melchiorri
// ("Trajectory Planning for Automatic Machines and Robots", 2008, Sec. 3.4) under the limits of
// s implied by the linear and angular limits.
#pragma once

#include "hexa/core/pose.hpp"
#include "hexa/core/user_frames.hpp"

namespace hexa {

struct AxisLimits {
  double max_speed = 0.0;         // m/s or rad/s
  double max_acceleration = 0.0;  // m/s^2 or rad/s^2
  double max_jerk = 0.0;          // m/s^3 or rad/s^3
};

struct AxisMotionState {
  double velocity = 0.0;
  double acceleration = 0.0;
};

// One step of dt_s towards `target_velocity` (clamped to +-max_speed).
void StepJerkLimitedVelocity(double target_velocity, const AxisLimits& limits, double dt_s,
                             AxisMotionState& state) noexcept;

struct JogProfileConfig {
  AxisLimits linear{0.05, 0.25, 2.5};   // m/s, m/s^2, m/s^3 per axis of B
  AxisLimits angular{0.2, 1.0, 10.0};   // rad/s, rad/s^2, rad/s^3 per axis of B
  double deadman_timeout_s = 0.25;      // no jog message for this long -> smooth stop
  double still_speed = 1e-9;            // |v|, |w| below this (and a = 0): still
  // Throws std::invalid_argument naming field, value and limit.
  void Validate() const;
};

struct JogInput {
  double time_s = 0.0;                     // this tick
  bool command_received = false;           // a jog message arrived since the last tick
  Vector6d twist_jog = Vector6d::Zero();   // [v; w] in the jog axes (m/s, rad/s)
  Eigen::Matrix3d R_B_jog = Eigen::Matrix3d::Identity();  // jog axes in B (JogAxes())
  double dt_s = 0.005;                     // time since the last Update
  // A limit lies within the stopping distance ahead (the caller checks the pose
  // StoppingDisplacement() away with the soft limits): target zero for this tick, so the jog
  // slows to a stop before the limit instead of being cut at it.
  bool brake = false;
};

enum class JogStatus { kStill, kMoving, kDeadmanStop, kRejected, kLimitBrake };
const char* ToString(JogStatus status);

struct JogOutput {
  Vector6d twist_C_B = Vector6d::Zero();         // pivot twist to integrate (IntegratePivotTwist)
  Vector6d acceleration_C_B = Vector6d::Zero();  // its rate
  Vector6d target_C_B = Vector6d::Zero();        // what the twist is heading to
  JogStatus status = JogStatus::kStill;
  double since_command_s = 0.0;
};

class JogProfile {
 public:
  explicit JogProfile(const JogProfileConfig& config);  // throws on an invalid config
  void Update(const JogInput& input, JogOutput& output) noexcept;
  // Stop at once (mode change while still, reset): state and command cleared.
  void Reset() noexcept;
  // Continue a motion already under way (a pose goal being stopped): the axes start at
  // `twist_C_B` and `acceleration_C_B` (each within this profile's limits, else clamped to
  // them), with no command: the next Update brings them to rest at the jerk limit.
  void StartFrom(const Vector6d& twist_C_B, const Vector6d& acceleration_C_B) noexcept;
  bool still() const noexcept;
  // Where a stop commanded now would end, per axis (m, rad): the acceleration ramped to zero at
  // J, then the time-optimal jerk-limited stop from the velocity reached (continuous forms).
  // As a pivot twist over 1 s (IntegratePivotTwist(X, pivot, d, 1.0)) it gives the stopping
  // pose, which the caller checks against the soft limits to set JogInput::brake.
  Vector6d StoppingDisplacement() const noexcept;

 private:
  JogProfileConfig config_;
  AxisMotionState axis_[6];
  Vector6d target_ = Vector6d::Zero();
  double last_command_time_s_ = 0.0;
  bool have_command_ = false;
};

// Rest-to-rest double-S on [0, h] (h >= 0) with limits V, A, J (all > 0).
struct DoubleSProfile {
  double distance = 0.0;
  double jerk_time_s = 0.0;          // Tj
  double acceleration_time_s = 0.0;  // Ta (= deceleration time)
  double cruise_time_s = 0.0;        // Tv
  double peak_acceleration = 0.0;    // alim = J Tj
  double peak_speed = 0.0;           // vlim = alim (Ta - Tj)
  double duration_s() const { return 2.0 * acceleration_time_s + cruise_time_s; }
};
DoubleSProfile PlanDoubleS(double distance, const AxisLimits& limits) noexcept;
// Position, velocity, acceleration at time t (clamped to [0, duration]).
void EvaluateDoubleS(const DoubleSProfile& profile, double t_s, double& position,
                     double& velocity, double& acceleration) noexcept;

struct PoseGoalSample {
  Pose X_BC;                                     // pivot frame pose
  Vector6d twist_C_B = Vector6d::Zero();         // [v_C; w] in B
  Vector6d acceleration_C_B = Vector6d::Zero();
  bool done = false;
};

class PoseGoalProfile {
 public:
  // Plans from X_BC_start (at rest) to X_BC_goal under the per-axis-free limits: |v_C| <= V_lin,
  // |w| <= V_ang, and likewise acceleration and jerk (norms along the path). False (and no
  // plan) if a pose is not finite or a limit is not positive.
  bool Plan(const Pose& X_BC_start, const Pose& X_BC_goal, const AxisLimits& linear,
            const AxisLimits& angular) noexcept;
  // t_s: time since the start of the motion.
  void Evaluate(double t_s, PoseGoalSample& sample) const noexcept;
  double duration_s() const { return profile_.duration_s(); }
  const DoubleSProfile& profile() const { return profile_; }

 private:
  Pose start_;
  Eigen::Vector3d displacement_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_rad_ = Eigen::Vector3d::Zero();
  DoubleSProfile profile_;
};

}  // namespace hexa
