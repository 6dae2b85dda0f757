// The plant node's loops: one tick is read (the commands) -> arbitrate -> step the device ->
// write (the next tick's sensors). Lockstep on the receive thread, real time on the main
// thread (the threading rule: plant_node.hpp).
#include "plant_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "hexa/services/command_answer.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::plant_sim {
namespace {

constexpr dds_attach_t kTokenWake = 2;  // services::Runtime::kShutdownToken is 1
// Real time: wake-ups later than this restart the schedule (RealtimeClock). Every slip is
// logged with its tick and kept for the summary: a lapse's tick can be matched to the stall.
constexpr std::int64_t kSlipAfter_ns = 2'000'000;

PlatformPlantConfig MakePlantConfig(const PlantNodeOptions& o, const config::SystemConfig& c) {
  PlatformPlantConfig p;
  p.rig = c.rig;
  p.disturbance = c.profiles.at(o.profile);
  p.seed = o.seed;
  p.tracker.enabled = o.tracker;
  p.free_fall = o.free_fall;
  p.faults = o.plant_faults;
  return p;
}

// The rig behind the seam. The board's calibration is the rig file's `board` block.
std::unique_ptr<device::Device> MakeDevice(const PlantNodeOptions& o, const config::SystemConfig& c) {
  if (o.device == DeviceKind::kSim) return std::make_unique<device::SimDevice>(MakePlantConfig(o, c), kTickS);
  if (!c.board) {
    throw std::invalid_argument(o.common.rig_path + ": no `board` block: --device board needs the board's "
                                "calibration (docs/board_protocol.md, \"Calibration\")");
  }
  device::RemoteBoardDeviceConfig b;
  b.board_host = o.board.host;
  b.board_port = o.board.port;
  b.local_host = "0.0.0.0";
  b.calibration = *c.board;
  b.valve_null_v = c.rig.valve.null_voltage_v;
  return std::make_unique<device::RemoteBoardDevice>(b);  // validates: names the field
}

ArbitrationParams MakeArbitrationParams(const PlantNodeOptions& o, const config::SystemConfig& c) {
  ArbitrationParams p;
  p.realtime = o.common.mode == node::TimeMode::kRealtime;
  p.hygiene = CommandHygieneParams::FromValve(c.rig.valve, p.realtime ? o.realtime_stale_ticks : 0);
  if (p.realtime) p.hygiene.startup_grace_ticks = o.startup_grace_ticks;
  p.compute_budget = o.compute_budget;
  p.expected_legs = o.expected_legs;
  p.lapse_confirm_ticks = std::max<std::int64_t>(1, std::llround(o.common.realtime_lease_s / kTickS));
  return p;
}

DeviceLinkParams LinkParams(const PlantNodeOptions& o) {
  DeviceLinkParams p;
  p.lockstep = o.common.mode == node::TimeMode::kLockstep;
  p.answer_timeout_s = o.board.answer_timeout_s;
  p.lost_after_ticks = o.board.lost_after_ticks;
  p.address = o.board.host + ":" + std::to_string(o.board.port);
  return p;
}

// The activation's checks use the leg controllers' own input ranges (the rig's nominal legs).
HardwareLifecycleConfig LifecycleConfig(const PlantNodeOptions& o, const config::SystemConfig& c) {
  return HardwareLifecycleConfig::FromLegController(
      LegControllerConfig::FromRig(c.rig, c.leg_controller, LegControllerKind::kBsSmc),
      o.expected_legs);
}

LockstepClockParams ClockParams(const PlantNodeOptions& o) {
  LockstepClockParams p;
  p.barrier.reask_after_ns = static_cast<std::int64_t>(o.resend_after_s * 1e9);
  p.barrier.timeout_ns = static_cast<std::int64_t>(o.common.lockstep_timeout_s * 1e9);
  p.sync_every_ticks = o.expect_recorder ? o.recorder_sync_ticks : 0;
  p.sync_window_ticks = o.recorder_sync_window_ticks;
  return p;
}

// The valve readers keep 64 samples per leg: with SHARED ownership a standby's samples (and
// a foreign writer's) share leg N's instance with the primary's, and a keep-last-1 history
// would let one displace the other before the plant takes it.
comm::QosParams ValveReaderQos(const node::CommonOptions& o) {
  comm::QosParams q = node::QosFor(o, comm::TopicKind::kValveCommand);
  q.control_reader_depth = 64;
  return q;
}

std::string LegList(LegMask mask) {
  std::string text;
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
    if (mask & LegBit(leg)) text += " leg" + std::to_string(leg);
  return text;
}

}  // namespace

PlantNode::PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
                     std::shared_ptr<spdlog::logger> log)
    : options_(options),
      config_(config),
      log_(std::move(log)),
      device_owner_(MakeDevice(options, config)),
      device_(*device_owner_),
      board_(dynamic_cast<device::RemoteBoardDevice*>(device_owner_.get())),
      arbitration_params_(MakeArbitrationParams(options, config)),
      // The six legs' samples of a tick leave in one datagram per reader (comm/writer.hpp).
      runtime_(options.common, "plant", log_, comm::WriteBatching::kOn),
      wake_(runtime_.participant()),
      sensors_topic_(runtime_.participant()),
      imu_topic_(runtime_.participant()),
      truth_topic_(runtime_.participant()),
      valve_topic_(runtime_.participant()),
      sensors_writer_(runtime_.participant(), sensors_topic_,
                      node::QosFor(options.common, comm::TopicKind::kLegSensors)),
      imu_writer_(runtime_.participant(), imu_topic_, node::QosFor(options.common, comm::TopicKind::kImuSample)),
      truth_writer_(runtime_.participant(), truth_topic_,
                    node::QosFor(options.common, comm::TopicKind::kGroundTruth)),
      tracker_topic_(runtime_.participant()),
      tracker_writer_(runtime_.participant(), tracker_topic_,
                      node::QosFor(options.common, comm::TopicKind::kTrackerPose)),
      valve_readers_(runtime_.participant(), valve_topic_, comm::EndpointRole::kControlReader,
                     ValveReaderQos(options.common), 64),
      faults_(runtime_.participant(), "plant"),
      peers_(runtime_.participant()),
      fault_topic_(runtime_.participant()),
      fault_reader_(runtime_.participant(), fault_topic_, comm::EndpointRole::kControlReader,
                    node::QosFor(options.common, comm::TopicKind::kFaultEvent), 64),
      operator_topic_(runtime_.participant()),
      operator_reader_(runtime_.participant(), operator_topic_, comm::EndpointRole::kControlReader,
                       [&] {
                         comm::QosParams q = node::QosFor(options.common, comm::TopicKind::kOperatorCommand);
                         q.user_data = services::kPlantCommandReader;  // hexa_operator waits for it
                         return q;
                       }(),
                       16),
      arbitration_(arbitration_params_),
      lockstep_(ClockParams(options)),
      realtime_(1'000'000, kSlipAfter_ns),
      link_(device_, board_, LinkParams(options), &node::MonotonicNow_ns),
      lifecycle_(LifecycleConfig(options, config)) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    leg_name_[i] = "leg" + std::to_string(i + 1);
    standby_name_[i] = leg_name_[i] + "_standby";
  }
  BringUpDevice();  // throws naming the cause (address, port, e-stop)
  cycle_.Bind<&PlantNode::OnCommands>(*this);
  runtime_.waitset().Attach(wake_.get(), kTokenWake);
  for (auto& age : truth_sample_.command_age_ticks) age = -1;
  // The loop may run recorder_sync_window_ticks (+ one sync period) ahead of the recorder;
  // the writers must still hold those samples, with margin.
  const auto depth = static_cast<std::uint64_t>(
      std::min({comm::WriterHistoryDepth(comm::TopicKind::kLegSensors),
                comm::WriterHistoryDepth(comm::TopicKind::kGroundTruth),
                comm::WriterHistoryDepth(comm::TopicKind::kValveCommand),
                schedule_.supervisor_every_ticks *
                    comm::WriterHistoryDepth(comm::TopicKind::kLegSetpoint)}));
  if (2 * (options_.recorder_sync_window_ticks + options_.recorder_sync_ticks) > depth)
    throw std::invalid_argument("recorder_sync_window_ticks " +
                                std::to_string(options_.recorder_sync_window_ticks) +
                                " + recorder_sync_ticks " +
                                std::to_string(options_.recorder_sync_ticks) +
                                ": more than half the writers' history of " +
                                std::to_string(depth) + " ticks");
}

bool PlantNode::CompleteTick(const ArbitrationInput& in) {
  TakeOperatorCommands();  // an e-stop acts on this tick's write
  UpdateHardware();  // the lifecycle: do the commands apply at this tick?
  arbitration_.Update(in, arbitration_out_);  // arbitrate
  relayed_ = relay_.For(tick_, arbitration_out_.forced);  // with the next tick's samples
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const std::int64_t age = arbitration_out_.command_age_ticks[i];
    figures_.command_age[i].Add(age);
    // Like applied_valve_v, the ages in a tick's ground truth are those of the step that led
    // to its state.
    truth_sample_.command_age_ticks[i] = static_cast<int32_t>(std::clamp<std::int64_t>(age, -1, INT32_MAX));
  }
  Report(arbitration_out_.events);
  const device::DeviceStatus status = ExchangeWithDevice(arbitration_out_.valve_v);  // step, read
  if (status == device::DeviceStatus::kFault) {
    faults_.Publish(0, tick_, hexa_msg_FAULT_STATE_NOT_FINITE, "plant state not finite: stopped");
    log_->error("plant state became non-finite at tick {}: stopping", tick_);
    LogLastGoodState();
    runtime_.Publish(hexa_msg_NODE_FAULT, Figures(), "state not finite");
    return false;
  }
  ++tick_;
  JudgeDeviceSafety();  // the e-stop as the sample of tick_ shows it
  events_.Clear();
  arbitration_.EndTick(tick_, events_);
  if (tick_ % 100 == 0) {
    runtime_.Publish(hexa_msg_NODE_RUNNING, Figures(), StatusDetail());
  }
  Report(events_);  // a fault episode in effect, repeated at the status rate
  return true;
}

void PlantNode::OnCommands() {
  TakeCommands(true);
  AdvanceIfComplete();
}

void PlantNode::AdvanceIfComplete() {
  // Lockstep: every awaited leg answered tick_ -> step, publish tick_ + 1 and await it. While
  // a recorder sync is pending, tick_ is not published yet and the barrier still holds the
  // previous (complete) tick: nothing may advance.
  while (lockstep_.ReadyToStep()) {
    const std::int64_t now = node::MonotonicNow_ns();
    cycle_times_.Add(static_cast<double>(now - tick_started_ns_) * 1e-9);
    figures_.tick_wall.Add(now - tick_started_ns_);
    ArbitrationInput in;
    in.tick = tick_;
    if (!CompleteTick(in)) {
      exit_code_ = exit_code::kPlantNonFinite;
    } else if (tick_ >= lockstep_.last_tick()) {
      exit_code_ = exit_code::kOk;
    }
    if (exit_code_ >= 0) {
      lockstep_.Stop();
      wake_.Set();
      return;
    }
    switch (lockstep_.AfterTick(tick_, now)) {
      case LockstepClock::Flow::kStart: break;
      case LockstepClock::Flow::kStartAndWake: wake_.Set(); break;  // an acknowledgement wait
      case LockstepClock::Flow::kBlocked: wake_.Set(); return;  // the main thread publishes tick_
    }
    StartTick(now);
  }
}

void PlantNode::StartTick(std::int64_t now_ns) {
  tick_started_ns_ = now_ns;
  PublishTick();
  lockstep_.Begin(tick_, static_cast<LegMask>(FirstLegs(options_.expected_legs) & ~arbitration_.dropped()),
                  now_ns);
  TakeCommands(true);  // answers that came in with this callback's data
}

void PlantNode::WatchSilence(dds_duration_t& wait) {
  TakeFaultEvents();
  ReportGoneWriters();
  const std::int64_t now = node::MonotonicNow_ns();
  JudgeSilentLegs(now);
  if (exit_code_ >= 0) return;
  const LockstepClock::Silence silence = lockstep_.CheckSilence(now);
  switch (silence.action) {
    case LockstepBarrier::Action::kWait:
      wait = std::clamp<dds_duration_t>(silence.next_check_ns - now, DDS_MSECS(1), DDS_MSECS(10));
      break;
    case LockstepBarrier::Action::kReask:
      // A sample can be lost to a reader that had not yet matched this writer, or to an
      // ownership hand-over (hot standby): ask the silent legs again for this tick. Leg
      // controllers answer a repeated tick with their cached command.
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
        if (silence.legs & LegBit(leg)) {
          PublishTick(leg);
          ++figures_.resent_samples;
        }
      if (silence.reask_supervisor) ReaskSupervisor();
      break;
    case LockstepBarrier::Action::kTimeout: {
      std::string states;
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
        if (silence.legs & LegBit(leg))
          states += "; " + runtime_.peer_processes().Describe(leg_name_[static_cast<std::size_t>(leg - 1)]);
      if (options_.expect_supervisor) states += "; " + runtime_.peer_processes().Describe("supervisor");
      log_->error("lockstep: tick {} not answered within {} s (the last resort) by:{}{}", tick_,
                  options_.common.lockstep_timeout_s, LegList(silence.legs), states);
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
        if (!(silence.legs & LegBit(leg))) continue;
        char detail[160];
        std::snprintf(detail, sizeof detail, "lockstep: no command for tick %llu within %.1f s",
                      static_cast<unsigned long long>(tick_), options_.common.lockstep_timeout_s);
        faults_.Publish(static_cast<uint8_t>(leg), tick_,
                        hexa_msg_FAULT_COMMAND_DEADLINE_MISSED, detail);
      }
      exit_code_ = exit_code::kPlantLockstepStall;
      lockstep_.Stop();
      break;
    }
  }
}

void PlantNode::ServeRecorderSync(bool acked) {
  // The acknowledgement wait has ended or a 10 ms slice of it has passed: resume the loop if
  // it stood still for it, or give the sync up when a reader will never acknowledge.
  const std::int64_t now = node::MonotonicNow_ns();
  const std::int64_t blocked_ns = lockstep_.blocked_ns(now);
  const bool give_up = !acked && lockstep_.sync_pending() && SyncGiveUpDue(blocked_ns);
  const LockstepClock::AckOutcome o = lockstep_.AckWaitEnded(acked, give_up, tick_, now);
  if (o.acknowledged_again) log_->info("tick {}: recorder sync acknowledged again", tick_);
  if (o.given_up) {
    // A reader does not acknowledge (a dead supervisor or recorder, until discovery drops
    // it): the control loop must not stand still for it.
    log_->warn("tick {}: a reliable reader has not acknowledged for {:.1f} s ({}; {}): "
               "recorder sync given up, the loop runs on (counted, logged per episode)",
               tick_, static_cast<double>(blocked_ns) * 1e-9,
               runtime_.peer_processes().Describe("recorder"), runtime_.peer_processes().Describe("supervisor"));
  }
  if (o.resume && lockstep_.running()) {
    StartTick(now);
    AdvanceIfComplete();
  }
}

int PlantNode::RunLockstep(std::uint64_t last_tick) {
  {
    std::lock_guard<std::mutex> lock(cycle_.mutex());
    lockstep_.Run(last_tick);
    // The callback first, then tick 0: an answer can never arrive unseen.
    cycle_.TriggerOn(valve_readers_);
    StartTick(node::MonotonicNow_ns());
    AdvanceIfComplete();
  }
  // The receive thread runs the loop; this thread watches for silence and shutdown, and
  // keeps the loop within the recorder's window. Every 10 ms at most it judges the legs the
  // tick still awaits (a dead one is no longer awaited: the detection bound is the liveliness
  // lease + 10 ms, docs/faults.md), takes the supervisor's sensor faults and reports writers
  // that are gone.
  while (!runtime_.shutdown_requested()) {
    dds_duration_t wait = DDS_MSECS(10);
    bool waiting_for_acks = false;
    {
      std::lock_guard<std::mutex> lock(cycle_.mutex());
      if (exit_code_ >= 0) break;
      if (lockstep_.TakeAckWaitRequest()) wake_.Set(false);
      waiting_for_acks = lockstep_.ack_wait_active();
    }
    // Everything written so far is in every reliable reader's history (the recorder's too):
    // from then on no sample of it can be lost by a keep-last writer history. The loop writes
    // on meanwhile (Cyclone's writers are thread-safe). Measured: while the loop writes at
    // full speed the acknowledgements do not come (a wait ends ~17 ms after the loop stopped
    // at the window: about two heartbeat intervals, deploy/cyclonedds-loopback.xml). Only the
    // all-legs partition (supervisor, recorder) and the ground truth: a leg controller's lost
    // sample is repaired by the re-ask, and a hung controller never acknowledges. Waited in
    // 10 ms slices, between which this thread watches the legs as when it is idle.
    const bool acked = waiting_for_acks &&
                       sensors_writer_.all().WaitForAcks(DDS_MSECS(10)) == DDS_RETCODE_OK &&
                       truth_writer_.WaitForAcks(DDS_MSECS(10)) == DDS_RETCODE_OK;
    {
      std::lock_guard<std::mutex> lock(cycle_.mutex());
      // systemd's watchdog: this thread holds the loop's lock, so the receive thread is not
      // stuck in a tick (a stuck tick keeps the lock and the pings stop).
      node::service_manager::Watchdog();
      if (exit_code_ >= 0) break;
      if (waiting_for_acks) ServeRecorderSync(acked);
      if (options_.expect_supervisor && lockstep_.running()) {
        // The supervisor ends the session (trajectory done, or after holding): no more ticks
        // (the legs wait for setpoints that will not come; that is no fault), until stopped.
        peers_.Poll();
        if (peers_.StateOf("supervisor") == hexa_msg_NODE_STOPPING) {
          lockstep_.Stop();
          log_->info("the supervisor ended its run at tick {}: no more ticks", tick_);
        }
      }
      if (!lockstep_.running()) {
        wait = DDS_MSECS(100);  // the run has ended: wait to be stopped
      } else {
        WatchSilence(wait);
        if (exit_code_ >= 0) break;
      }
    }
    if (!waiting_for_acks) runtime_.waitset().Wait(wait);
  }
  {
    std::lock_guard<std::mutex> lock(cycle_.mutex());
    lockstep_.Stop();
  }
  // No callback runs after this (it touches members destroyed before the reader).
  cycle_.StopTriggers();
  return exit_code_ >= 0 ? exit_code_ : exit_code::kOk;
}

int PlantNode::RunRealtime(std::uint64_t last_tick) {
  realtime_.Start();
  // No data callback in real time: this thread alone touches the loop state. The lock is
  // held for form (uncontended) so that the helpers' contract is the same in both modes.
  std::lock_guard<std::mutex> lock(cycle_.mutex());
  while (!runtime_.shutdown_requested() && tick_ < last_tick) {
    node::service_manager::Watchdog();
    PublishTick();                            // write: the sensors of tick_
    realtime_.SleepUntilNext();
    TakeCommands(false);                      // read: the newest commands
    if (tick_ % 10 == 0) TakeFaultEvents();   // the interlock within 10 ms: no take every tick
    ArbitrationInput in;
    in.tick = tick_;
    in.after_slip = tick_ <= slip_recent_until_tick_;
    in.report_gone_writers = tick_ % 100 == 0;
    // A writer that appeared (a restarted controller) is resolved every 100 ticks.
    if (in.report_gone_writers) writers_.Refresh(valve_readers_);
    in.writers = WriterCounts();
    in.writers_valid = true;
    const RealtimeClock::Wake w = realtime_.Measure(tick_);
    cycle_times_.Add(static_cast<double>(w.late_ns) * 1e-9);
    figures_.tick_wall.Add(w.late_ns);
    if (w.slipped) {
      // The schedule restarts from now (RealtimeClock); the controllers on the same host catch
      // up over a few ticks: their answers count as fresh for the stale-command tolerance.
      log_->warn("tick {}: the plant woke {:.1f} ms late: its schedule slips (simulated time "
                 "pauses with the host; slip {})", tick_, w.late_ns * 1e-6, realtime_.slips().count());
      slip_recent_until_tick_ = tick_ + options_.realtime_stale_ticks;
    }
    if (!CompleteTick(in)) return exit_code::kPlantNonFinite;  // arbitrate, step the device
  }
  return exit_code::kOk;
}

}  // namespace hexa::plant_sim
