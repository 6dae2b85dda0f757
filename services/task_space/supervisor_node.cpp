#include "supervisor_node.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "hexa/config/washout_file.hpp"
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

// The operator modes for this rig; the stream's kind and, for vehicle packets, the washout
// parameters from their file (throws with the file's messages).
OperatorMotionConfig OperatorMotionFrom(const SupervisorNodeOptions& o, const config::SystemConfig& c) {
  OperatorMotionConfig m = MakeOperatorMotionConfig(config::MakeSupervisorRig(c), ParamsFrom(o, c));
  m.stream.kind = o.stream_kind;
  if (!o.washout_path.empty()) {
    const config::WashoutFileResult washout = config::LoadWashoutFile(o.washout_path);
    if (!washout.ok) throw std::runtime_error(washout.error);
    m.stream.washout = washout.config;
    m.stream.washout.period_s = m.stream.period_s;  // the supervisor's
  }
  return m;
}

FaultReason FromWire(hexa_msg_FaultReason r) {
  return static_cast<FaultReason>(static_cast<int>(r));
}

}  // namespace

SupervisorNode::SupervisorNode(const SupervisorNodeOptions& options,
                               const config::SystemConfig& config,
                               std::shared_ptr<spdlog::logger> log)
    : options_(options),
      log_(log),
      supervisor_(config::MakeSupervisorRig(config), ParamsFrom(options, config),
                  PotentiometersFrom(config), OperatorMotionFrom(options, config)),
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
      plant_status_(runtime_.participant()),
      done_(runtime_.participant()) {
  runtime_.waitset().Attach(operator_reader_.data_condition(), kTokenOperator);
  runtime_.waitset().Attach(fault_reader_.data_condition(), kTokenFault);
  runtime_.waitset().Attach(done_.get(), kTokenDone);
  leg_fault_.fill(FaultReason::kNone);
  if (options_.stream) {
    // Throws (address, port, reason) when the port cannot be bound: the service does not start.
    stream_receiver_ = std::make_unique<udp::MotionStreamReceiver>(
        options_.stream_endpoint, supervisor_.operator_motion().stream().config().decode);
    const MotionStreamConfig& sc = supervisor_.operator_motion().stream().config();
    log_->warn("motion stream input ENABLED on UDP {}:{} (kind {}{}{}, timeout {:.3f} s): whoever "
               "can send to it moves the platform while STREAMING (hexa_operator stream)",
               options_.stream_endpoint.address, stream_receiver_->port(), ToString(sc.kind),
               sc.kind == StreamKind::kVehicle ? ", washout " : "",
               sc.kind != StreamKind::kVehicle ? ""
               : options_.washout_path.empty() ? "built-in defaults" : options_.washout_path.c_str(),
               sc.timeout_s);
  }
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
  // others move (docs/measurements/deployment_partitions.md, "A primary without setpoints").
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
  // A hold within 2 s of a stall of this process by the host (NoteInputLag): the line says so,
  // since the legs' stale setpoints then come from the host, not from a controller.
  if (host_stall_.at_mono_ns > 0 && node::MonotonicNow_ns() - host_stall_.at_mono_ns < 2'000'000'000) {
    const std::size_t used = std::strlen(line);
    std::snprintf(line + used, sizeof line - used,
                  "; the host stopped the supervisor: the plant's tick %llu reached it %.1f ms old, "
                  "while it ran %.2f ms of CPU in %.1f ms",
                  static_cast<unsigned long long>(host_stall_.tick), host_stall_.lag_s * 1e3,
                  host_stall_.cpu_s * 1e3, host_stall_.wall_s * 1e3);
  }
  log_->error("{}", line);
  std::snprintf(hold_line_, sizeof hold_line_, "%s", line);
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
  const bool command_allowed = !options_.operator_activation || ActivationAllows();
  FillInput(time_s);
  if (!command_allowed) input_.command = OperatorCommandKind::kNone;  // it waits
  const SupervisorState state_before = output_.state;
  supervisor_.Update(input_, output_);
  if (pending_command_ != OperatorCommandKind::kNone && command_allowed)
    FinishCommand(state_before, tick, time_s);
  if (output_.state == SupervisorState::kStreaming || state_before == SupervisorState::kStreaming)
    LogStreamEvents(state_before, time_s);
  if (output_.state == SupervisorState::kIdle && state_before != output_.state)
    LogModeEnd(state_before, time_s);
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
  input_.jog = pending_jog_;
  input_.goal_X_BP = pending_goal_;
  input_.frames = pending_frames_;
  if (stream_receiver_) {
    // Drained every tick (outside STREAMING the core ignores them): no backlog at the start.
    input_.stream_packet_count = stream_receiver_->Receive(stream_decoder_refusals_);
    input_.stream_packets = stream_receiver_->packets();
  }
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
    char line[sizeof end_line_];
    std::snprintf(line, sizeof line, "held, no operator reset within %g s: %s",
                  options_.hold_timeout_s, hold_line_);
    EndSession(exit_code::kSupervisorHeld, line);
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
  // A session ends when its trajectory ends (or a hold, with --exit-when-done); a jog, a goal,
  // a stream or a home ends in IDLE without ending it.
  NoteSessionMotion(time_s);
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

void SupervisorNode::LogStreamCounters(const char* when) {
  const StreamCounters& c = supervisor_.operator_motion().stream().counters();
  const StreamCounters& d = stream_decoder_refusals_;
  const auto n = [](const StreamCounters& k, StreamPacketError e) {
    return k.by_reason[static_cast<std::size_t>(e)];
  };
  log_->info("motion stream {}: applied {}, missing {}, late {}, duplicate {}, wrong kind {}, "
             "timeouts {}; refused by the decoder: wrong size {}, bad magic {}, wrong version {}, "
             "unknown kind {}, not finite {}, absurd value {}; setpoint clamped by the soft "
             "limits on {} ticks", when, c.applied, c.missing, n(c, StreamPacketError::kLate),
             n(c, StreamPacketError::kDuplicate), n(c, StreamPacketError::kWrongKind), c.timeouts,
             n(d, StreamPacketError::kWrongSize), n(d, StreamPacketError::kBadMagic),
             n(d, StreamPacketError::kWrongVersion), n(d, StreamPacketError::kUnknownKind),
             n(d, StreamPacketError::kNotFinite), n(d, StreamPacketError::kAbsurdValue),
             stream_clamped_ticks_);
}

void SupervisorNode::LogStreamEvents(SupervisorState before, double time_s) {
  const OperatorMotionStatus& m = output_.operator_motion;
  if (before != SupervisorState::kStreaming) {
    last_stream_state_ = StreamState::kWaiting;
    stream_clamped_ticks_ = 0;
    return;  // entered (logged with the command's answer) or left (LogModeEnd)
  }
  if (output_.state != SupervisorState::kStreaming) return;
  if (m.limits.result != SoftLimitsResult::kInside) ++stream_clamped_ticks_;
  const StreamState state = m.stream.state;
  if (state == StreamState::kStreaming && last_stream_state_ != StreamState::kStreaming) {
    log_->info("motion stream: packets applied from t = {:.3f} s ({} applied so far)", time_s,
               supervisor_.operator_motion().stream().counters().applied);
  }
  if (m.stream.timed_out) {
    log_->warn("motion stream TIMEOUT at t = {:.3f} s: no packet for {:.3f} s (limit {:.3f} s); "
               "returning to neutral", time_s, m.stream.since_packet_s,
               supervisor_.operator_motion().stream().config().timeout_s);
  }
  if (state == StreamState::kWaiting && last_stream_state_ == StreamState::kReturning)
    log_->info("motion stream: at neutral at t = {:.3f} s, waiting for packets", time_s);
  last_stream_state_ = state;
}

void SupervisorNode::LogModeEnd(SupervisorState before, double time_s) {
  if (before != SupervisorState::kJogging && before != SupervisorState::kGoal &&
      before != SupervisorState::kStreaming)
    return;
  const Vector6d& q = output_.desired_xyz_rpy;
  if (before == SupervisorState::kStreaming) {
    log_->info("stream stopped: at neutral at t = {:.3f} s: ({:.4f}, {:.4f}, {:.4f}) m, ({:.4f}, "
               "{:.4f}, {:.4f}) rad", time_s, q[0], q[1], q[2], q[3], q[4], q[5]);
    LogStreamCounters("so far");
  } else if (before == SupervisorState::kJogging) {
    log_->info("jog at rest at t = {:.3f} s, {:.3f} s after the last jog message (t = {:.3f} s): "
               "({:.4f}, {:.4f}, {:.4f}) m, ({:.4f}, {:.4f}, {:.4f}) rad", time_s,
               time_s - last_jog_time_s_, last_jog_time_s_, q[0], q[1], q[2], q[3], q[4], q[5]);
  } else {
    log_->info("goal motion at rest at t = {:.3f} s: ({:.4f}, {:.4f}, {:.4f}) m, ({:.4f}, {:.4f}, "
               "{:.4f}) rad", time_s, q[0], q[1], q[2], q[3], q[4], q[5]);
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
  if (options_.exit_when_done && exit_code_ < 0 && runtime_.shutdown().signal_number() != 0) {
    std::snprintf(end_line_, sizeof end_line_, "the supervisor was stopped by signal %d (%s) "
                  "before the trajectory's end", runtime_.shutdown().signal_number(),
                  strsignal(runtime_.shutdown().signal_number()));
    log_->warn("{}", end_line_);
  }
  WriteEndReport();
  return exit_code_ < 0 ? exit_code::kOk : exit_code_;
}

}  // namespace hexa::task_space
