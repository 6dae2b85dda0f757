#include "supervisor_node.hpp"

#include <signal.h>
#include <unistd.h>

#include "hexa/core/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::task_space {
namespace {

constexpr dds_attach_t kTokenShutdown = 1;
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

}  // namespace

SupervisorNode::SupervisorNode(const SupervisorNodeOptions& options,
                               const config::SystemConfig& config,
                               std::shared_ptr<spdlog::logger> log)
    : options_(options),
      log_(std::move(log)),
      supervisor_(config::MakeSupervisorRig(config), ParamsFrom(options, config),
                  PotentiometersFrom(config)),
      // The six legs' samples of a tick leave in one datagram per reader (comm/writer.hpp).
      participant_(static_cast<dds_domainid_t>(options.common.domain_id),
                   comm::WriteBatching::kOn),
      shutdown_(participant_),
      sensors_topic_(participant_),
      imu_topic_(participant_),
      setpoint_topic_(participant_),
      pose_topic_(participant_),
      operator_topic_(participant_),
      fault_topic_(participant_),
      sensors_reader_(participant_, sensors_topic_, comm::EndpointRole::kControlReader,
                      node::QosFor(options.common, comm::TopicKind::kLegSensors), 64),
      imu_reader_(participant_, imu_topic_, comm::EndpointRole::kControlReader,
                  node::QosFor(options.common, comm::TopicKind::kImuSample)),
      operator_reader_(participant_, operator_topic_, comm::EndpointRole::kControlReader,
                       [&] {
                         // Named, so that hexa_operator writes once THIS reader has matched.
                         comm::QosParams q = node::QosFor(options.common, comm::TopicKind::kOperatorCommand);
                         q.user_data = comm::kSupervisorCommandReader;
                         return q;
                       }()),
      fault_reader_(participant_, fault_topic_, comm::EndpointRole::kControlReader,
                    node::QosFor(options.common, comm::TopicKind::kFaultEvent), 64),
      setpoint_writer_(participant_, setpoint_topic_,
                       node::QosFor(options.common, comm::TopicKind::kLegSetpoint)),
      pose_writer_(participant_, pose_topic_,
                   node::QosFor(options.common, comm::TopicKind::kPoseReport)),
      status_(participant_, "supervisor"),
      faults_(participant_, "supervisor"),
      done_(participant_),
      waitset_(participant_) {
  waitset_.Attach(shutdown_.guard_condition(), kTokenShutdown);
  waitset_.Attach(operator_reader_.data_condition(), kTokenOperator);
  waitset_.Attach(fault_reader_.data_condition(), kTokenFault);
  waitset_.Attach(done_.get(), kTokenDone);
  leg_fault_.fill(FaultReason::kNone);
}

void SupervisorNode::PublishStatus(hexa_msg_NodeState state, const char* detail) {
  const auto imu = imu_reader_.Snapshot();
  status_.Publish(state, last_run_tick_, static_cast<double>(last_run_tick_) * 0.001,
                  imu.requested_deadline_missed_total, 0,
                  cycles_, cycle_times_.Median(), cycle_times_.Max(), detail);
}

bool SupervisorNode::WaitUntilMatched() {
  const int64_t end = node::MonotonicNow_ns() + static_cast<int64_t>(options_.startup_timeout_s * 1e9);
  while (!shutdown_.requested()) {
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
    if (node::MonotonicNow_ns() > end) {
      log_->error("peers not matched after {} s: sensors {}, imu {}, setpoint readers of the "
                  "legs' primaries {}, pose readers {} of {}",
                  options_.startup_timeout_s, sensors, imu,
                  legs ? "all" : "missing for leg(s) " + missing_primaries_, pose_readers,
                  options_.pose_readers);
      return false;
    }
    waitset_.Wait(DDS_MSECS(20));  // match counts change without data: bounded re-check
  }
  return false;
}

void SupervisorNode::TakeSensors() {
  while (sensors_reader_.Take() > 0) {
    for (std::size_t k = 0; k < sensors_reader_.count(); ++k) {
      if (!sensors_reader_.info(k).valid_data) continue;
      const auto& s = sensors_reader_.sample(k);
      if (s.leg_id < 1 || s.leg_id > kNumLegs) continue;
      const std::size_t i = s.leg_id - 1;
      sensor_ring_[i][sensor_ring_count_[i]++ % kSensorRing] = s;
      if (sensors_seen_[i] && s.header.tick < sensors_[i].header.tick) continue;
      sensors_[i] = s;
      sensors_seen_[i] = true;
    }
  }
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
  bool fresh = false;
  repeated = false;
  while (imu_reader_.Take() > 0) {
    for (std::size_t k = 0; k < imu_reader_.count(); ++k) {
      if (!imu_reader_.info(k).valid_data) continue;
      const auto& s = imu_reader_.sample(k);
      if (imu_seen_ && s.header.tick == imu_.header.tick) repeated = true;
      if (imu_seen_ && s.header.tick <= imu_.header.tick) continue;
      imu_ = s;
      imu_seen_ = true;
      fresh = true;
    }
  }
  return fresh;
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

void SupervisorNode::TakeOperatorCommands() {
  while (operator_reader_.Take() > 0) {
    for (std::size_t k = 0; k < operator_reader_.count(); ++k) {
      if (!operator_reader_.info(k).valid_data) continue;
      const auto& c = operator_reader_.sample(k);
      log_->info("operator command #{}: kind {} trajectory '{}'", c.sequence,
                 static_cast<int>(c.kind), c.trajectory);
      switch (c.kind) {
        case hexa_msg_OPERATOR_START: {
          if (!supervisor_.initialized()) {
            log_->warn("start refused: no pose estimate yet");
            break;
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
        case hexa_msg_OPERATOR_SHUTDOWN: shutdown_.RequestShutdown(); break;
      }
    }
  }
}

void SupervisorNode::TakeFaults() {
  while (fault_reader_.Take() > 0) {
    for (std::size_t k = 0; k < fault_reader_.count(); ++k) {
      if (!fault_reader_.info(k).valid_data) continue;
      const auto& f = fault_reader_.sample(k);
      if (std::strcmp(f.source_node, "supervisor") == 0) continue;  // our own
      log_->warn("fault from {}: leg {} tick {} reason {}: {}", f.source_node, f.leg_id, f.tick,
                 ToString(FromWire(f.reason)), f.detail);
      if (f.leg_id >= 1 && f.leg_id <= kNumLegs) {
        leg_fault_[f.leg_id - 1] = FromWire(f.reason);
      } else if (f.reason != hexa_msg_FAULT_NONE) {
        system_fault_ = FromWire(f.reason);  // the host or the plant itself
      }
      if (f.reason == hexa_msg_FAULT_IMU_LOST) imu_lost_ = true;
    }
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
  supervisor_.Update(input_, output_);
  if (pending_command_ != OperatorCommandKind::kNone) {
    log_->info("command {}: {}", ToString(pending_command_), ToString(output_.command_result));
    pending_command_ = OperatorCommandKind::kNone;
  }
  cycle_times_.Add(static_cast<double>(node::MonotonicNow_ns() - t0) * 1e-9);
  ++cycles_;
  ran_once_ = true;
  last_run_tick_ = tick;
  Publish(tick, time_s);

  if (output_.fault_raised) {
    log_->error("HOLD: {} (leg {}): {}", ToString(output_.fault), output_.fault_leg,
                output_.fault_detail.data());
    faults_.Publish(static_cast<uint8_t>(output_.fault_leg), tick,
                    static_cast<hexa_msg_FaultReason>(static_cast<int>(output_.fault)),
                    output_.fault_detail.data());
    PublishStatus(hexa_msg_NODE_HOLD, output_.fault_detail.data());
    // With --exit-when-done the session ends in HOLD, but only after holding for a while,
    // so that the recording shows what the platform did after the fault.
    if (options_.exit_when_done && hold_exit_tick_ == 0) hold_exit_tick_ = tick + 1000;
  }
  if (hold_exit_tick_ != 0 && tick >= hold_exit_tick_ && exit_code_ < 0) {
    log_->error("leaving after 1 s in HOLD (exit 5): {}", output_.fault_detail.data());
    exit_code_ = 5;
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
  }
  if (output_.state != SupervisorState::kIdle) left_idle_ = true;
  if (options_.exit_when_done && left_idle_ && output_.state == SupervisorState::kIdle &&
      exit_code_ < 0) {
    log_->info("trajectory finished at t = {:.3f} s", time_s);
    exit_code_ = 0;
  }
  if (cycles_ % 20 == 0) PublishStatus(output_.state == SupervisorState::kHold ? hexa_msg_NODE_HOLD
                                                                             : hexa_msg_NODE_RUNNING,
                                       ToString(output_.state));
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

void SupervisorNode::OnData(void* self) {
  auto* node = static_cast<SupervisorNode*>(self);
  std::lock_guard<std::mutex> lock(node->mutex_);
  node->RunCycle();
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

int SupervisorNode::Run() {
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  PublishStatus(hexa_msg_NODE_STARTING, "waiting for peers");
  if (!WaitUntilMatched()) {
    PublishStatus(hexa_msg_NODE_FAULT, "peers not matched");
    return shutdown_.requested() ? 0 : 3;
  }
  PublishStatus(hexa_msg_NODE_RUNNING, "idle");
  node::service_manager::Ready("idle");
  autostart_pending_ = options_.autostart;
  log_->info("supervisor running ({}, outer loop {}, feed-forward {}, estimator {})",
             realtime ? "real time" : "lockstep", options_.outer_loop ? "on" : "off",
             supervisor_.params().feedforward_enabled ? "on" : "off",
             options_.least_squares ? "six-leg least squares" : "GQFK (eq 47)");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    sensors_reader_.OnDataAvailable(&SupervisorNode::OnData, this);
    imu_reader_.OnDataAvailable(&SupervisorNode::OnData, this);
    RunCycle();  // what arrived before the callbacks
  }
  // Real time: the IMU is due every 5 ms; 10 ms without one counts a miss and the state
  // machine runs on what it has (it holds after the configured count).
  const dds_duration_t wait = realtime ? DDS_MSECS(10) : DDS_SECS(1);
  const int64_t imu_due_ns = 10'000'000;
  while (!shutdown_.requested()) {
    const dds_return_t n = waitset_.Wait(wait);
    if (n < 0) return 1;
    std::lock_guard<std::mutex> lock(mutex_);
    node::service_manager::Watchdog();  // the control lock is ours: the cycle is not stuck
    if (exit_code_ >= 0) break;
    TakeOperatorCommands();
    TakeFaults();
    // Lockstep without the IMU: the tick it awaits may already be here (its data callback
    // ran before the plant's FAULT_IMU_LOST arrived).
    if (imu_lost_ && !realtime) RunCycle();
    if (realtime && ran_once_ && node::MonotonicNow_ns() - last_imu_mono_ns_ > imu_due_ns) {
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
    if (exit_code_ >= 0) break;
  }
  sensors_reader_.OnDataAvailable(nullptr, nullptr);
  imu_reader_.OnDataAvailable(nullptr, nullptr);
  std::lock_guard<std::mutex> lock(mutex_);
  // An orderly end, said at once: the legs see their setpoint disposed (not a lapsed lease:
  // a crash never disposes) and the plant sees STOPPING, before this process's teardown,
  // which can take a while (a reliable writer lingers for a reader that does not
  // acknowledge, such as a hung leg's; docs/faults.md).
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    hexa_msg_LegSetpoint key{};
    key.leg_id = static_cast<uint8_t>(i + 1);
    setpoint_writer_.Dispose(key);
  }
  PublishStatus(hexa_msg_NODE_STOPPING, "stopped");
  node::service_manager::Stopping("stopped");
  log_->info("supervisor stopped after {} cycles (state {}), compute median {:.1f} us max {:.1f} us, "
             "failed writes {}, setpoints re-published {} times (lockstep re-asks), largest "
             "leg-length consistency residual {:.2f} mm (limit {:.1f} mm, docs/faults.md)",
             cycles_, ToString(output_.state), cycle_times_.Median() * 1e6,
             cycle_times_.Max() * 1e6, setpoint_writer_.write_errors_total(),
             setpoint_republishes_, supervisor_.max_consistency_residual_m() * 1e3,
             supervisor_.params().length_consistency_limit_m * 1e3);
  return exit_code_ < 0 ? 0 : exit_code_;
}

}  // namespace hexa::task_space
