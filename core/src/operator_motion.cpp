#include "hexa/core/operator_motion.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hexa/core/param_checks.hpp"

namespace hexa {

void OperatorMotionConfig::Validate() const {
  jog.Validate();
  limits.Validate();
  frames.Validate();
  stream.Validate();
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.Positive("goal.linear.max_speed", goal_linear.max_speed, "speed limit");
  c.Positive("goal.linear.max_acceleration", goal_linear.max_acceleration, "acceleration limit");
  c.Positive("goal.linear.max_jerk", goal_linear.max_jerk, "jerk limit");
  c.Positive("goal.angular.max_speed", goal_angular.max_speed, "speed limit");
  c.Positive("goal.angular.max_acceleration", goal_angular.max_acceleration, "acceleration limit");
  c.Positive("goal.angular.max_jerk", goal_angular.max_jerk, "jerk limit");
  // A stopped goal is brought to rest by the jog profile: its limits must hold the goal's
  // motion (each axis of the goal's twist is at most the path's norm).
  const auto at_most = [&](const char* field, double v, const char* limit_field, double limit) {
    if (v > limit)
      c.Fail(field, std::string("must not exceed ") + limit_field + " (" + FormatParam(limit) + ")",
             FormatParam(v), "<= " + FormatParam(limit));
  };
  at_most("goal.linear.max_speed", goal_linear.max_speed, "jog.linear.max_speed", jog.linear.max_speed);
  at_most("goal.linear.max_acceleration", goal_linear.max_acceleration,
          "jog.linear.max_acceleration", jog.linear.max_acceleration);
  at_most("goal.angular.max_speed", goal_angular.max_speed, "jog.angular.max_speed", jog.angular.max_speed);
  at_most("goal.angular.max_acceleration", goal_angular.max_acceleration,
          "jog.angular.max_acceleration", jog.angular.max_acceleration);
  ThrowIfIssues(issues, "operator motion");
}

const char* ToString(OperatorMode mode) {
  switch (mode) {
    case OperatorMode::kNone: return "none";
    case OperatorMode::kJog: return "jog";
    case OperatorMode::kGoal: return "goal";
    case OperatorMode::kStream: return "stream";
  }
  return "unknown";
}

OperatorMotion::OperatorMotion(const RigParams& rig, const OperatorMotionConfig& config)
    : config_(config), limits_(rig, config.limits), jog_(config.jog), stream_(config.stream) {
  config_.Validate();
}

void OperatorMotion::BeginJog(const Pose& X_BP) noexcept {
  jog_.Reset();
  setpoint_ = X_BP;
  mode_ = OperatorMode::kJog;
  stopping_ = false;
}

GoalCheck OperatorMotion::BeginGoal(const Pose& X_BP, const Pose& X_BP_goal, double time_s) noexcept {
  const Eigen::Vector3d& pivot = config_.frames.p_PC_P_m;
  GoalCheck check = limits_.CheckGoal(X_BP, X_BP_goal, pivot);
  if (!check.accepted) return check;
  if (!goal_.Plan(PivotPose(X_BP, pivot), PivotPose(X_BP_goal, pivot), config_.goal_linear,
                  config_.goal_angular)) {
    check.accepted = false;
    std::snprintf(check.message.data(), check.message.size(),
                  "goal refused: no motion profile to it (not finite)");
    return check;
  }
  jog_.Reset();
  setpoint_ = X_BP;
  goal_start_s_ = time_s;
  mode_ = OperatorMode::kGoal;
  stopping_ = false;
  return check;
}

void OperatorMotion::BeginStream(const Pose& X_BP) noexcept {
  stream_.Restart();
  stream_neutral_ = X_BP;
  setpoint_ = X_BP;
  mode_ = OperatorMode::kStream;
  stopping_ = false;
}

void OperatorMotion::RequestStop() noexcept { stopping_ = true; }

bool OperatorMotion::SetFrames(const UserFramesConfig& frames,
                               std::array<char, 160>& message) noexcept {
  const bool still = mode_ == OperatorMode::kNone ||
                     (mode_ == OperatorMode::kJog && !stopping_ && jog_.still());
  if (!still) {
    std::snprintf(message.data(), message.size(),
                  "frames refused: the %s motion is not at rest (frames change only while still)",
                  ToString(mode_));
    return false;
  }
  char why[136];  // + the prefix: fits the 160 of the message
  if (!CheckFramesRequest(frames, config_.frames, why, sizeof(why))) {
    std::snprintf(message.data(), message.size(), "frames refused: %s", why);
    return false;
  }
  const double max_pivot_distance_m = config_.frames.max_pivot_distance_m;
  const double max_work_offset_m = config_.frames.max_work_offset_m;
  config_.frames = frames;
  config_.frames.max_pivot_distance_m = max_pivot_distance_m;  // the configured bounds stay
  config_.frames.max_work_offset_m = max_work_offset_m;
  message[0] = '\0';
  return true;
}

namespace {

// Angular velocity, in the parent's axes, of R(rpy) = Rz(yaw) Ry(pitch) Rx(roll) (pose.hpp)
// for the angle rates rpy_dot: w = E(rpy) rpy_dot, and its rate E rpy_ddot + dE/dt rpy_dot.
void AngularRatesFromRollPitchYaw(const Eigen::Vector3d& rpy, const Eigen::Vector3d& rpy_dot,
                                  const Eigen::Vector3d& rpy_ddot, Eigen::Vector3d& w,
                                  Eigen::Vector3d& w_dot) {
  const double cp = std::cos(rpy[1]), sp = std::sin(rpy[1]);
  const double cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
  Eigen::Matrix3d E;
  E << cy * cp, -sy, 0.0,
       sy * cp, cy, 0.0,
       -sp, 0.0, 1.0;
  const double dp = rpy_dot[1], dy = rpy_dot[2];
  Eigen::Matrix3d E_dot;
  E_dot << -sy * dy * cp - cy * sp * dp, -cy * dy, 0.0,
           cy * dy * cp - sy * sp * dp, -sy * dy, 0.0,
           -cp * dp, 0.0, 0.0;
  w = E * rpy_dot;
  w_dot = E * rpy_ddot + E_dot * rpy_dot;
}

}  // namespace

Pose OperatorMotion::StepStream(double time_s, const StreamPacket* packets, std::size_t count,
                                Vector6d& twist_C_B, Vector6d& acceleration_C_B,
                                OperatorMotionStatus& status) noexcept {
  MotionStreamInput in;
  in.time_s = time_s;
  in.packets = packets;
  in.packet_count = count;
  in.return_to_neutral = stopping_;
  stream_.Update(in, status.stream);
  const MotionStreamOutput& out = status.stream;
  // The displacement is in the work frame's axes (user_frames.hpp): p_C = p_C0 + R_BW d_p,
  // R_BC = R_BW R(d_rpy) R_BW^T R_BC0, so v_C = R_BW d_p', w = R_BW E(d_rpy) d_rpy'.
  const Eigen::Matrix3d& R_BW = config_.frames.X_BW.R_BP;
  Eigen::Vector3d w, w_dot;
  AngularRatesFromRollPitchYaw(out.displacement.tail<3>(), out.velocity.tail<3>(),
                               out.acceleration.tail<3>(), w, w_dot);
  twist_C_B.head<3>() = R_BW * out.velocity.head<3>();
  twist_C_B.tail<3>() = R_BW * w;
  acceleration_C_B.head<3>() = R_BW * out.acceleration.head<3>();
  acceleration_C_B.tail<3>() = R_BW * w_dot;
  status.done = stopping_ && out.state == StreamState::kWaiting;
  return PlatformPoseFromDisplacement(stream_neutral_, out.displacement, config_.frames);
}

void OperatorMotion::StepJog(double time_s, double dt_s, const JogRequest* jog, Vector6d& twist_C_B,
                             Vector6d& acceleration_C_B, OperatorMotionStatus& status) noexcept {
  const Eigen::Vector3d& pivot = config_.frames.p_PC_P_m;
  JogInput in;
  in.time_s = time_s;
  in.dt_s = dt_s;
  in.command_received = jog != nullptr && !stopping_;
  if (in.command_received) {
    in.twist_jog = jog->twist;
    in.R_B_jog = JogAxes(jog->frame, setpoint_, config_.frames);
  }
  // Look-ahead: where a stop commanded now would end; outside a limit -> brake now, so that
  // the jog slows down to the limit instead of being cut at it (docs/operate.md).
  const Pose stop = IntegratePivotTwist(setpoint_, pivot, jog_.StoppingDisplacement(), 1.0);
  in.brake = stopping_ || limits_.CheckPose(stop).kind != SoftLimitKind::kNone;
  JogOutput out;
  jog_.Update(in, out);
  twist_C_B = out.twist_C_B;
  acceleration_C_B = out.acceleration_C_B;
  status.jog = out.status;
  const bool let_go = stopping_ || out.since_command_s > config_.jog.deadman_timeout_s;
  status.done = jog_.still() && let_go;
}

void OperatorMotion::Update(double time_s, double dt_s, const JogRequest* jog,
                            TrajectorySample& desired, OperatorMotionStatus& status,
                            const StreamPacket* stream_packets,
                            std::size_t stream_packet_count) noexcept {
  status = OperatorMotionStatus{};
  status.mode = mode_;
  status.stopping = stopping_;
  const Eigen::Vector3d& pivot = config_.frames.p_PC_P_m;
  Vector6d twist_C_B = Vector6d::Zero(), acceleration_C_B = Vector6d::Zero();
  Pose candidate = setpoint_;
  if (mode_ == OperatorMode::kGoal && stopping_) {
    // Hand the goal's motion over to the jog profile, which stops it at the jerk limit.
    PoseGoalSample g;
    goal_.Evaluate(time_s - goal_start_s_, g);
    jog_.StartFrom(g.twist_C_B, g.acceleration_C_B);
    mode_ = OperatorMode::kJog;
  }
  if (mode_ == OperatorMode::kJog) {
    StepJog(time_s, dt_s, jog, twist_C_B, acceleration_C_B, status);
    candidate = IntegratePivotTwist(setpoint_, pivot, twist_C_B, dt_s);
  } else if (mode_ == OperatorMode::kGoal) {
    status.goal_time_s = time_s - goal_start_s_;
    PoseGoalSample g;
    goal_.Evaluate(status.goal_time_s, g);
    candidate = PlatformFromPivot(g.X_BC, pivot);
    twist_C_B = g.twist_C_B;
    acceleration_C_B = g.acceleration_C_B;
    status.done = g.done;
  } else if (mode_ == OperatorMode::kStream) {
    candidate = StepStream(time_s, stream_packets, stream_packet_count, twist_C_B,
                           acceleration_C_B, status);
  }
  limits_.Update({setpoint_, candidate, dt_s}, status.limits);
  setpoint_ = status.limits.setpoint;
  if (status.limits.result != SoftLimitsResult::kInside) {
    // Stopped (or held) by a limit: no velocity is asked beyond it.
    twist_C_B *= status.limits.fraction;
    acceleration_C_B.setZero();
  }
  if (status.done) {
    mode_ = OperatorMode::kNone;
    twist_C_B.setZero();
    acceleration_C_B.setZero();
  }
  // The platform origin's twist and its rate from the pivot's: v_P = v_C + w x r,
  // a_P = a_C + alpha x r + w x (w x r), r = p_P - p_C.
  const Eigen::Vector3d w = twist_C_B.tail<3>(), alpha = acceleration_C_B.tail<3>();
  const Eigen::Vector3d r = -(setpoint_.R_BP * pivot);
  desired.phase = TrajectoryPhase::kTracking;
  desired.pose = setpoint_;
  desired.twist_B.head<3>() = twist_C_B.head<3>() + w.cross(r);
  desired.twist_B.tail<3>() = w;
  desired.twist_rate_B.head<3>() = acceleration_C_B.head<3>() + alpha.cross(r) + w.cross(w.cross(r));
  desired.twist_rate_B.tail<3>() = alpha;
  desired.vector.q = VectorFromPose(setpoint_);
  // The xyz-rpy rates are not used downstream (the legs' kinematics take the twist).
  desired.vector.q_dot.setZero();
  desired.vector.q_ddot.setZero();
}

}  // namespace hexa
