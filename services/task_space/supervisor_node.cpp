#include "supervisor_node.hpp"

#include <signal.h>
#include <unistd.h>

#include "hexa/core/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::task_space {
namespace {

// services::Runtime::kShutdownToken (1) is the shutdown guard's.
constexpr dds_attach_t kTokenOperator = 2;
constexpr dds_attach_t kTokenFault = 3;
constexpr dds_attach_t kTokenDone = 4;

// Each leg's potentiometer calibration (rig overlay; identity without one).
LegArray<PotentiometerCalibrationParams> PotentiometersFrom(const config::SystemConfig& c) {
  const ControllerModel model = config::MakeControllerModel(c);
  LegArray<PotentiometerCalibrationParams> p{};
  for (std::size_t i = 0; i < kNumLegs; ++i) p[i] = model.legs[i].potentiometer;
  return p;
}

SupervisorParams ParamsFrom(const SupervisorNodeOptions& o, const config::SystemConfig& c) {
  SupervisorParams p = c.supervisor;
  if (!o.outer_loop) p.outer_loop.enabled = false;
  if (o.least_squares) p.least_squares_estimator = true;
  if (!o.feedforward) p.feedforward_enabled = false;
  return p;
}

FaultReason FromWire(hexa_msg_FaultReason r) {
  return static_cast<FaultReason>(static_cast<int>(r));
}

const char* CommandName(hexa_msg_OperatorCommandKind kind) {
  switch (kind) {
    case hexa_msg_OPERATOR_START: return "start";
    case hexa_msg_OPERATOR_STOP: return "stop";
    case hexa_msg_OPERATOR_RESET: return "reset";
    case hexa_msg_OPERATOR_HOME: return "home";
    case hexa_msg_OPERATOR_SHUTDOWN: return "shutdown";
    case hexa_msg_OPERATOR_ESTOP: return "estop";
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

SupervisorNode::SupervisorNode(const SupervisorNodeOptions& options,
                               const config::SystemConfig& config,
                               std::shared_ptr<spdlog::logger> log)
    : options_(options),
      log_(log),
      supervisor_(config::MakeSupervisorRig(config), ParamsFrom(options, config),
                  PotentiometersFrom(config)),
      // The six legs' samples of a tick leave in one datagram per reader (comm/writer.hpp).
      runtime_(options.common, "supervisor", std::move(log), comm::WriteBatching::kOn),
      sensors_topic_(runtime_.participant()),
      imu_topic_(runtime_.participant()),
      setpoint_topic_(runtime_.participant()),
      pose_topic_(runtime_.participant()),
      operator_topic_(runtime_.participant()),
      fault_topic_(runtime_.participant()),
      sensors_reader_(runtime_.participant(), sensors_topic_, comm::EndpointRole::kControlReader,
                      node::QosFor(options.common, comm::TopicKind::kLegSensors), 64),
      imu_reader_(runtime_.participant(), imu_topic_, comm::EndpointRole::kControlReader,
                  node::QosFor(options.common, comm::TopicKind::kImuSample)),
      operator_reader_(runtime_.participant(), operator_topic_, comm::EndpointRole::kControlReader,
                       [&] {
                         // Named, so that hexa_operator writes once THIS reader has matched.
                         comm::QosParams q = node::QosFor(options.common, comm::TopicKind::kOperatorCommand);
                         q.user_data = comm::kSupervisorCommandReader;
                         return q;
                       }()),
      fault_reader_(runtime_.participant(), fault_topic_, comm::EndpointRole::kControlReader,
                    node::QosFor(options.common, comm::TopicKind::kFaultEvent), 64),
      setpoint_writer_(runtime_.participant(), setpoint_topic_,
                       node::QosFor(options.common, comm::TopicKind::kLegSetpoint)),
      pose_writer_(runtime_.participant(), pose_topic_,
                   node::QosFor(options.common, comm::TopicKind::kPoseReport)),
      faults_(runtime_.participant(), "supervisor"),
      done_(runtime_.participant()) {
  runtime_.waitset().Attach(operator_reader_.data_condition(), kTokenOperator);
  runtime_.waitset().Attach(fault_reader_.data_condition(), kTokenFault);
  runtime_.waitset().Attach(done_.get(), kTokenDone);
  leg_fault_.fill(FaultReason::kNone);
  cycle_.Bind<&SupervisorNode::RunCycle>(*this);
}

services::StatusFigures SupervisorNode::Figures() {
  services::StatusFigures f;
  f.tick = last_run_tick_;
  f.sim_time_s = static_cast<double>(last_run_tick_) * 0.001;
  f.deadline_missed = imu_reader_.Snapshot().requested_deadline_missed_total;
  f.cycles = cycles_;
  f.cycle_median_s = cycle_times_.Median();
  f.cycle_max_s = cycle_times_.Max();
  return f;
}

hexa_msg_NodeState SupervisorNode::RunningState() const {
  return output_.state == SupervisorState::kHold ? hexa_msg_NODE_HOLD : hexa_msg_NODE_RUNNING;
}

bool SupervisorNode::PeersMatched(std::string& missing) {
  const bool sensors = sensors_reader_.Snapshot().subscription_matched_current >= 1;
  const bool imu = imu_reader_.Snapshot().subscription_matched_current >= 1;
  // Every leg's primary controller reads its setpoints (plus the plant in lockstep). Its
  // reader says so in its USER_DATA: a hot standby's reader alone is not enough, since a
  // primary without setpoints holds its leg (and its ownership of the valve) while the
  // others move (docs/measurements/deployment.md, "A primary without setpoints").
  bool legs = true;
  missing_primaries_.clear();
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    if (comm::CountMatchedReadersWithUserData(setpoint_writer_.leg(leg).get(),
                                              comm::LegEndpointUserData(leg, false)) == 0) {
      legs = false;
      missing_primaries_ += (missing_primaries_.empty() ? "" : " ") + std::to_string(leg);
    }
  }
  // With a recorder: it must have matched the pose reports before the first one is written.
  const uint32_t pose_readers = pose_writer_.Snapshot().publication_matched_current;
  const bool poses = pose_readers >= static_cast<uint32_t>(options_.pose_readers);
  if (sensors && imu && legs && poses) return true;
  missing = fmt::format("sensors {}, imu {}, setpoint readers of the legs' primaries {}, pose "
                        "readers {} of {}", sensors, imu,
                        legs ? "all" : "missing for leg(s) " + missing_primaries_, pose_readers,
                        options_.pose_readers);
  return false;
}

void SupervisorNode::TakeSensors() {
  services::TakeValid(sensors_reader_, [&](const hexa_msg_LegSensors& s, std::size_t) {
    if (s.leg_id < 1 || s.leg_id > kNumLegs) return;
    const std::size_t i = s.leg_id - 1;
    sensor_ring_[i][sensor_ring_count_[i]++ % kSensorRing] = s;
    if (sensors_seen_[i] && s.header.tick < sensors_[i].header.tick) return;
    sensors_[i] = s;
    sensors_seen_[i] = true;
  });
}

const hexa_msg_LegSensors* SupervisorNode::RingSample(std::size_t leg_index,
                                                      std::uint64_t tick) const {
  const std::size_t n = std::min(sensor_ring_count_[leg_index], kSensorRing);
  for (std::size_t k = 0; k < n; ++k) {
    const hexa_msg_LegSensors& s = sensor_ring_[leg_index][k];
    if (s.header.tick == tick) return &s;
  }
  return nullptr;
}

bool SupervisorNode::TakeImu(bool& repeated) {
  return services::TakeNewest(imu_reader_, imu_, imu_seen_, repeated);
}

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
    log_->info("operator command #{}: kind {} trajectory '{}'", c.sequence,
               static_cast<int>(c.kind), c.trajectory);
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
      case hexa_msg_OPERATOR_SHUTDOWN:
        AnswerCommand(c.sequence, "shutdown", CommandAnswer::kAccepted, "");
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

void SupervisorNode::TakeFaults() {
  services::TakeValid(fault_reader_, [&](const hexa_msg_FaultEvent& f, std::size_t) {
    if (std::strcmp(f.source_node, "supervisor") == 0) return;  // our own
    log_->warn("fault from {}: leg {} tick {} reason {}: {}", f.source_node, f.leg_id, f.tick,
               ToString(FromWire(f.reason)), f.detail);
    // A refused command changed nothing: the legs follow their own controllers and the
    // supervisor its operator. Reported, not a reason to hold.
    if (f.reason == hexa_msg_FAULT_COMMAND_REFUSED) return;
    if (f.leg_id >= 1 && f.leg_id <= kNumLegs) {
      leg_fault_[f.leg_id - 1] = FromWire(f.reason);
    } else if (f.reason != hexa_msg_FAULT_NONE) {
      system_fault_ = FromWire(f.reason);  // the host or the plant itself
    }
    if (f.reason != hexa_msg_FAULT_NONE) {
      ReportedFault& r = reported_[f.leg_id >= 1 && f.leg_id <= kNumLegs ? f.leg_id - 1 : kNumLegs];
      r.reason = FromWire(f.reason);
      std::snprintf(r.source.data(), r.source.size(), "%s", f.source_node);
      std::snprintf(r.detail.data(), r.detail.size(), "%s", f.detail);
    }
    if (f.reason == hexa_msg_FAULT_IMU_LOST) imu_lost_ = true;
  });
}

void SupervisorNode::FinishCommand(SupervisorState before, std::uint64_t tick, double time_s) {
  const OperatorCommandKind cmd = pending_command_;
  pending_command_ = OperatorCommandKind::kNone;
  const CommandResult result = output_.command_result;
  log_->info("command {}: {}", ToString(cmd), ToString(result));
  const bool accepted = result == CommandResult::kAccepted;
  if (accepted && cmd == OperatorCommandKind::kStop &&
      (before == SupervisorState::kBlending || before == SupervisorState::kTracking)) {
    stopped_by_operator_ = true;
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
  if (result == CommandResult::kRefused) WhyRefused(cmd, before, supervisor_.initialized(), why);
  if (result == CommandResult::kRejected)
    std::snprintf(why, sizeof why, "%s", output_.fault_detail.data());
  const CommandAnswer answer = accepted                               ? CommandAnswer::kAccepted
                               : result == CommandResult::kRejected ? CommandAnswer::kRejected
                                                                      : CommandAnswer::kRefused;
  AnswerCommand(pending_sequence_, ToString(cmd), answer, why);
}

void SupervisorNode::ReportHold(double time_s) {
  // The cause as reported (a leg's or the plant's FaultEvent), else the supervisor's own.
  const int leg = output_.fault_leg;
  const ReportedFault& r = reported_[leg >= 1 && leg <= static_cast<int>(kNumLegs)
                                         ? static_cast<std::size_t>(leg - 1)
                                         : kNumLegs];
  const bool reported = r.reason == output_.fault && r.reason != FaultReason::kNone;
  char line[512];
  std::snprintf(line, sizeof line, "held at t = %.3f s: %s%s%s, %s %s: %s", time_s,
                ToString(output_.fault), leg > 0 ? ", leg " : "",
                leg > 0 ? std::to_string(leg).c_str() : "",
                reported ? "reported by" : "detected by", reported ? r.source.data() : "supervisor",
                reported ? r.detail.data() : output_.fault_detail.data());
  log_->error("{}", line);
  if (options_.hold_report_path.empty()) return;
  const std::string tmp = options_.hold_report_path + ".tmp";
  if (FILE* f = std::fopen(tmp.c_str(), "w")) {
    const bool ok = std::fprintf(f, "%s\n", line) > 0;
    if (std::fclose(f) == 0 && ok) std::rename(tmp.c_str(), options_.hold_report_path.c_str());
  }
}

void SupervisorNode::RunTick(std::uint64_t tick, double time_s) {
  if (options_.crash_at_s >= 0 && time_s >= options_.crash_at_s) {
    log_->warn("FAULT INJECTION: supervisor crash (SIGKILL) at t = {:.3f} s", time_s);
    log_->flush();
    kill(getpid(), SIGKILL);
  }
  // Faults reported by the plant or the legs take effect at the next supervisor tick, not
  // when the main thread next wakes: lockstep runs many ticks per wall millisecond, and a
  // dead leg's fault, published before the plant's next tick, must hold the platform at once
  // (a local take; nothing is sent).
  TakeFaults();
  const int64_t t0 = node::MonotonicNow_ns();
  FillInput(time_s);
  const SupervisorState state_before = output_.state;
  supervisor_.Update(input_, output_);
  if (pending_command_ != OperatorCommandKind::kNone) FinishCommand(state_before, tick, time_s);
  cycle_times_.Add(static_cast<double>(node::MonotonicNow_ns() - t0) * 1e-9);
  ++cycles_;
  ran_once_ = true;
  last_run_tick_ = tick;
  Publish(tick, time_s);
  ReactToOutput(tick, time_s);
}

void SupervisorNode::FillInput(double time_s) {
  input_ = SupervisorInput{};
  input_.time_s = time_s;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    input_.length_m[i] = sensors_seen_[i] ? sensors_[i].length_m : std::nan("");
    // A leg whose sensor sample did not advance since the previous supervisor tick.
    if (ran_once_ && sensors_[i].header.tick <= sensor_tick_at_last_run_[i]) ++leg_misses_consecutive_[i];
    else leg_misses_consecutive_[i] = 0;
    sensor_tick_at_last_run_[i] = sensors_[i].header.tick;
    input_.deadline_misses_consecutive[i] = leg_misses_consecutive_[i];
    input_.leg_fault[i] = leg_fault_[i];
  }
  input_.system_fault = system_fault_;
  input_.imu_deadline_misses_consecutive = imu_misses_consecutive_;
  for (int k = 0; k < 4; ++k) input_.orientation_wxyz[k] = imu_.orientation_wxyz[k];
  // A leg whose controller died is reported by the plant (FaultEvent: its command stops
  // advancing) and held through leg_fault: this service reads no ValveCommand, so that the
  // legs' 1 kHz commands are not sent to one more process (docs/performance.md).
  input_.command = pending_command_;
  input_.start = pending_start_ ? &*pending_start_ : nullptr;
}

void SupervisorNode::ReactToOutput(std::uint64_t tick, double time_s) {
  if (output_.fault_raised) {
    log_->error("HOLD: {} (leg {}): {}", ToString(output_.fault), output_.fault_leg,
                output_.fault_detail.data());
    faults_.Publish(static_cast<uint8_t>(output_.fault_leg), tick,
                    static_cast<hexa_msg_FaultReason>(static_cast<int>(output_.fault)),
                    output_.fault_detail.data());
    runtime_.Publish(hexa_msg_NODE_HOLD, Figures(), output_.fault_detail.data());
    ReportHold(time_s);
    // With --exit-when-done the session waits in HOLD for an operator reset, then ends held.
    if (options_.exit_when_done && hold_exit_tick_ == 0) {
      hold_exit_tick_ = tick + std::max<std::uint64_t>(
                                   1, static_cast<std::uint64_t>(std::llround(options_.hold_timeout_s * 1000.0)));
      log_->warn("waiting up to {} s (simulated) in HOLD for an operator reset (hexa_operator "
                 "--domain {} reset); without one the service leaves held (exit {})",
                 options_.hold_timeout_s, options_.common.domain_id, exit_code::kSupervisorHeld);
    }
  }
  if (hold_exit_tick_ != 0 && tick >= hold_exit_tick_ && exit_code_ < 0) {
    log_->error("no operator reset within {} s in HOLD: leaving held (exit {}): {}",
                options_.hold_timeout_s, exit_code::kSupervisorHeld, output_.fault_detail.data());
    exit_code_ = exit_code::kSupervisorHeld;
  }
  if (!was_initialized_ && supervisor_.initialized()) {
    was_initialized_ = true;
    const Vector6d& rest = supervisor_.rest_xyz_rpy();
    log_->info("pose estimate available at t = {:.3f} s: rest pose ({:.4f}, {:.4f}, {:.4f}) m, "
               "({:.3f}, {:.3f}, {:.3f}) deg", time_s, rest[0], rest[1], rest[2],
               rest[3] * 57.29577951308232, rest[4] * 57.29577951308232, rest[5] * 57.29577951308232);
  } else if (!supervisor_.initialized() && cycles_ % 200 == 1) {
    log_->warn("no valid pose estimate yet ({}): IMU q = ({:.4f} {:.4f} {:.4f} {:.4f}), leg "
               "lengths [{:.4f} {:.4f} {:.4f} {:.4f} {:.4f} {:.4f}] m",
               ToString(output_.estimate.status), input_.orientation_wxyz[0],
               input_.orientation_wxyz[1], input_.orientation_wxyz[2], input_.orientation_wxyz[3],
               input_.length_m[0], input_.length_m[1], input_.length_m[2], input_.length_m[3],
               input_.length_m[4], input_.length_m[5]);
  }
  if (autostart_pending_ && supervisor_.initialized()) {
    autostart_pending_ = false;
    // A rejected trajectory is passed on all the same: the core goes to HOLD with the
    // rejection message at the next tick (and the service exits with --exit-when-done).
    PrepareStart(options_.trajectory, options_.periods);
    pending_from_operator_ = false;
  }
  if (output_.state != SupervisorState::kIdle) left_idle_ = true;
  if (options_.exit_when_done && left_idle_ && output_.state == SupervisorState::kIdle &&
      exit_code_ < 0) {
    if (stopped_by_operator_) {
      log_->warn("motion ended at t = {:.3f} s by the operator's stop, before the trajectory's "
                 "end (exit {})", time_s, exit_code::kStoppedByOperator);
      exit_code_ = exit_code::kStoppedByOperator;
    } else {
      log_->info("trajectory finished at t = {:.3f} s", time_s);
      exit_code_ = exit_code::kOk;
    }
  }
  // The last command's answer is repeated for 1 s (200 cycles), then the state is the detail.
  const bool repeat_answer = last_answer_[0] != '\0' && cycles_ - last_answer_cycle_ <= 200;
  if (cycles_ % 20 == 0)
    runtime_.Publish(RunningState(), Figures(), repeat_answer ? last_answer_ : ToString(output_.state));
}

void SupervisorNode::Publish(std::uint64_t tick, double time_s) {
  const int64_t now_ns = comm::RealtimeNow_ns();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    hexa_msg_LegSetpoint s{};
    s.leg_id = static_cast<uint8_t>(i + 1);
    comm::FillHeader(s.header, tick, time_s, now_ns);
    const SupervisorLegSetpoint& sp = output_.setpoint[i];
    s.length_m = sp.length_m;
    s.velocity_m_s = sp.velocity_m_s;
    s.acceleration_m_s2 = sp.acceleration_m_s2;
    s.correction_m = sp.correction_m;
    s.hold = sp.hold;
    s.feedforward_valid = sp.feedforward_valid;
    s.feedforward_force_n = sp.feedforward_force_n;
    s.feedforward_force_rate_n_s = sp.feedforward_force_rate_n_s;
    setpoint_writer_.WriteDeferred(s, now_ns);
    last_setpoints_[i] = s;
  }
  setpoint_writer_.Flush();
  hexa_msg_PoseReport r{};
  comm::FillHeader(r.header, tick, time_s, now_ns);
  r.state = static_cast<hexa_msg_SupervisorState>(static_cast<int>(output_.state));
  r.trajectory_time_s = output_.trajectory_time_s;
  for (int k = 0; k < 6; ++k) {
    r.desired_pose[k] = output_.desired_xyz_rpy[k];
    r.estimated_pose[k] = output_.estimate.xyz_rpy[k];
    r.error_pose[k] = output_.desired_xyz_rpy[k] - output_.estimate.xyz_rpy[k];
  }
  r.estimator_status = static_cast<uint8_t>(output_.estimate.status);
  r.excluded_leg = static_cast<int8_t>(output_.estimate.excluded_leg);
  pose_writer_.Write(r, now_ns);
}

void SupervisorNode::RepublishSetpoints() {
  const int64_t now_ns = comm::RealtimeNow_ns();
  for (const hexa_msg_LegSetpoint& s : last_setpoints_) setpoint_writer_.WriteDeferred(s, now_ns);
  setpoint_writer_.Flush();
  if (setpoint_republishes_++ == 0)
    log_->info("lockstep re-ask of tick {}: its setpoints published again (logged once)",
               last_run_tick_);
}

bool SupervisorNode::SensorsOfTick(std::uint64_t m) {
  LegArray<const hexa_msg_LegSensors*> at_m{};
  for (std::size_t i = 0; i < kNumLegs; ++i)
    if ((at_m[i] = RingSample(i, m)) == nullptr) return false;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    sensors_[i] = *at_m[i];
    sensors_seen_[i] = true;
  }
  return true;
}

bool SupervisorNode::RunLockstepWithoutImu() {
  // The plant said the IMU delivers nothing: tick m runs on the six legs' samples of m with
  // the last orientation, as an IMU miss (the plant's FAULT_IMU_LOST holds the platform).
  bool ran = false;
  for (;;) {
    const std::uint64_t m = ran_once_ ? last_run_tick_ + static_cast<std::uint64_t>(5) : 0;
    if (!SensorsOfTick(m)) return ran;
    ++imu_misses_consecutive_;
    RunTick(m, sensors_[0].header.sim_time_s);
    ran = true;
    if (exit_code_ >= 0) return ran;
  }
}

void SupervisorNode::RunCycle() {
  if (exit_code_ >= 0) return;
  TakeSensors();
  if (imu_lost_ && options_.common.mode == node::TimeMode::kLockstep) {
    bool ignored = false;
    TakeImu(ignored);  // whatever still comes is stale: ignored
    RunLockstepWithoutImu();
    if (exit_code_ >= 0) done_.Set();
    return;
  }
  bool repeated_imu = false;
  const bool fresh_imu = TakeImu(repeated_imu);
  if (!imu_seen_) return;
  const std::uint64_t m = imu_.header.tick;
  if (options_.common.mode == node::TimeMode::kRealtime) {
    // On each IMU sample, with the newest leg samples.
    if (!fresh_imu) return;
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    imu_misses_consecutive_ = 0;
    RunTick(m, imu_.header.sim_time_s);
  } else {
    // Lockstep: the IMU of tick m and the six legs' samples of tick m.
    // The plant re-asks the tick it last sent when a leg cannot answer the next one (core
    // lockstep_protocol.hpp: that leg may lack this tick's setpoint): publish it again.
    if (ran_once_ && m <= last_run_tick_) {
      if (repeated_imu && m == last_run_tick_) RepublishSetpoints();
      return;
    }
    if (!SensorsOfTick(m)) return;
    RunTick(m, imu_.header.sim_time_s);
  }
  if (exit_code_ >= 0) done_.Set();
}

void SupervisorNode::MainThreadLook() {
  const bool realtime = !runtime_.lockstep();
  TakeOperatorCommands();
  TakeFaults();
  // Lockstep without the IMU: the tick it awaits may already be here (its data callback
  // ran before the plant's FAULT_IMU_LOST arrived).
  if (imu_lost_ && !realtime) RunCycle();
  // Real time: the IMU is due every 5 ms; 10 ms without one counts a miss and the state
  // machine runs on what it has (it holds after the configured count).
  constexpr int64_t kImuDue_ns = 10'000'000;
  if (realtime && ran_once_ && node::MonotonicNow_ns() - last_imu_mono_ns_ > kImuDue_ns) {
    ++imu_misses_consecutive_;
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    // Once the plant reported the IMU lost: on the legs' newest samples, so that time goes
    // on without it (the hold, and the exit 1 s after it, must still come).
    if (imu_lost_ && sensors_seen_[0] && sensors_[0].header.tick > last_run_tick_) {
      RunTick(sensors_[0].header.tick, sensors_[0].header.sim_time_s);
    } else {
      RunTick(last_run_tick_, imu_.header.sim_time_s);
    }
  }
}

void SupervisorNode::LogSummary() {
  log_->info("supervisor stopped after {} cycles (state {}), compute median {:.1f} us max {:.1f} us, "
             "failed writes {}, setpoints re-published {} times (lockstep re-asks), largest "
             "leg-length consistency residual {:.2f} mm (limit {:.1f} mm, docs/faults.md)",
             cycles_, ToString(output_.state), cycle_times_.Median() * 1e6,
             cycle_times_.Max() * 1e6, setpoint_writer_.write_errors_total(),
             setpoint_republishes_, supervisor_.max_consistency_residual_m() * 1e3,
             supervisor_.params().length_consistency_limit_m * 1e3);
}

int SupervisorNode::Run() {
  const bool realtime = !runtime_.lockstep();
  runtime_.Start(Figures(), "waiting for peers");
  services::PeerWait wait;
  wait.rule.timeout_s = options_.startup_timeout_s;
  wait.matched = [this](std::string& missing) { return PeersMatched(missing); };
  wait.processes = {"plant", "leg1", "leg2", "leg3", "leg4", "leg5", "leg6"};
  if (options_.pose_readers > 0) wait.processes.push_back("recorder");
  if (runtime_.WaitForPeers(wait) != services::PeerWaitResult::kMatched)
    return runtime_.FailStart(Figures(), "peers not matched", exit_code::kPeersNotMatched);
  runtime_.Running(Figures(), "idle", "idle");
  autostart_pending_ = options_.autostart;
  log_->info("supervisor running ({}, outer loop {}, feed-forward {}, estimator {})",
             realtime ? "real time" : "lockstep", options_.outer_loop ? "on" : "off",
             supervisor_.params().feedforward_enabled ? "on" : "off",
             options_.least_squares ? "six-leg least squares" : "GQFK (eq 47)");
  {
    std::lock_guard<std::mutex> lock(cycle_.mutex());
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    cycle_.TriggerOn(sensors_reader_);
    cycle_.TriggerOn(imu_reader_);
    cycle_.RunHoldingLock();  // what arrived before the callbacks
  }
  const dds_duration_t wait_timeout = realtime ? DDS_MSECS(10) : DDS_SECS(1);
  while (!runtime_.shutdown_requested()) {
    if (runtime_.waitset().Wait(wait_timeout) < 0) return exit_code::kRunError;
    std::lock_guard<std::mutex> lock(cycle_.mutex());
    node::service_manager::Watchdog();  // the control lock is ours: the cycle is not stuck
    if (exit_code_ >= 0) break;
    MainThreadLook();
    if (exit_code_ >= 0) break;
  }
  cycle_.StopTriggers();
  std::lock_guard<std::mutex> lock(cycle_.mutex());
  // An orderly end, said at once: the legs see their setpoint disposed (not a lapsed lease:
  // a crash never disposes) and the plant sees STOPPING, before this process's teardown,
  // which can take a while (a reliable writer lingers for a reader that does not
  // acknowledge, such as a hung leg's; docs/faults.md).
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    hexa_msg_LegSetpoint key{};
    key.leg_id = static_cast<uint8_t>(i + 1);
    setpoint_writer_.Dispose(key);
  }
  runtime_.Stop(Figures(), "stopped");
  LogSummary();
  return exit_code_ < 0 ? exit_code::kOk : exit_code_;
}

}  // namespace hexa::task_space
