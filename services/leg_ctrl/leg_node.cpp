#include "leg_node.hpp"

#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::leg_ctrl {
namespace {

comm::QosParams ValveQos(const LegNodeOptions& o, const comm::ParticipantPrefix& participant_prefix) {
  comm::QosParams q = node::QosFor(o.common, comm::TopicKind::kValveCommand);
  q.ownership_strength = o.standby ? comm::kStandbyOwnershipStrength
                                   : comm::kPrimaryOwnershipStrength;
  // Which leg this writer drives, for the plant's per-leg liveliness (docs/faults.md).
  // Signed with the session key: the plant counts this writer as the leg's before it has
  // written anything, and a copy of the text in another process does not pass (command_auth.hpp).
  q.user_data = comm::SignEndpointClaim(comm::InstalledCommandMac(), participant_prefix,
                                        comm::LegEndpointUserData(o.leg, o.standby));
  return q;
}

comm::QosParams ControlReaderQos(const LegNodeOptions& o, comm::TopicKind kind) {
  comm::QosParams q = node::QosFor(o.common, kind);
  // The setpoint reader says whose it is: the supervisor waits for every leg's primary.
  if (kind == comm::TopicKind::kLegSetpoint) q.user_data = comm::LegEndpointUserData(o.leg, o.standby);
  if (o.common.mode == node::TimeMode::kLockstep) {
    q.control_reader_depth = static_cast<int32_t>(kLockstepQueue);
  }
  return q;
}

hexa_msg_LegCtrlStatus ToWire(LegControlStatus s) {
  return static_cast<hexa_msg_LegCtrlStatus>(static_cast<int>(s));
}

void SleepFor(double seconds) {
  timespec ts{static_cast<time_t>(seconds), static_cast<long>(std::fmod(seconds, 1.0) * 1e9)};
  nanosleep(&ts, nullptr);
}

}  // namespace

bool ParseFaultKind(const std::string& text, FaultKind& kind) {
  static const std::pair<const char*, FaultKind> kKinds[] = {
      {"none", FaultKind::kNone},       {"crash", FaultKind::kCrash},
      {"hang", FaultKind::kHang},       {"slow", FaultKind::kSlow},
      {"garbage", FaultKind::kGarbage}, {"silence", FaultKind::kSilence}};
  for (const auto& [name, k] : kKinds) {
    if (text == name) {
      kind = k;
      return true;
    }
  }
  return false;
}

const char* ToString(FaultKind kind) {
  switch (kind) {
    case FaultKind::kNone: return "none";
    case FaultKind::kCrash: return "crash";
    case FaultKind::kHang: return "hang";
    case FaultKind::kSlow: return "slow";
    case FaultKind::kGarbage: return "garbage";
    case FaultKind::kSilence: return "silence";
  }
  return "?";
}

LegNode::LegNode(const LegNodeOptions& options, const config::SystemConfig& config,
                 std::shared_ptr<spdlog::logger> log)
    : options_(options),
      log_(log),
      runtime_(options.common, NodeName(options), std::move(log)),
      controller_([&] {
        config::SystemConfig system = config;
        if (options.coupled_legs) system.leg_controller.coupled.enabled = true;
        LegControllerConfig c = config::MakeLegControllerConfig(system, options.leg, options.controller);
        c.excitation = options.excitation;
        return c;
      }()),
      sensors_topic_(runtime_.participant()),
      setpoint_topic_(runtime_.participant()),
      valve_topic_(runtime_.participant()),
      // This leg's partition only: the writers route each leg's samples to its controllers
      // (comm::LegRoutedWriter), nothing of the other legs arrives here.
      sensors_reader_(runtime_.participant(), sensors_topic_, comm::EndpointRole::kControlReader,
                      ControlReaderQos(options, comm::TopicKind::kLegSensors), kLockstepQueue,
                      {comm::LegPartition(options.leg)}),
      setpoint_reader_(runtime_.participant(), setpoint_topic_, comm::EndpointRole::kControlReader,
                       ControlReaderQos(options, comm::TopicKind::kLegSetpoint), kSetpointRing,
                       {comm::LegPartition(options.leg)}),
      // Leg N's partition: DDS Security grants it to leg N's identities only (docs/security.md).
      valve_writer_(runtime_.participant(), valve_topic_,
                    ValveQos(options, comm::PrefixOfEntity(runtime_.participant().get())),
                    {comm::LegPartition(options.leg)}),
      stuck_status_(runtime_.participant(), name_),
      faults_(runtime_.participant(), name_) {
  cycle_.Bind<&LegNode::RunCycle>(*this);
  last_command_.leg_id = static_cast<uint8_t>(options.leg);
  base_controller_ =
      options.controller == LegControllerKind::kPi ? hexa_msg_CONTROLLER_PI : hexa_msg_CONTROLLER_BSSMC;
  last_command_.controller = base_controller_;
  last_command_.standby = options.standby;
  last_command_.friction_scale = 1.0;  // eq 14 nominal until the controller answers
}

services::StatusFigures LegNode::Figures() {
  services::StatusFigures f;
  f.tick = last_command_.header.tick;
  f.sim_time_s = last_command_.header.sim_time_s;
  f.deadline_missed = sensors_reader_.Snapshot().requested_deadline_missed_total;
  f.liveliness_changes = valve_writer_.Snapshot().liveliness_lost_total;
  f.cycles = cycles_;
  f.cycle_median_s = cycle_times_.Median();
  f.cycle_max_s = cycle_times_.Max();
  return f;
}

bool LegNode::PeersMatched(std::string& missing) {
  const bool sensors = sensors_reader_.Snapshot().subscription_matched_current >= 1;
  const uint32_t valve_readers = valve_writer_.Snapshot().publication_matched_current;
  const bool readers = valve_readers >= static_cast<uint32_t>(options_.valve_readers);
  // Lockstep: tick n > 0 cannot be answered without the supervisor's setpoint s(n), and a
  // volatile sample that arrives before this side has matched its writer is dropped (the
  // supervisor only knows that its side matched). So this node reports RUNNING, which the
  // plant waits for before tick 0, only once it knows the setpoint writer. Real time needs
  // no such wait: a lost first setpoint is replaced 5 ms later.
  const bool setpoints = !runtime_.lockstep() ||
                         setpoint_reader_.Snapshot().subscription_matched_current >= 1;
  if (sensors && readers && setpoints) return true;
  missing = fmt::format("sensor writer matched: {}, valve readers matched {} of {} (the plant{}){}",
                        sensors, valve_readers, options_.valve_readers,
                        options_.valve_readers > 1 ? " and the recorder" : "",
                        setpoints ? "" : ", setpoint writer (the supervisor) not matched");
  valve_writer_.AssertLiveliness();  // the lease holds while this node starts
  return false;
}

void LegNode::TakeSetpoints() {
  while (setpoint_reader_.Take() > 0) {
    for (std::size_t k = 0; k < setpoint_reader_.count(); ++k) {
      const dds_sample_info_t& info = setpoint_reader_.info(k);
      if (!info.valid_data) {
        // The supervisor disposed its setpoint: an orderly end of the session (a crashed
        // supervisor never disposes; its lease lapses instead). A dispose carries no tag: it
        // counts only from a writer whose setpoints were authenticated.
        if (info.instance_state == DDS_IST_NOT_ALIVE_DISPOSED && !supervisor_finished_ &&
            trusted_setpoint_writers_.Contains(info.publication_handle)) {
          supervisor_finished_ = true;
          log_->info("{}: the supervisor withdrew its setpoints (orderly end)", name_);
        }
        continue;
      }
      const auto& s = setpoint_reader_.sample(k);
      // Only the session's supervisor sets this leg's course (docs/faults.md, "Foreign
      // commands"): an unauthenticated setpoint is refused and its writer reported.
      const comm::CommandTrust trust = setpoint_reader_.Authenticate(k);
      if (!comm::Trusted(trust)) {
        refusals_.Refuse(setpoint_reader_.get(), info, trust, "LegSetpoint",
                         static_cast<std::uint8_t>(options_.leg), last_command_.header.tick, faults_,
                         *log_);
        continue;
      }
      if (s.leg_id != options_.leg) continue;
      trusted_setpoint_writers_.Note(info.publication_handle, trust);
      IssuedSetpoint issued;
      issued.tick = s.header.tick;
      issued.time_s = s.header.sim_time_s;
      issued.value.length_m = s.length_m;
      issued.value.velocity_m_s = s.velocity_m_s;
      issued.value.acceleration_m_s2 = s.acceleration_m_s2;
      issued.value.correction_m = s.correction_m;
      issued.value.hold = s.hold;
      issued.value.feedforward_valid = s.feedforward_valid;
      issued.value.feedforward_force_n = s.feedforward_force_n;
      issued.value.feedforward_force_rate_n_s = s.feedforward_force_rate_n_s;
      setpoints_.Add(issued);  // an older or repeated one is ignored
    }
  }
}

bool LegNode::SupervisorGoneNow() const {
  // Its writer left without disposing its setpoints (a supervisor ending the session disposes
  // them first), or the process the launcher started for it ended. A lapsed lease is not
  // enough: a supervisor that is stopped or not scheduled lets it lapse too, and lockstep
  // waits for it (docs/faults.md). Only writers whose setpoints were authenticated count: a
  // foreign LegSetpoint writer in this leg's partition keeps no supervisor "present".
  if (options_.common.mode != node::TimeMode::kLockstep || !supervisor_seen_ || supervisor_finished_)
    return false;
  if (trusted_setpoint_writers_.Present(setpoint_reader_.status()) == 0) return true;
  return runtime_.peer_processes().State("supervisor") == node::PeerProcessState::kEnded;
}

const IssuedSetpoint* LegNode::SetpointFor(std::uint64_t tick) const {
  // Lockstep: the protocol's setpoint for this tick (core/lockstep_protocol.hpp). Real time,
  // and lockstep once the supervisor is gone: the newest setpoint not from the future (it
  // goes stale and the controller holds).
  if (options_.common.mode == node::TimeMode::kLockstep && !SupervisorLost())
    return setpoints_.ForTick(tick, schedule_.supervisor_every_ticks);
  return setpoints_.NewestNotAfter(tick);
}

bool LegNode::CanAnswer(std::uint64_t tick) const {
  if (options_.common.mode == node::TimeMode::kRealtime) return true;
  return setpoints_.CanAnswer(tick, schedule_.supervisor_every_ticks) || SupervisorLost();
}

void LegNode::ReportControlFault(const hexa_msg_LegSensors& s) {
  // Held control is a fault once it persists: bad input for 3 ticks (a dead or implausible
  // sensor, supply pressure low), a stale setpoint for 50 (the supervisor has not answered
  // for 50 ms beyond the setpoint timeout: gone or stalled). The valve is at null from the
  // first held tick on (core LegController); this reports it so that the supervisor holds.
  hexa_msg_FaultReason cause = hexa_msg_FAULT_NONE;
  std::uint64_t persist_ticks = 0;
  if (output_.status == LegControlStatus::kHoldBadInput) {
    cause = output_.input_fault == LegInputFault::kSupplyLow ? hexa_msg_FAULT_SUPPLY_PRESSURE_LOW
                                                             : hexa_msg_FAULT_SENSOR_INVALID;
    persist_ticks = 3;
  } else if (output_.status == LegControlStatus::kHoldStaleSetpoint && !supervisor_finished_) {
    cause = hexa_msg_FAULT_SETPOINT_STALE;
    persist_ticks = 50;
  }
  if (cause == hexa_msg_FAULT_NONE) {
    control_fault_ticks_ = 0;
    if (control_fault_reported_ && ++control_ok_ticks_ >= 100) {
      log_->info("{} tick {}: control valid again after {}", name_, s.header.tick,
                 ToString(output_.status));
      control_fault_reported_ = false;
      control_fault_ = hexa_msg_FAULT_NONE;
    }
    return;
  }
  control_ok_ticks_ = 0;
  if (cause != control_fault_) control_fault_ticks_ = 0;
  control_fault_ = cause;
  ++control_fault_ticks_;
  const bool first = !control_fault_reported_ && control_fault_ticks_ >= persist_ticks;
  const bool reminder = control_fault_reported_ && control_fault_ticks_ % 100 == 0;
  if (!first && !reminder) return;
  char detail[160];
  if (cause == hexa_msg_FAULT_SETPOINT_STALE) {
    std::snprintf(detail, sizeof detail, "setpoint of tick %llu is %.3f s old%s: valve held at null",
                  static_cast<unsigned long long>(output_.setpoint_tick), output_.input_fault_value,
                  SupervisorLost() ? " (the supervisor is gone)" : "");
  } else {
    std::snprintf(detail, sizeof detail, "%s reads %.6g (held %llu ticks): valve held at null",
                  ToString(output_.input_fault), output_.input_fault_value,
                  static_cast<unsigned long long>(control_fault_ticks_));
  }
  faults_.Publish(static_cast<uint8_t>(options_.leg), s.header.tick, cause, detail);
  if (first) log_->warn("{} tick {}: {}", name_, s.header.tick, detail);
  control_fault_reported_ = true;
}

bool LegNode::InjectFault(double sim_time_s) {
  if (options_.fault.kind == FaultKind::kNone || sim_time_s < options_.fault.at_sim_time_s)
    return false;
  if (!fault_active_) {
    fault_active_ = true;
    log_->warn("FAULT INJECTION: '{}' from t = {:.3f} s", ToString(options_.fault.kind), sim_time_s);
  }
  switch (options_.fault.kind) {
    case FaultKind::kCrash:
      log_->flush();
      kill(getpid(), SIGKILL);  // a sudden death, no clean-up
      return true;
    case FaultKind::kHang:
      // The control thread stops; only a shutdown request (or SIGKILL) ends it.
      while (!runtime_.shutdown_requested()) SleepFor(0.05);
      return true;
    case FaultKind::kSlow:
      SleepFor(options_.fault.slow_extra_s);
      return false;  // still answers, late
    case FaultKind::kGarbage:
    case FaultKind::kSilence:
    case FaultKind::kNone:
      return false;
  }
  return false;
}

void LegNode::Answer(const hexa_msg_LegSensors& s) {
  const int64_t t0 = node::MonotonicNow_ns();
  if (InjectFault(s.header.sim_time_s)) return;
  input_ = LegControllerInput{};  // nothing carries over from the previous tick
  input_.tick = s.header.tick;
  input_.time_s = s.header.sim_time_s;
  input_.length_m = s.length_m;
  input_.cap_pressure_pa = s.cap_pressure_pa;
  input_.rod_pressure_pa = s.rod_pressure_pa;
  input_.supply_pressure_pa = s.supply_pressure_pa;
  input_.relayed.present = s.relayed_present;
  input_.relayed.tick = s.relayed_tick;
  for (std::size_t j = 0; j < kNumLegs; ++j)
    input_.relayed.parts[j] = FeedbackPart{s.relayed_valid[j], s.relayed_force_n[j], s.relayed_rate_n_s[j]};
  SetSetpointInput(SetpointFor(s.header.tick), input_);
  controller_.Update(input_, output_);
  const double compute_s = static_cast<double>(node::MonotonicNow_ns() - t0) * 1e-9;
  cycle_times_.Add(compute_s);
  ++cycles_;

  hexa_msg_ValveCommand& c = last_command_;
  comm::FillHeader(c.header, s.header.tick, s.header.sim_time_s, 0);
  c.valve_v = output_.valve_v;
  c.status = ToWire(output_.status);
  c.setpoint_tick = output_.setpoint_tick;
  c.desired_length_m = output_.desired_length_m;
  c.sliding_surface_m_s = output_.sliding_surface_m_s;
  c.friction_scale = output_.friction_scale;
  c.compute_time_s = compute_s;
  c.feedback_valid = output_.feedback.valid;
  c.feedback_force_n = output_.feedback.force_n;
  c.feedback_rate_n_s = output_.feedback.rate_n_s;
  c.coupled = output_.coupled;
  // Open loop (identification excitation): no position controller chose this voltage.
  c.controller = output_.open_loop ? hexa_msg_CONTROLLER_NONE : base_controller_;
  if (fault_active_ && options_.fault.kind == FaultKind::kGarbage) {
    c.valve_v = (cycles_ % 2 == 0) ? std::numeric_limits<double>::quiet_NaN() : 42.0;
  }
  answered_any_ = true;
  unwritten_answer_ = true;  // until it is published: the liveliness rule (Run)
  ReportControlFault(s);
  if (fault_active_ && options_.fault.kind == FaultKind::kSilence) return;
  valve_writer_.WriteNow(c);
  unwritten_answer_ = false;
  last_write_ns_.store(node::MonotonicNow_ns(), std::memory_order_relaxed);
}

void LegNode::ResendLastAnswer() {
  // The plant asked again for a tick already answered (lost sample or ownership hand-over):
  // repeat the cached answer, the controller state must not advance twice.
  if (!(fault_active_ && options_.fault.kind == FaultKind::kSilence)) {
    valve_writer_.WriteNow(last_command_);
    last_write_ns_.store(node::MonotonicNow_ns(), std::memory_order_relaxed);
    ++resent_;
  }
}

void LegNode::AnswerAndReport(const hexa_msg_LegSensors& s) {
  Answer(s);
  if (cycles_ % 100 == 0) runtime_.Publish(hexa_msg_NODE_RUNNING, Figures(), ToString(output_.status));
}

void LegNode::TakeSensorsRealtime() {
  // Only the newest sample matters: an older tick is already too late to act on.
  hexa_msg_LegSensors s{};
  if (sensors_reader_.TakeLatestForLeg(static_cast<uint8_t>(options_.leg), s) == 1) {
    if (answered_any_ && s.header.tick == last_command_.header.tick) {
      ResendLastAnswer();
    } else if (!answered_any_ || s.header.tick > last_command_.header.tick) {
      pending_ = s;
      has_pending_ = true;
    }
  }
  if (has_pending_ && CanAnswer(pending_.header.tick)) {
    has_pending_ = false;
    AnswerAndReport(pending_);
  }
}

void LegNode::TakeSensorsLockstep() {
  // Every tick, in order: a primary gets one at a time (the plant waits for it); a hot
  // standby may be several behind and must still compute every tick, so that its state is
  // the primary's when it takes over (bit-identical hand-over).
  services::TakeValid(sensors_reader_, [this](const hexa_msg_LegSensors& s, std::size_t) {
    if (s.leg_id != options_.leg) return;
    const std::uint64_t tick = s.header.tick;
    const std::uint64_t newest_queued = queue_.empty() ? 0 : queue_.back().header.tick;
    if (answered_any_ && queue_.empty() && tick == last_command_.header.tick) {
      ResendLastAnswer();  // the plant's re-ask
      return;
    }
    if ((answered_any_ && tick <= last_command_.header.tick) ||
        (!queue_.empty() && tick <= newest_queued)) {
      if (!queue_.empty() && tick == queue_.front().header.tick && waiting_logged_tick_ != tick) {
        // The plant re-asks the tick this node cannot answer yet: say once per tick what it
        // waits for and what its setpoint reader has seen (the evidence of a lost setpoint).
        waiting_logged_tick_ = tick;
        LogWaitingForSetpoint(tick);
      }
      return;  // a repeat of a queued tick (a re-ask while this node lags): ignored
    }
    // A tick that never arrived (more than the reader's depth behind, the sample was
    // overwritten): this node's state no longer follows the primary's. Say so once.
    const std::uint64_t expected = !queue_.empty() ? newest_queued + 1
                                   : answered_any_ ? last_command_.header.tick + 1 : 0;
    if (tick > expected) {
      if (ticks_missed_ == 0)
        log_->warn("{} missed ticks {}..{} (more than {} behind the plant): its state no "
                   "longer matches the primary's", name_, expected, tick - 1, kLockstepQueue);
      ticks_missed_ += tick - expected;
    }
    if (queue_.full() && queue_overflows_ == 0) {  // the oldest is lost
      log_->warn("{} is more than {} ticks behind the plant: dropping tick {} (its state "
                 "will no longer match the primary's)",
                 name_, kLockstepQueue, queue_.front().header.tick);
    }
    if (queue_.Push(s)) ++queue_overflows_;
  });
  while (!queue_.empty() && CanAnswer(queue_.front().header.tick)) {
    AnswerAndReport(queue_.Pop());  // the slot is only reused by a later take
  }
}

void LegNode::LogWaitingForSetpoint(std::uint64_t tick) {
  std::uint64_t required = 0;
  if (!RequiredSetpointTick(tick, schedule_.supervisor_every_ticks, required)) return;
  const auto s = setpoint_reader_.Snapshot();
  const IssuedSetpoint* newest = setpoints_.newest();
  log_->warn("{} tick {}: re-asked while waiting for the setpoint of tick {} (newest setpoint "
             "{}); setpoint reader: writers matched {} (alive {}, not alive {}), samples lost {} "
             "rejected {}, refused {}; logged once per tick",
             name_, tick, required, newest != nullptr ? static_cast<long long>(newest->tick) : -1LL,
             s.subscription_matched_current, s.liveliness_alive_count,
             s.liveliness_not_alive_count, s.sample_lost_total, s.sample_rejected_total,
             refusals_.samples());
}

void LegNode::WatchControlCycle() {
  // The same cycle in progress, or the same answer unpublished, at kStuckChecks checks of
  // this thread in a row: the cycle is stuck (hang, silence). Counted in this thread's own
  // checks, so a process that is stopped or not scheduled is never called stuck.
  bool unpublished = false;
  std::uint64_t tick = 0;
  {
    std::unique_lock<std::mutex> lock(cycle_.mutex(), std::try_to_lock);
    if (lock.owns_lock()) {
      unpublished = unwritten_answer_;
      tick = last_command_.header.tick;
    }
  }
  // The cycle's thread: did it wait for a CPU more than it ran since the last check (the
  // machine keeps it off, ControlCycleWatch)?
  bool starved = false;
  std::uint64_t run_ns = 0, wait_ns = 0;
  const int tid = cycle_.thread_id();
  if (tid > 0 && sched::ReadThreadSchedStat(tid, run_ns, wait_ns)) {
    starved = tid == watched_tid_ && wait_ns - watched_wait_ns_ > run_ns - watched_run_ns_;
    watched_tid_ = tid;
    watched_run_ns_ = run_ns;
    watched_wait_ns_ = wait_ns;
  }
  const auto cause = cycle_watch_.Check(cycle_.sequence(), unpublished, tick, starved);
  if (cause == stuck_reported_) return;
  stuck_reported_ = cause;
  char detail[160];
  if (cause == ControlCycleWatch::Cause::kNone) {
    std::snprintf(detail, sizeof detail, "control cycle running again");
    stuck_status_.Publish(hexa_msg_NODE_RUNNING, tick, 0.0, 0, 0, cycles_, 0.0, 0.0, detail);
    log_->info("{}: {}", name_, detail);
    return;
  }
  if (cause == ControlCycleWatch::Cause::kHang) {
    std::snprintf(detail, sizeof detail, "control cycle stuck: the same cycle has run through %d "
                  "checks of the main thread (hang)", kStuckChecks);
  } else {
    std::snprintf(detail, sizeof detail, "control cycle stuck: the answer to tick %llu was "
                  "computed and not published through %d checks (silence)",
                  static_cast<unsigned long long>(tick), kStuckChecks);
  }
  stuck_status_.Publish(hexa_msg_NODE_FAULT, tick, 0.0, 0, 0, cycles_, 0.0, 0.0, detail);
  log_->error("{}: {}", name_, detail);
}

void LegNode::RunCycle() {
  TakeSetpoints();
  if (!supervisor_seen_) supervisor_seen_ = trusted_setpoint_writers_.any();
  if (options_.common.mode == node::TimeMode::kRealtime) {
    TakeSensorsRealtime();
  } else {
    TakeSensorsLockstep();
  }
}

void LegNode::AssertLivelinessIfIdle(std::int64_t idle_ns) {
  if (node::MonotonicNow_ns() - last_write_ns_.load(std::memory_order_relaxed) < idle_ns) return;
  std::unique_lock<std::mutex> lock(cycle_.mutex(), std::try_to_lock);
  if (lock.owns_lock() && !unwritten_answer_) valve_writer_.AssertLiveliness();
}

void LegNode::RunCycleWithoutSupervisor() {
  if (!supervisor_lost_) {
    TakeSetpoints();  // a dispose not taken yet: the supervisor ended the session
    supervisor_lost_ = SupervisorGoneNow();
    if (supervisor_lost_)
      log_->warn("{}: the supervisor is gone ({}): answering every tick with the newest "
                 "setpoint held (tick {}), valve at null once stale", name_,
                 runtime_.peer_processes().State("supervisor") == node::PeerProcessState::kEnded
                     ? "its process ended"
                     : "its setpoint writer left without disposing its setpoints",
                 setpoints_.newest() ? setpoints_.newest()->tick : 0);
  }
  if (supervisor_lost_) cycle_.RunHoldingLock();
}

bool LegNode::MainThreadLook(std::int64_t idle_ns) {
  const dds_return_t n = runtime_.waitset().Wait(static_cast<dds_duration_t>(idle_ns));
  if (n < 0) {
    log_->error("waitset failed: {}", dds_strretcode(n));
    return false;
  }
  if (node::service_manager::WatchdogDue()) {
    // systemd's watchdog, fed only when the control lock is free: a cycle stuck in a
    // callback holds it, and systemd then restarts the process.
    std::unique_lock<std::mutex> lock(cycle_.mutex(), std::try_to_lock);
    if (lock.owns_lock()) node::service_manager::Watchdog();
  }
  if (runtime_.shutdown_requested()) return true;
  if (runtime_.lockstep()) {
    WatchControlCycle();
    if (supervisor_lost_ || SupervisorGoneNow()) {
      // No setpoint will arrive to trigger the cycle: answer the queued ticks from here.
      std::unique_lock<std::mutex> lock(cycle_.mutex(), std::try_to_lock);
      if (lock.owns_lock()) RunCycleWithoutSupervisor();
    }
  }
  AssertLivelinessIfIdle(idle_ns);
  return true;
}

void LegNode::LogSummary() {
  const auto sensors = sensors_reader_.Snapshot();
  log_->info("{} stopped after {} cycles (last tick {}): sensor deadline misses {}, repeated "
             "answers {}, lockstep ticks dropped {} and missed {}, failed writes {}, compute "
             "median {:.1f} us max {:.1f} us",
             name_, cycles_, last_command_.header.tick, sensors.requested_deadline_missed_total,
             resent_, queue_overflows_, ticks_missed_, valve_writer_.Snapshot().write_errors_total,
             cycle_times_.Median() * 1e6, cycle_times_.Max() * 1e6);
}

int LegNode::Run() {
  runtime_.Start(Figures(), "waiting for the plant");
  services::PeerWait wait;
  wait.rule.timeout_s = options_.startup_timeout_s;
  wait.matched = [this](std::string& missing) { return PeersMatched(missing); };
  wait.processes = {"plant"};
  if (runtime_.lockstep()) wait.processes.push_back("supervisor");
  if (runtime_.WaitForPeers(wait) != services::PeerWaitResult::kMatched)
    return runtime_.FailStart(Figures(), "no plant", exit_code::kPeersNotMatched);
  const char* role = options_.standby ? "standby" : "primary";
  runtime_.Running(Figures(), role, role);
  log_->info("{} running: leg {}, {}, {}", name_, options_.leg,
             options_.controller == LegControllerKind::kPi           ? "PI"
             : options_.controller == LegControllerKind::kExcitation ? "excitation + BS-SMC"
                                                                     : "BS-SMC",
             options_.standby ? "hot standby (ownership strength 10)" : "primary (strength 20)");
  // From here the control cycle runs on the receive thread (callbacks first, then whatever
  // arrived before them).
  cycle_.TriggerOn(sensors_reader_);
  cycle_.TriggerOn(setpoint_reader_);
  cycle_.Run();
  // MANUAL_BY_TOPIC liveliness (lease: 10 ms real time, 0.2 s lockstep; node.cpp QosFor) is
  // asserted by every write; while the control path is idle this thread asserts it every
  // quarter lease (real time: 3 ms), but only if it gets the control lock (a control cycle
  // stuck in a callback holds it) and the cycle published every answer it computed (a silent
  // cycle did not): otherwise the lease lapses (docs/faults.md).
  const int64_t idle_ns = runtime_.lockstep()
                              ? static_cast<int64_t>(options_.common.lockstep_lease_s * 0.25e9)
                              : 3'000'000;
  while (!runtime_.shutdown_requested()) {
    if (!MainThreadLook(idle_ns)) return exit_code::kRunError;
  }
  // No callback may run while the counters are read and the node is torn down.
  cycle_.StopTriggers();
  std::lock_guard<std::mutex> lock(cycle_.mutex());
  LogSummary();
  runtime_.Stop(Figures(), "stopped");
  return exit_code::kOk;
}

}  // namespace hexa::leg_ctrl
