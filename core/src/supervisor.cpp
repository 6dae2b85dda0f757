// Task-space supervisor state machine (see supervisor.hpp).
#include "hexa/core/supervisor.hpp"

#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>


namespace hexa {
namespace {

constexpr double kStartPoseTolerance = 1e-6;  // m and rad: a trajectory must start at rest_

void CopyDetail(std::array<char, 160>& dst, const char* src) {
  std::snprintf(dst.data(), dst.size(), "%s", src);
}

// The supervisor's own parameters are checked before the operator modes are built from them,
// so that a bad one is reported as the supervisor's.
// The stream runs at the supervisor's period.
OperatorMotionConfig CheckedFirst(const SupervisorParams& params, const OperatorMotionConfig& config) {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckSupervisorParams(c, params);
  ThrowIfIssues(issues, "Supervisor");
  OperatorMotionConfig checked = config;
  checked.stream.period_s = params.period_s;
  checked.stream.washout.period_s = params.period_s;
  return checked;
}

}  // namespace

OperatorMotionConfig MakeOperatorMotionConfig(const RigParams& rig, const SupervisorParams& params) {
  OperatorMotionConfig config = CheckedFirst(params, OperatorMotionConfig{});
  config.limits = MakeSoftLimitsConfig(rig, params);
  return config;
}

const char* ToString(SupervisorState state) {
  switch (state) {
    case SupervisorState::kIdle: return "SUPERVISOR_IDLE";
    case SupervisorState::kBlending: return "SUPERVISOR_BLENDING";
    case SupervisorState::kTracking: return "SUPERVISOR_TRACKING";
    case SupervisorState::kStopping: return "SUPERVISOR_STOPPING";
    case SupervisorState::kHold: return "SUPERVISOR_HOLD";
    case SupervisorState::kJogging: return "SUPERVISOR_JOGGING";
    case SupervisorState::kGoal: return "SUPERVISOR_GOAL";
    case SupervisorState::kStreaming: return "SUPERVISOR_STREAMING";
  }
  return "?";
}

const char* ToString(FaultReason reason) {
  switch (reason) {
    case FaultReason::kNone: return "FAULT_NONE";
    case FaultReason::kCommandDeadlineMissed: return "FAULT_COMMAND_DEADLINE_MISSED";
    case FaultReason::kCommandStale: return "FAULT_COMMAND_STALE";
    case FaultReason::kCommandNotFinite: return "FAULT_COMMAND_NOT_FINITE";
    case FaultReason::kCommandOutOfRange: return "FAULT_COMMAND_OUT_OF_RANGE";
    case FaultReason::kSetpointStale: return "FAULT_SETPOINT_STALE";
    case FaultReason::kLivelinessLost: return "FAULT_LIVELINESS_LOST";
    case FaultReason::kDeadlineMissesExceeded: return "FAULT_DEADLINE_MISSES_EXCEEDED";
    case FaultReason::kStateNotFinite: return "FAULT_STATE_NOT_FINITE";
    case FaultReason::kEstimateOutsideWorkspace: return "FAULT_ESTIMATE_OUTSIDE_WORKSPACE";
    case FaultReason::kSensorInvalid: return "FAULT_SENSOR_INVALID";
    case FaultReason::kTrajectoryRejected: return "FAULT_TRAJECTORY_REJECTED";
    case FaultReason::kHostOverload: return "FAULT_HOST_OVERLOAD";
    case FaultReason::kComputeOverrun: return "FAULT_COMPUTE_OVERRUN";
    case FaultReason::kWriterGone: return "FAULT_WRITER_GONE";
    case FaultReason::kSupplyPressureLow: return "FAULT_SUPPLY_PRESSURE_LOW";
    case FaultReason::kSensorInconsistent: return "FAULT_SENSOR_INCONSISTENT";
    case FaultReason::kImuLost: return "FAULT_IMU_LOST";
    case FaultReason::kCommandRefused: return "FAULT_COMMAND_REFUSED";
    case FaultReason::kEstop: return "FAULT_ESTOP";
    case FaultReason::kBoardLink: return "FAULT_BOARD_LINK";
  }
  return "?";
}

const char* ToString(OperatorCommandKind kind) {
  switch (kind) {
    case OperatorCommandKind::kNone: return "none";
    case OperatorCommandKind::kStart: return "start";
    case OperatorCommandKind::kStop: return "stop";
    case OperatorCommandKind::kReset: return "reset";
    case OperatorCommandKind::kHome: return "home";
    case OperatorCommandKind::kJog: return "jog";
    case OperatorCommandKind::kGoal: return "goal";
    case OperatorCommandKind::kStream: return "stream";
    case OperatorCommandKind::kFrames: return "frames";
  }
  return "?";
}

const char* ToString(CommandResult result) {
  switch (result) {
    case CommandResult::kNone: return "none";
    case CommandResult::kAccepted: return "accepted";
    case CommandResult::kRefused: return "refused";
    case CommandResult::kRejected: return "rejected";
  }
  return "?";
}

Supervisor::Supervisor(const RigParams& rig, const SupervisorParams& params,
                       const LegArray<PotentiometerCalibrationParams>& potentiometer)
    : Supervisor(rig, params, potentiometer,
                 MakeOperatorMotionConfig(rig, params)) {}

Supervisor::Supervisor(const RigParams& rig, const SupervisorParams& params,
                       const LegArray<PotentiometerCalibrationParams>& potentiometer,
                       const OperatorMotionConfig& operator_motion)
    : rig_(rig),
      params_(params),
      estimator_(rig.geometry, PoseEstimatorConfig{params.least_squares_estimator,
                                                   params.estimator_outlier_threshold_m,
                                                   kGqfkDefaultLegs, 0.01}),
      outer_loop_(rig.geometry, params.outer_loop),
      envelope_(MakeLegEnvelope(rig, params)),
      inertial_(PlatformInertialParams::FromRig(rig)),
      potentiometer_(potentiometer),
      home_(HomePoseVector(rig.geometry.home_position_m)),
      home_motion_(std::make_shared<const ConstantMotion>(home_)),
      operator_motion_(rig, CheckedFirst(params, operator_motion)) {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckSupervisorParams(c, params);
  if (!(envelope_.max_length_m > envelope_.min_length_m)) {
    c.Fail("supervisor.stroke_margin_m", "stroke margin must leave a usable stroke",
           FormatParam(params.stroke_margin_m),
           "< cylinder.stroke_m / 2 (" + FormatParam(0.5 * rig.cylinder.stroke_m) + ")");
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    CheckPotentiometerCalibrationParams(c, potentiometer_[i],
                                        "potentiometer[leg=" + std::to_string(i + 1) + "]");
    const PotentiometerCalibrationParams& pot = potentiometer_[i];
    potentiometer_calibrated_ = potentiometer_calibrated_ || pot.offset_m != 0.0 || pot.gain != 1.0;
  }
  ThrowIfIssues(issues, "Supervisor");
  rest_ = home_;
  last_desired_.pose = PoseFromVector(home_);
  last_desired_.vector.q = home_;
}

StartRequest Supervisor::PrepareStart(Trajectory trajectory) const {
  StartRequest request;
  request.trajectory = std::move(trajectory);
  request.feasibility = CheckFeasibility(rig_, params_, request.trajectory);
  return request;
}

StartRequest Supervisor::PreparePaperStart(PaperMotion motion, int periods,
                                           double amplitude_scale) const {
  return PrepareStart(
      MakePaperTrajectory(motion, rest_, home_, timing(), periods, amplitude_scale));
}

StartRequest Supervisor::PrepareRowsStart(std::shared_ptr<const CsvMotion> rows) const {
  return PrepareStart(MakeCsvTrajectory(std::move(rows), rest_, home_, timing()));
}

StartRequest Supervisor::RejectedStart(std::string message) {
  StartRequest request;
  request.feasibility.feasible = false;
  request.feasibility.message = std::move(message);
  return request;
}

void Supervisor::StartTrajectory(const Trajectory& trajectory, double time_s) {
  trajectory_ = trajectory;
  trajectory_start_time_s_ = time_s;
  stop_at_s_ = trajectory_.tracking_end_s();
  state_ = SupervisorState::kBlending;
}

void Supervisor::FillFeedforward(const TrajectorySample& desired, double sample_time_s, bool moving,
                                 LegArray<SupervisorLegSetpoint>& setpoint) const {
  for (auto& sp : setpoint) {
    sp.feedforward_valid = false;
    sp.feedforward_force_n = 0.0;
    sp.feedforward_force_rate_n_s = 0.0;
  }
  if (!params_.feedforward_enabled) return;
  PlatformMotion motion{desired.pose, desired.twist_B, desired.twist_rate_B};
  LegForceResult now;
  if (LegForcesForMotion(rig_.geometry, inertial_, motion, now) != KinStatus::kOk) return;
  LegForceResult next = now;
  if (moving) {
    // The force one supervisor period ahead on the same trajectory: the legs interpolate
    // force + rate * dt between setpoints, as they do the length (no 200 Hz staircase).
    TrajectorySample ahead;
    trajectory_.EvaluateStopped(sample_time_s + params_.period_s, stop_at_s_, ahead);
    const PlatformMotion m{ahead.pose, ahead.twist_B, ahead.twist_rate_B};
    if (LegForcesForMotion(rig_.geometry, inertial_, m, next) != KinStatus::kOk) next = now;
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    setpoint[i].feedforward_valid = true;
    setpoint[i].feedforward_force_n = now.force_n[i];
    setpoint[i].feedforward_force_rate_n_s = (next.force_n[i] - now.force_n[i]) / params_.period_s;
  }
}

void Supervisor::EnterHold(FaultReason reason, int leg, const char* detail,
                           SupervisorOutput& output) {
  state_ = SupervisorState::kHold;
  fault_ = reason;
  fault_leg_ = leg;
  CopyDetail(fault_detail_, detail);
  output.fault_raised = true;
  // Freeze what the legs were last told: same lengths and corrections, at rest.
  for (auto& sp : last_setpoint_) {
    sp.velocity_m_s = 0.0;
    sp.acceleration_m_s2 = 0.0;
    sp.hold = true;
  }
  last_desired_.vector.q_dot.setZero();
  last_desired_.vector.q_ddot.setZero();
  last_desired_.twist_B.setZero();
  last_desired_.twist_rate_B.setZero();
  // Held at rest: the feed-forward becomes the static load of the frozen pose (the force
  // of the last setpoint would keep the motion's inertial part).
  if (initialized_) FillFeedforward(last_desired_, trajectory_time_s_, false, last_setpoint_);
}

void Supervisor::HandleCommand(const SupervisorInput& input, SupervisorOutput& output) {
  const OperatorCommandKind cmd = input.command;
  if (cmd == OperatorCommandKind::kNone) return;
  CommandResult& result = output.command_result;
  if (state_ == SupervisorState::kHold) {
    if (cmd != OperatorCommandKind::kReset) {
      result = CommandResult::kRefused;
      return;
    }
    // Leave HOLD at rest where the platform is, not where the setpoints were frozen: after an
    // e-stop (valves blocked) or a lost board the platform coasts off them, and resuming on
    // a stale setpoint would be a step. The outer loop's correction restarts from zero, so
    // that the legs are told the lengths they have; every motion from here begins with its
    // blend at limited speed. Faults still present are detected again in this same tick.
    state_ = SupervisorState::kIdle;
    if (output.estimate.status == KinStatus::kOk) {
      rest_ = output.estimate.xyz_rpy;
      outer_loop_.Reset();
    } else {
      rest_ = last_desired_.vector.q;
    }
    fault_ = FaultReason::kNone;
    fault_leg_ = 0;
    fault_detail_[0] = '\0';
    result = CommandResult::kAccepted;
    return;
  }
  if (!initialized_) {
    result = CommandResult::kRefused;  // no pose to start from yet
    return;
  }
  switch (cmd) {
    case OperatorCommandKind::kStart: {
      if (state_ != SupervisorState::kIdle || input.start == nullptr) {
        result = CommandResult::kRefused;
        return;
      }
      const StartRequest& req = *input.start;
      if (!req.feasibility.feasible || !req.trajectory.valid()) {
        result = CommandResult::kRejected;
        EnterHold(FaultReason::kTrajectoryRejected, req.feasibility.leg,
                  req.feasibility.message.empty() ? "trajectory rejected"
                                                  : req.feasibility.message.c_str(),
                  output);
        return;
      }
      const double mismatch = (req.trajectory.start_xyz_rpy() - rest_).cwiseAbs().maxCoeff();
      if (!(mismatch <= kStartPoseTolerance)) {
        char detail[160];
        std::snprintf(detail, sizeof(detail),
                      "trajectory starts %.6g away from the rest pose (prepare it from "
                      "rest_xyz_rpy())",
                      mismatch);
        result = CommandResult::kRejected;
        EnterHold(FaultReason::kTrajectoryRejected, 0, detail, output);
        return;
      }
      StartTrajectory(req.trajectory, input.time_s);
      result = CommandResult::kAccepted;
      return;
    }
    case OperatorCommandKind::kHome: {
      if (state_ != SupervisorState::kIdle) {
        result = CommandResult::kRefused;
        return;
      }
      // Blend to home; the stop phase is empty because the reference is already at rest.
      // Parameters were validated in the constructor, so this does not throw.
      TrajectoryTiming home_timing{params_.blend_duration_s, 0.0};
      StartTrajectory(Trajectory(home_motion_, rest_, home_, home_timing), input.time_s);
      result = CommandResult::kAccepted;
      return;
    }
    case OperatorCommandKind::kJog:
    case OperatorCommandKind::kGoal:
    case OperatorCommandKind::kStream:
    case OperatorCommandKind::kFrames:
      HandleMotionCommand(input, output);
      return;
    case OperatorCommandKind::kStop: {
      if (in_operator_mode()) {
        // To rest at the jog limits (a stream: back to neutral at its limits), then IDLE.
        operator_motion_.RequestStop();
      }
      if (state_ == SupervisorState::kBlending || state_ == SupervisorState::kTracking) {
        const double t = input.time_s - trajectory_start_time_s_;
        if (t < stop_at_s_) stop_at_s_ = std::max(t, 0.0);
        state_ = SupervisorState::kStopping;
      }
      result = CommandResult::kAccepted;  // stop is always honoured (no-op at rest)
      return;
    }
    case OperatorCommandKind::kReset:
      result = CommandResult::kRefused;  // reset only leaves HOLD
      return;
    case OperatorCommandKind::kNone: return;
  }
}

FaultReason Supervisor::CheckFaults(const SupervisorInput& input,
                                    const PoseEstimatorOutput& estimate, int& leg,
                                    std::array<char, 160>& detail) const {
  if (input.system_fault != FaultReason::kNone) {
    leg = 0;
    std::snprintf(detail.data(), detail.size(), "the plant reports %s",
                  ToString(input.system_fault));
    return input.system_fault;
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (input.leg_fault[i] != FaultReason::kNone) {
      leg = static_cast<int>(i) + 1;
      std::snprintf(detail.data(), detail.size(), "leg %d reports %s", leg,
                    ToString(input.leg_fault[i]));
      return input.leg_fault[i];
    }
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!input.leg_alive[i]) {
      leg = static_cast<int>(i) + 1;
      std::snprintf(detail.data(), detail.size(), "leg %d controller liveliness lost", leg);
      return FaultReason::kLivelinessLost;
    }
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (input.deadline_misses_consecutive[i] > params_.max_consecutive_deadline_misses) {
      leg = static_cast<int>(i) + 1;
      std::snprintf(detail.data(), detail.size(),
                    "leg %d: %d consecutive deadline misses (limit %d)", leg,
                    input.deadline_misses_consecutive[i], params_.max_consecutive_deadline_misses);
      return FaultReason::kDeadlineMissesExceeded;
    }
  }
  if (input.imu_deadline_misses_consecutive > params_.max_consecutive_deadline_misses) {
    leg = 0;
    std::snprintf(detail.data(), detail.size(), "IMU: %d consecutive deadline misses (limit %d)",
                  input.imu_deadline_misses_consecutive, params_.max_consecutive_deadline_misses);
    return FaultReason::kDeadlineMissesExceeded;
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double l = input.length_m[i];
    if (!std::isfinite(l) || l <= 0.0) {
      leg = static_cast<int>(i) + 1;
      std::snprintf(detail.data(), detail.size(), "leg %d: measured length %g m is invalid", leg,
                    l);
      return FaultReason::kSensorInvalid;
    }
  }
  if (inconsistent_leg_ >= 0 && inconsistent_ticks_ >= params_.length_consistency_ticks) {
    leg = inconsistent_leg_ + 1;
    std::snprintf(detail.data(), detail.size(),
                  "leg %d: measured length disagrees with the other five legs and the IMU by "
                  "%.1f mm (limit %.1f mm, %d ticks): length sensor stuck or drifting",
                  leg, inconsistent_residual_m_ * 1e3, params_.length_consistency_limit_m * 1e3,
                  inconsistent_ticks_);
    return FaultReason::kSensorInconsistent;
  }
  if (estimate.status != KinStatus::kOk) {
    leg = 0;
    std::snprintf(detail.data(), detail.size(), "pose estimate failed: %s (IMU or lengths)",
                  hexa::ToString(estimate.status));
    return FaultReason::kSensorInvalid;
  }
  const double distance_m = (estimate.pose.p_BP_B_m - home_.head<3>()).norm();
  const double rotation_rad =
      PoseError(PoseFromVector(home_), estimate.pose).tail<3>().norm();
  if (distance_m > params_.workspace_radius_m || rotation_rad > params_.workspace_max_rotation_rad) {
    leg = 0;
    std::snprintf(detail.data(), detail.size(),
                  "estimate %.1f mm / %.2f deg from home exceeds the workspace %.1f mm / %.2f deg",
                  distance_m * 1e3, rotation_rad * 180.0 / 3.14159265358979323846,
                  params_.workspace_radius_m * 1e3,
                  params_.workspace_max_rotation_rad * 180.0 / 3.14159265358979323846);
    return FaultReason::kEstimateOutsideWorkspace;
  }
  return FaultReason::kNone;
}

void Supervisor::Update(const SupervisorInput& input, SupervisorOutput& output) noexcept {
  output.command_result = CommandResult::kNone;
  output.command_detail[0] = '\0';
  output.fault_raised = false;

  // 0. Calibrated lengths (reading of piston position x = offset + gain x).
  sensed_length_m_ = input.length_m;
  if (potentiometer_calibrated_) {
    const double mid = rig_.cylinder.mid_stroke_length_m;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      sensed_length_m_[i] =
          mid + (input.length_m[i] - mid - potentiometer_[i].offset_m) / potentiometer_[i].gain;
    }
  }

  // 1. Estimate (IMU orientation + GQFK / LSQ position).
  PoseEstimatorInput est_in;
  est_in.length_m = sensed_length_m_;
  est_in.orientation_wxyz = input.orientation_wxyz;
  estimator_.Update(est_in, output.estimate);

  // 2. Latch the first valid estimate as the rest pose ("blend from the current pose").
  if (!initialized_ && output.estimate.status == KinStatus::kOk) {
    initialized_ = true;
    rest_ = output.estimate.xyz_rpy;
    // What a fault at this very tick freezes: the legs where they are.
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      last_setpoint_[i] = SupervisorLegSetpoint{sensed_length_m_[i], 0.0, 0.0, 0.0, false};
    }
    last_desired_ = TrajectorySample{};
    last_desired_.vector.q = rest_;
    last_desired_.pose = output.estimate.pose;
  }

  // 3. Operator command.
  HandleCommand(input, output);

  // 4. Desired pose for this tick.
  TrajectorySample desired;
  output.operator_motion = OperatorMotionStatus{};
  if (in_operator_mode()) {
    // Dt: the tick's period (time is an argument; the jog integrates over it).
    const bool jog_message = input.command == OperatorCommandKind::kJog &&
                             output.command_result == CommandResult::kAccepted;
    operator_motion_.Update(input.time_s, params_.period_s, jog_message ? &input.jog : nullptr,
                            desired, output.operator_motion, input.stream_packets,
                            input.stream_packet_count);
    if (output.operator_motion.done) {
      state_ = SupervisorState::kIdle;
      rest_ = desired.vector.q;
    }
  }
  if (following_trajectory()) {
    trajectory_time_s_ = input.time_s - trajectory_start_time_s_;
    trajectory_.EvaluateStopped(trajectory_time_s_, stop_at_s_, desired);
    switch (desired.phase) {
      case TrajectoryPhase::kBlend: state_ = SupervisorState::kBlending; break;
      case TrajectoryPhase::kTracking: state_ = SupervisorState::kTracking; break;
      case TrajectoryPhase::kStop: state_ = SupervisorState::kStopping; break;
      case TrajectoryPhase::kDone:
        state_ = SupervisorState::kIdle;
        rest_ = trajectory_.rest_xyz_rpy();
        break;
    }
  }
  if (state_ == SupervisorState::kIdle) {
    desired.phase = TrajectoryPhase::kDone;
    desired.vector.q = rest_;
    desired.vector.q_dot.setZero();
    desired.vector.q_ddot.setZero();
    desired.pose = PoseFromVector(rest_);
    desired.twist_B.setZero();
    desired.twist_rate_B.setZero();
  }

  // 5. Safety checks (HOLD latches until reset).
  if (initialized_) UpdateConsistency(input);
  if (state_ != SupervisorState::kHold && initialized_) {
    int leg = 0;
    std::array<char, 160> detail{};
    const FaultReason fault = CheckFaults(input, output.estimate, leg, detail);
    if (fault != FaultReason::kNone) EnterHold(fault, leg, detail.data(), output);
  }

  // 6. Outer loop and setpoints.
  const bool estimate_ok = output.estimate.status == KinStatus::kOk;
  OuterLoopInput ol_in;
  ol_in.estimated = output.estimate.pose;
  ol_in.estimate_valid = estimate_ok;
  if (state_ == SupervisorState::kHold) {
    ol_in.desired = last_desired_.pose;
    ol_in.freeze = true;
    outer_loop_.Update(ol_in, output.outer_loop);
    output.setpoint = last_setpoint_;
    output.desired = last_desired_;
  } else if (!initialized_) {
    // No pose yet: hold the legs where they are.
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      output.setpoint[i] = SupervisorLegSetpoint{sensed_length_m_[i], 0.0, 0.0, 0.0, true};
    }
    output.outer_loop = OuterLoopOutput{};
    output.desired = desired;
  } else {
    ol_in.desired = desired.pose;
    // Setpoint lead (control_params.hpp): the legs track the motion setpoint_lead_s ahead.
    TrajectorySample led = desired;
    double led_time_s = trajectory_time_s_;
    const bool moving = following_trajectory();
    if (moving && params_.setpoint_lead_s > 0.0) {
      led_time_s = trajectory_time_s_ + params_.setpoint_lead_s;
      trajectory_.EvaluateStopped(led_time_s, stop_at_s_, led);
    }
    LegArray<double> length_m{}, speed_m_s{}, accel_m_s2{};
    LegKinematicsOf(rig_.geometry, led, length_m, speed_m_s, accel_m_s2);  // eq 46
    for (const double v : speed_m_s) ol_in.max_leg_speed_m_s = std::max(ol_in.max_leg_speed_m_s, std::abs(v));
    outer_loop_.Update(ol_in, output.outer_loop);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      output.setpoint[i] = SupervisorLegSetpoint{length_m[i], speed_m_s[i], accel_m_s2[i],
                                                 output.outer_loop.correction_m[i], false};
    }
    FillFeedforward(led, led_time_s, moving, output.setpoint);
    last_setpoint_ = output.setpoint;
    // A HOLD freezes the pose the legs were told (the led one), so that reset rests there.
    last_desired_ = led;
    output.desired = desired;
  }

  output.state = state_;
  output.trajectory_time_s = following_trajectory() || state_ == SupervisorState::kHold
                                 ? trajectory_time_s_
                                 : output.operator_motion.goal_time_s;
  output.desired_xyz_rpy = output.desired.vector.q;
  output.fault = fault_;
  output.fault_leg = fault_leg_;
  output.fault_detail = fault_detail_;
}

void Supervisor::HandleMotionCommand(const SupervisorInput& input, SupervisorOutput& output) {
  CommandResult& result = output.command_result;
  if (input.command == OperatorCommandKind::kFrames) {
    // Only while still: IDLE, or a jog at rest (OperatorMotion::SetFrames checks the latter).
    if (state_ != SupervisorState::kIdle && state_ != SupervisorState::kJogging) {
      result = CommandResult::kRefused;
      std::snprintf(output.command_detail.data(), output.command_detail.size(),
                    "frames only from SUPERVISOR_IDLE or SUPERVISOR_JOGGING at rest (state %s)",
                    ToString(state_));
      return;
    }
    result = operator_motion_.SetFrames(input.frames, output.command_detail)
                 ? CommandResult::kAccepted
                 : CommandResult::kRefused;
    return;
  }
  const bool jog = input.command == OperatorCommandKind::kJog;
  if (jog && state_ == SupervisorState::kJogging) {
    result = CommandResult::kAccepted;  // the jog goes on (Update takes the message)
    return;
  }
  if (state_ != SupervisorState::kIdle) {
    result = CommandResult::kRefused;
    std::snprintf(output.command_detail.data(), output.command_detail.size(),
                  "%s only from SUPERVISOR_IDLE%s (state %s)", ToString(input.command),
                  jog ? " or SUPERVISOR_JOGGING" : "", ToString(state_));
    return;
  }
  const Pose rest = PoseFromVector(rest_);
  if (jog) {
    operator_motion_.BeginJog(rest);
    state_ = SupervisorState::kJogging;
    result = CommandResult::kAccepted;
    return;
  }
  if (input.command == OperatorCommandKind::kStream) {
    operator_motion_.BeginStream(rest);
    state_ = SupervisorState::kStreaming;
    result = CommandResult::kAccepted;
    return;
  }
  const GoalCheck check = operator_motion_.BeginGoal(rest, input.goal_X_BP, input.time_s);
  if (!check.accepted) {
    result = CommandResult::kRefused;
    output.command_detail = check.message;
    return;
  }
  state_ = SupervisorState::kGoal;
  result = CommandResult::kAccepted;
}

void Supervisor::UpdateConsistency(const SupervisorInput& input) {
  // Six lengths and the IMU orientation over-determine the position (3 unknowns): a leg whose
  // reading disagrees with the other five shows as the outlier of the least-squares fit.
  const auto& q = input.orientation_wxyz;
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  GqfkLsqResult fit;
  KinStatus status = KinStatus::kInvalidInput;
  if (std::isfinite(norm) && std::abs(norm - 1.0) < 0.01) {
    const Eigen::Matrix3d R_BP =
        Eigen::Quaterniond(q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm).toRotationMatrix();
    // The lengths as the estimator sees them (potentiometer calibration applied).
    status = GqfkLeastSquares(rig_.geometry, R_BP, sensed_length_m_,
                              params_.length_consistency_limit_m, fit);
  }
  if (status == KinStatus::kInvalidInput || status == KinStatus::kDegenerate) {
    inconsistent_leg_ = -1;  // other checks name invalid inputs
    inconsistent_ticks_ = 0;
    return;
  }
  double worst = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i) worst = std::max(worst, std::abs(fit.residual_m[i]));
  max_consistency_residual_m_ = std::max(max_consistency_residual_m_, worst);
  if (fit.excluded_leg < 0) {
    inconsistent_leg_ = -1;
    inconsistent_ticks_ = 0;
    return;
  }
  inconsistent_ticks_ = fit.excluded_leg == inconsistent_leg_ ? inconsistent_ticks_ + 1 : 1;
  inconsistent_leg_ = fit.excluded_leg;
  inconsistent_residual_m_ = std::abs(fit.residual_m[static_cast<std::size_t>(fit.excluded_leg)]);
}

}  // namespace hexa
