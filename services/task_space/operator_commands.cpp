// The supervisor's operator commands (supervisor_node.hpp): taken on the main thread, checked,
// handed to the core at the next tick, answered in the NodeStatus detail (command_answer.hpp).
#include <cmath>
#include <cstdio>
#include <cstring>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/core/calibration.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/operator_motion_wire.hpp"
#include "supervisor_node.hpp"

namespace hexa::task_space {
namespace {

const char* CommandName(hexa_msg_OperatorCommandKind kind) {
  switch (kind) {
    case hexa_msg_OPERATOR_START: return "start";
    case hexa_msg_OPERATOR_STOP: return "stop";
    case hexa_msg_OPERATOR_RESET: return "reset";
    case hexa_msg_OPERATOR_HOME: return "home";
    case hexa_msg_OPERATOR_SHUTDOWN: return "shutdown";
    case hexa_msg_OPERATOR_JOG: return "jog";
    case hexa_msg_OPERATOR_GOAL: return "goal";
    case hexa_msg_OPERATOR_ESTOP: return "estop";
    case hexa_msg_OPERATOR_STREAM: return "stream";
    case hexa_msg_OPERATOR_FRAMES: return "frames";
  }
  return "unknown";
}

// Why the core refused `cmd` in state `before` (core Supervisor::HandleCommand's rules).
void WhyRefused(OperatorCommandKind cmd, SupervisorState before, bool initialized,
                char (&why)[160]) {
  if (before == SupervisorState::kHold)
    std::snprintf(why, sizeof why, "the platform is held (%s): only reset leaves HOLD",
                  ToString(before));
  else if (cmd == OperatorCommandKind::kReset)
    std::snprintf(why, sizeof why, "reset only leaves HOLD (state %s)", ToString(before));
  else if (!initialized)
    std::snprintf(why, sizeof why, "no pose estimate yet");
  else
    std::snprintf(why, sizeof why, "%s only from SUPERVISOR_IDLE (state %s)", ToString(cmd),
                  ToString(before));
}

}  // namespace

bool SupervisorNode::PrepareStart(const std::string& trajectory, int periods) {
  PaperMotion motion;
  StartRequest request;
  if (trajectory == "calibration") {
    // Kinematic calibration poses (core/calibration.hpp), record with --tracker.
    request = supervisor_.PrepareStart(MakeCalibrationTrajectory(
        supervisor_.rig(), supervisor_.rest_xyz_rpy(), supervisor_.home_xyz_rpy(),
        supervisor_.timing(), CalibrationProcedureParams{}));
  } else if (ParsePaperMotion(trajectory, motion)) {
    request = supervisor_.PreparePaperStart(motion, periods);
  } else {
    // The file is read and validated here (config/), the core gets the rows; a file that does
    // not parse becomes a rejected start: HOLD with the parser's message, a FaultEvent, exit 5.
    try {
      request = supervisor_.PrepareRowsStart(config::LoadCsvTrajectory(trajectory));
    } catch (const std::exception& e) {  // config::CsvTrajectoryError, or the core's checks
      request = Supervisor::RejectedStart(e.what());
    }
  }
  if (!request.feasibility.feasible) {
    log_->error("trajectory '{}' rejected before any motion: {}", trajectory,
                request.feasibility.message);
  } else {
    log_->info("trajectory '{}' accepted: {:.3f} s, tracking window [{:.3f}, {:.3f}) s",
               trajectory, request.trajectory.duration_s(), request.trajectory.tracking_start_s(),
               request.trajectory.tracking_end_s());
  }
  pending_start_ = std::move(request);
  pending_command_ = OperatorCommandKind::kStart;
  return pending_start_->feasibility.feasible;
}

void SupervisorNode::AnswerCommand(std::uint32_t sequence, const char* kind,
                                   CommandAnswer answer, const char* why) {
  char (&detail)[sizeof last_answer_] = last_answer_;
  FormatCommandAnswer(detail, sequence, kind, answer, why);
  last_answer_cycle_ = cycles_;
  (answer == CommandAnswer::kAccepted ? log_->info("{}", detail)
                                                        : log_->warn("{}", detail));
  runtime_.Publish(RunningState(), Figures(), detail);
}

void SupervisorNode::TakeOperatorCommands() {
  services::TakeValid(operator_reader_, [&](const hexa_msg_OperatorCommand& c, std::size_t k) {
    // Only the session's operator tools command the supervisor (docs/faults.md, "Foreign
    // commands"): an unauthenticated command is refused and its writer reported.
    const comm::CommandTrust trust = operator_reader_.Authenticate(k);
    if (!comm::Trusted(trust)) {
      log_->warn("operator command #{} (kind {}) REFUSED: {}", c.sequence, static_cast<int>(c.kind),
                 comm::ToString(trust));
      refusals_.Refuse(operator_reader_.get(), operator_reader_.info(k), trust,
                       "OperatorCommand", 0, last_run_tick_, faults_, *log_);
      return;
    }
    if (c.kind == hexa_msg_OPERATOR_JOG) {
      log_->debug("operator command #{}: jog", c.sequence);  // a stream: tens a second
    } else {
      log_->info("operator command #{}: kind {} trajectory '{}'", c.sequence,
                 static_cast<int>(c.kind), c.trajectory);
    }
    // Commands take effect at the next tick; one that a newer one replaces before then is
    // answered below, so that no operator waits for it in vain.
    const OperatorCommandKind replaced =
        pending_from_operator_ ? pending_command_ : OperatorCommandKind::kNone;
    const std::uint32_t replaced_sequence = pending_sequence_;
    switch (c.kind) {
      case hexa_msg_OPERATOR_START: {
        if (!supervisor_.initialized()) {
          AnswerCommand(c.sequence, "start", CommandAnswer::kRefused,
                        "no pose estimate yet");
          return;
        }
        const std::string traj = std::strcmp(c.trajectory, "csv") == 0 ? c.csv_path : c.trajectory;
        PrepareStart(traj, options_.periods);
        break;
      }
      case hexa_msg_OPERATOR_STOP: pending_command_ = OperatorCommandKind::kStop; break;
      case hexa_msg_OPERATOR_RESET:
        pending_command_ = OperatorCommandKind::kReset;
        leg_fault_.fill(FaultReason::kNone);  // re-latched if the cause is still reported
        system_fault_ = FaultReason::kNone;
        break;
      case hexa_msg_OPERATOR_HOME: pending_command_ = OperatorCommandKind::kHome; break;
      case hexa_msg_OPERATOR_JOG:
      case hexa_msg_OPERATOR_GOAL:
      case hexa_msg_OPERATOR_FRAMES:
        if (!TakeMotionCommand(c, operator_reader_.info(k).publication_handle)) return;
        break;
      case hexa_msg_OPERATOR_STREAM:
        if (!stream_receiver_) {
          AnswerCommand(c.sequence, "stream", CommandAnswer::kRefused,
                        "the motion stream input is off (start hexa_task_space with --stream)");
          return;
        }
        pending_command_ = OperatorCommandKind::kStream;
        break;
      case hexa_msg_OPERATOR_SHUTDOWN:
        AnswerCommand(c.sequence, "shutdown", CommandAnswer::kAccepted, "");
        // A session that a shutdown ends before its trajectory's end did not complete, whether
        // the trajectory ran or had not started (only jogs, goals, a stream or a home ran, or
        // nothing): the same exit as a `stop` before the trajectory's end (docs/exit_codes.md).
        if (options_.exit_when_done && exit_code_ < 0) EndByShutdown();
        runtime_.shutdown().RequestShutdown();
        return;
      case hexa_msg_OPERATOR_ESTOP:
        // The plant latches it in the rig and reports FAULT_ESTOP, on which this holds
        // (docs/faults.md, "Emergency stop"); held already at once, in case that report is late.
        // Also told to the plant as a FaultEvent: its own command reader may not have matched
        // the operator's writer in time (the operator waits for this reader only).
        system_fault_ = FaultReason::kEstop;
        {
          char detail[64];
          std::snprintf(detail, sizeof detail, "e-stop: operator command #%u", static_cast<unsigned>(c.sequence));
          faults_.Publish(0, last_run_tick_, hexa_msg_FAULT_ESTOP, detail);
        }
        AnswerCommand(c.sequence, "estop", CommandAnswer::kAccepted, "the plant latches the e-stop");
        return;
      default:
        AnswerCommand(c.sequence, CommandName(c.kind), CommandAnswer::kRefused,
                      "unknown command");
        return;
    }
    if (replaced != OperatorCommandKind::kNone) {
      char why[64];
      std::snprintf(why, sizeof why, "replaced by command #%u before it was applied",
                    static_cast<unsigned>(c.sequence));
      AnswerCommand(replaced_sequence, ToString(replaced),
                    CommandAnswer::kRefused, why);
    }
    pending_from_operator_ = true;
    pending_sequence_ = c.sequence;
  });
}

bool SupervisorNode::TakeMotionCommand(const hexa_msg_OperatorCommand& c, dds_instance_handle_t writer) {
  char why[160] = "";
  if (c.kind == hexa_msg_OPERATOR_JOG) {
    JogRequest jog;
    if (!wire::JogFromWire(c, jog, why)) {
      AnswerCommand(c.sequence, "jog", CommandAnswer::kRefused, why);
      return false;
    }
    // A writer's stream of jog messages is answered once, at its first: a new writer (another
    // hexa_operator, the bridge) is told whether its jog was taken, even while another jogs.
    const bool new_writer = writer != jog_writer_;
    if (pending_command_ == OperatorCommandKind::kJog && !new_writer) {
      pending_jog_ = jog;  // the newest twist; the pending one's answer still goes to its sender
      return false;
    }
    if (pending_command_ != OperatorCommandKind::kNone && pending_command_ != OperatorCommandKind::kJog)
      return false;  // that command goes first
    pending_jog_ = jog;
    pending_command_ = OperatorCommandKind::kJog;
    answer_jog_ = new_writer;
    jog_writer_ = writer;
    return true;
  }
  if (c.kind == hexa_msg_OPERATOR_FRAMES) {
    UserFramesConfig frames;
    if (!wire::FramesFromWire(c, frames, why)) {
      AnswerCommand(c.sequence, "frames", CommandAnswer::kRefused, why);
      return false;
    }
    const Eigen::Vector3d& p = frames.p_PC_P_m;
    log_->info("frames #{}: pivot ({:.4f}, {:.4f}, {:.4f}) m in the platform frame", c.sequence,
               p.x(), p.y(), p.z());
    pending_frames_ = frames;
    pending_command_ = OperatorCommandKind::kFrames;
    return true;
  }
  Pose goal;
  if (!wire::GoalFromWire(c, goal, why)) {
    AnswerCommand(c.sequence, "goal", CommandAnswer::kRefused, why);
    return false;
  }
  const Vector6d q = VectorFromPose(goal);
  log_->info("goal #{}: ({:.4f}, {:.4f}, {:.4f}) m, ({:.4f}, {:.4f}, {:.4f}) rad", c.sequence,
             q[0], q[1], q[2], q[3], q[4], q[5]);
  pending_goal_ = goal;
  pending_command_ = OperatorCommandKind::kGoal;
  return true;
}

void SupervisorNode::FinishCommand(SupervisorState before, std::uint64_t tick, double time_s) {
  const OperatorCommandKind cmd = pending_command_;
  pending_command_ = OperatorCommandKind::kNone;
  const CommandResult result = output_.command_result;
  const bool accepted = result == CommandResult::kAccepted;
  if (cmd == OperatorCommandKind::kJog && accepted) last_jog_time_s_ = time_s;
  if (cmd == OperatorCommandKind::kJog && accepted && before == SupervisorState::kJogging &&
      !answer_jog_) {
    pending_from_operator_ = false;  // the jog goes on: nothing to answer
    return;
  }
  log_->info("command {}: {}", ToString(cmd), ToString(result));
  if (accepted && cmd == OperatorCommandKind::kJog)
    log_->info("jogging from t = {:.3f} s ({} frame)", time_s, ToString(pending_jog_.frame));
  if (accepted && cmd == OperatorCommandKind::kStream)
    log_->info("streaming from t = {:.3f} s: UDP {}:{}, neutral pose ({:.4f}, {:.4f}, {:.4f}) m, "
               "({:.4f}, {:.4f}, {:.4f}) rad", time_s, options_.stream_endpoint.address,
               stream_receiver_->port(), supervisor_.rest_xyz_rpy()[0], supervisor_.rest_xyz_rpy()[1],
               supervisor_.rest_xyz_rpy()[2], supervisor_.rest_xyz_rpy()[3],
               supervisor_.rest_xyz_rpy()[4], supervisor_.rest_xyz_rpy()[5]);
  if (accepted && cmd == OperatorCommandKind::kGoal)
    log_->info("goal started at t = {:.3f} s: {:.3f} s to reach it", time_s,
               supervisor_.operator_motion().goal_duration_s());
  if (accepted && cmd == OperatorCommandKind::kFrames) LogFrames(time_s);
  if (accepted && cmd == OperatorCommandKind::kStart) {
    trajectory_started_ = true;
    homing_ = false;
  }
  if (accepted && cmd == OperatorCommandKind::kHome) homing_ = true;  // not the trajectory
  if (accepted && cmd == OperatorCommandKind::kStop && !homing_ &&
      (before == SupervisorState::kBlending || before == SupervisorState::kTracking)) {
    stopped_by_operator_ = true;
    stopped_at_trajectory_s_ = output_.trajectory_time_s;
    log_->warn("stopped by the operator at t = {:.3f} s (trajectory time {:.3f} s)", time_s,
               output_.trajectory_time_s);
  }
  if (accepted && cmd == OperatorCommandKind::kReset && before == SupervisorState::kHold) {
    hold_exit_tick_ = 0;
    if (!options_.hold_report_path.empty()) std::remove(options_.hold_report_path.c_str());
    // Resume: with --autostart the trajectory starts again from where the platform was held;
    // without, the operator's next start does. Either way the session has not finished.
    const bool restart = options_.exit_when_done && options_.autostart;
    if (restart) autostart_pending_ = true;
    left_idle_ = false;
    log_->warn("reset by the operator at t = {:.3f} s (tick {}): HOLD left{}", time_s, tick,
               restart ? "; the trajectory starts again from the held pose" : "");
  }
  if (!pending_from_operator_) return;
  pending_from_operator_ = false;
  char why[160] = "";
  if (result == CommandResult::kRefused && output_.command_detail[0] != '\0')
    std::snprintf(why, sizeof why, "%s", output_.command_detail.data());
  else if (result == CommandResult::kRefused)
    WhyRefused(cmd, before, supervisor_.initialized(), why);
  if (result == CommandResult::kRejected)
    std::snprintf(why, sizeof why, "%s", output_.fault_detail.data());
  const CommandAnswer answer = accepted                               ? CommandAnswer::kAccepted
                               : result == CommandResult::kRejected ? CommandAnswer::kRejected
                                                                      : CommandAnswer::kRefused;
  AnswerCommand(pending_sequence_, ToString(cmd), answer, why);
}

void SupervisorNode::LogFrames(double time_s) {
  const UserFramesConfig& f = supervisor_.operator_motion().config().frames;
  const Eigen::Vector3d& c = f.p_PC_P_m;
  const Eigen::Vector3d& t = f.X_PT.p_BP_B_m;
  const Eigen::Vector3d& w = f.X_BW.p_BP_B_m;
  // Degrees to the log's 0.01: no "-0.00" for an angle of -1e-17 rad.
  const auto degrees = [](const Eigen::Matrix3d& R) {
    Eigen::Vector3d deg = RollPitchYawFromRotation(R) * (180.0 / M_PI);
    for (int k = 0; k < 3; ++k) deg[k] = std::abs(deg[k]) < 0.005 ? 0.0 : deg[k];
    return deg;
  };
  const Eigen::Vector3d t_rpy = degrees(f.X_PT.R_BP);
  const Eigen::Vector3d w_rpy = degrees(f.X_BW.R_BP);
  log_->info("frames set at t = {:.3f} s: pivot ({:.4f}, {:.4f}, {:.4f}) m in the platform frame; "
             "tool ({:.4f}, {:.4f}, {:.4f}) m, ({:.2f}, {:.2f}, {:.2f}) deg in the platform frame; "
             "work ({:.4f}, {:.4f}, {:.4f}) m, ({:.2f}, {:.2f}, {:.2f}) deg in the base frame",
             time_s, c.x(), c.y(), c.z(), t.x(), t.y(), t.z(), t_rpy.x(), t_rpy.y(), t_rpy.z(),
             w.x(), w.y(), w.z(), w_rpy.x(), w_rpy.y(), w_rpy.z());
}

}  // namespace hexa::task_space

namespace hexa::task_space {

bool SupervisorNode::ActivationAllows() {
  const OperatorCommandKind cmd = pending_command_;
  const bool asks_activation = cmd == OperatorCommandKind::kStart || cmd == OperatorCommandKind::kHome;
  const bool moves = asks_activation || cmd == OperatorCommandKind::kJog ||
                     cmd == OperatorCommandKind::kGoal || cmd == OperatorCommandKind::kStream;
  if (!moves) return true;  // stop, reset: never wait
  plant_status_.Poll();
  const std::string detail = plant_status_.DetailOf("plant");
  const services::HardwareStatus status = services::ParseHardwareStatus(detail);
  if (status != services::HardwareStatus::kUnknown) hardware_active_ = status == services::HardwareStatus::kActive;
  auto refuse = [&](const std::string& why) {
    if (pending_from_operator_) AnswerCommand(pending_sequence_, ToString(cmd), CommandAnswer::kRefused, why.c_str());
    pending_command_ = OperatorCommandKind::kNone;
    pending_start_.reset();
    pending_from_operator_ = false;
    activation_deadline_ns_ = 0;
    return false;
  };
  if (!asks_activation) {
    if (hardware_active_) return true;
    return refuse("hardware inactive: an operator start or home activates it (--activation operator)");
  }
  // The plant answers the activation the same command asked of it.
  const CommandAnswer plant = pending_from_operator_ ? ParseCommandAnswer(detail, pending_sequence_)
                                                     : CommandAnswer::kNone;
  if (plant == CommandAnswer::kAccepted) {
    activation_deadline_ns_ = 0;
    hardware_active_ = true;
    return true;
  }
  if (plant != CommandAnswer::kNone) {
    std::string why = services::CommandAnswerReason(detail);
    const std::string inactive = "hardware inactive: ";
    if (why.rfind(inactive, 0) == 0) why.erase(0, inactive.size());
    return refuse("hardware not activated: " + why);
  }
  const std::int64_t now = node::MonotonicNow_ns();
  if (activation_deadline_ns_ == 0) {
    activation_deadline_ns_ = now + static_cast<std::int64_t>(options_.activation_answer_wait_s * 1e9);
    log_->info("command #{} {}: waiting for the plant's answer to the activation", pending_sequence_, ToString(cmd));
  } else if (now > activation_deadline_ns_) {
    return refuse(fmt::format("the plant did not answer the activation within {:.1f} s (its status: '{}')",
                              options_.activation_answer_wait_s, detail));
  }
  return false;
}

}  // namespace hexa::task_space
