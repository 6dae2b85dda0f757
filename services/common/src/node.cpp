#include "hexa/services/node.hpp"

#include <algorithm>
#include <cstdlib>
#include <ctime>
#include <limits>

#include "hexa/services/scheduling.hpp"

namespace hexa::node {

void AddCommonOptions(cli::Parser& p) {
  p.AddOption("rig", "file", "rig file (protobuf text format)", config::DefaultRigFile());
  p.AddRepeatable("rig-overlay", "file",
                  "rig overlay applied on top of the rig file for the controllers and the "
                  "supervisor (identified / calibrated values; docs/config.md)");
  p.AddOption("domain", "id", "DDS domain id", "0");
  p.AddChoice("mode", {"lockstep", "realtime"}, "time base (docs/architecture.md)", "lockstep");
  p.AddOption("dds-config", "file",
              "Cyclone DDS configuration (default: $CYCLONEDDS_URI, else loopback only)");
  p.AddOption("log-file", "file", "also log to this file");
  p.AddChoice("log-level", {"trace", "debug", "info", "warn", "error"}, "log level", "info");
  p.AddOption("lockstep-timeout", "s", "lockstep: a peer silent this long is a fault", "10");
  p.AddOption("lockstep-lease", "s",
              "lockstep: liveliness lease of the leg controllers' valve commands (asserted by "
              "the control loop) and of the supervisor's setpoints: how soon a hot standby "
              "takes over; a lapse alone is no fault in lockstep (docs/faults.md)", "0.2");
  p.AddOption("rt-lease", "s",
              "real time: liveliness lease of the leg controllers' valve commands", "0.01");
  p.AddOption("rt-deadline-1ms", "s", "real time: deadline of the 1 ms topics", "0.001");
  p.AddOption("rt-deadline-5ms", "s", "real time: deadline of the 5 ms topics", "0.005");
  p.AddFlag("no-rt-sched", "do not try SCHED_FIFO / mlockall in real time");
  p.AddOption("rt-priority", "N", "real time: SCHED_FIFO priority 1..98 (default: the service's)");
  p.AddOption("cpu-latency-us", "N|none",
              "hold the kernel's CPU wake-up latency limit (/dev/cpu_dma_latency) at N us while "
              "the loop runs (both modes); 0: idle CPUs poll instead of halting "
              "(docs/performance.md); none: leave the machine's setting", "0");
  p.AddChoice("rt-dds-event-thread", {"normal", "fifo"},
              "real time: scheduling of Cyclone's timed-event thread (deadline timers, "
              "heartbeats): normal keeps its per-millisecond wake-ups off the loop's priority "
              "(docs/performance.md)", "normal");
  p.AddOption("cpus", "list", "pin every thread to these CPUs, e.g. 1 or 0,1 or 0-1");
  p.AddRepeatable("peer-pid", "name=pid",
                  "another process of the session on this host (the launcher gives them): one "
                  "that ended is dead at once (docs/faults.md)");
  p.AddOption("session-key", "file",
              "the session key that authenticates commands (default: $HEXA_SESSION_KEY; "
              "hexa_session and hexa_deploy make it; docs/faults.md, \"Foreign commands\")");
}

bool ReadCommonOptions(cli::Parser& p, CommonOptions& o) {
  o.rig_path = p.Get("rig");
  o.rig_overlays = p.GetAll("rig-overlay");
  const auto domain = p.GetInt("domain", 0, 230);
  const auto timeout = p.GetDouble("lockstep-timeout", 0.1, 3600);
  const auto d1 = p.GetDouble("rt-deadline-1ms", 0.001, 1.0);
  const auto d5 = p.GetDouble("rt-deadline-5ms", 0.005, 1.0);
  const auto lease = p.GetDouble("lockstep-lease", 0.01, 60);
  const auto rt_lease = p.GetDouble("rt-lease", 0.003, 10);
  if (!domain || !timeout || !d1 || !d5 || !lease || !rt_lease) return false;
  o.lockstep_lease_s = *lease;
  o.realtime_lease_s = *rt_lease;
  o.domain_id = static_cast<int>(*domain);
  o.lockstep_timeout_s = *timeout;
  o.realtime_deadline_1ms_topics_s = *d1;
  o.realtime_deadline_5ms_topics_s = *d5;
  o.mode = p.Get("mode") == "realtime" ? TimeMode::kRealtime : TimeMode::kLockstep;
  if (p.Has("dds-config")) o.dds_config = p.Get("dds-config");
  o.log_file = p.Get("log-file");
  if (p.Has("session-key")) o.session_key_path = p.Get("session-key");
  o.log_level = p.Get("log-level");
  o.try_realtime_scheduling = !p.Flag("no-rt-sched");
  o.realtime_dds_event_thread_normal = p.Get("rt-dds-event-thread") == "normal";
  const auto latency = p.GetIntOrWord("cpu-latency-us", "none", -1, 0, sched::kMaxCpuLatencyUs);
  if (!latency) return false;
  o.cpu_latency_us = static_cast<int>(*latency);
  if (p.Has("rt-priority")) {
    const auto prio = p.GetInt("rt-priority", 1, 98);
    if (!prio) return false;
    o.realtime_priority = static_cast<int>(*prio);
  }
  o.peer_pids = p.GetAll("peer-pid");
  if (p.Has("cpus") && !sched::ParseCpuList(p.Get("cpus"), o.cpus)) {
    return p.Fail("--cpus '" + p.Get("cpus") + "': expected CPU numbers such as 1, 0,1 or 0-1");
  }
  return true;
}

sched::CpuLatencyHold ApplyScheduling(const CommonOptions& o, int default_priority,
                                      spdlog::logger& log) {
  std::string message;
  if (!o.cpus.empty()) {
    const bool ok = sched::SetCpuAffinity(o.cpus, message);
    ok ? log.info("{}", message) : log.warn("{}", message);
  }
  if (o.mode == TimeMode::kRealtime && o.try_realtime_scheduling) {
    const bool fifo = sched::SetRealtime(
        o.realtime_priority > 0 ? o.realtime_priority : default_priority, message);
    fifo ? log.info("{}", message) : log.warn("{}", message);
    if (fifo && o.realtime_dds_event_thread_normal) {
      comm::AppendCycloneThreadClass("tev", "timeshare");
      log.info("Cyclone's timed-event thread (tev: deadline timers, heartbeats) at normal "
               "scheduling; every other thread at SCHED_FIFO");
    }
  }
  if (o.cpu_latency_us < 0) return {};
  sched::CpuLatencyHold hold(o.cpu_latency_us, message);
  hold.held() ? log.info("{}", message) : log.warn("{}", message);
  return hold;
}

void LeaveRealtimeScheduling(const CommonOptions& o, sched::CpuLatencyHold& latency_hold,
                             spdlog::logger& log) {
  const bool held = latency_hold.held();
  latency_hold.Release();
  if (held) log.info("CPU wake-up latency limit released");
  if (o.mode != TimeMode::kRealtime || !o.try_realtime_scheduling) return;
  std::string message;
  const bool ok = sched::LeaveRealtime(message);
  ok ? log.info("{}", message) : log.warn("{}", message);
}

comm::QosParams QosFor(const CommonOptions& o, comm::TopicKind kind) {
  comm::QosParams q;
  if (o.mode == TimeMode::kLockstep) {
    q.lockstep = true;
    // Simulated time runs at whatever pace the slowest process allows: the deadline is a
    // stall detector at the lockstep timeout. The leg's liveliness is MANUAL_BY_TOPIC as in
    // real time, with a lease suited to lockstep (0.2 s: a loaded machine's scheduling
    // stalls stay well below it): asserted by every write, and while the leg waits for the
    // plant by its main thread only when it can take the control lock and every answer it
    // computed was published. A crashed, hung or silent controller lets it lapse; the plant
    // stops awaiting it and a hot standby takes the valve over (docs/faults.md).
    if (comm::NominalPeriod_s(kind)) q.deadline_period_s = o.lockstep_timeout_s;
    q.valve_liveliness = comm::LivelinessKind::kManualByTopic;
    q.valve_liveliness_lease_s = o.lockstep_lease_s;
  } else {
    const auto nominal = comm::NominalPeriod_s(kind);
    if (nominal) {
      q.deadline_period_s = *nominal < 0.002 ? o.realtime_deadline_1ms_topics_s
                                             : o.realtime_deadline_5ms_topics_s;
    }
    // MANUAL_BY_TOPIC catches a hung control thread. 10 ms lease: 3 ms gave false drops on
    // this VM, 5-10 ms none (docs/platform_notes.md); a hot standby takes over after about the
    // lease + 0.5 ms, inside the plant's 15-tick command tolerance, so the platform does not
    // notice the hand-over.
    q.valve_liveliness = comm::LivelinessKind::kManualByTopic;
    q.valve_liveliness_lease_s = o.realtime_lease_s;
  }
  // The supervisor's process being gone is seen by the legs within this (docs/faults.md).
  q.setpoint_liveliness_lease_s = o.lockstep_lease_s;
  return q;
}

std::optional<config::SystemConfig> LoadConfig(const std::string& path, spdlog::logger& log) {
  auto result = config::LoadSystemConfig(path);
  if (!result.ok) {
    log.error("rig file rejected:\n{}", result.error);
    return std::nullopt;
  }
  log.info("rig file {} loaded (rig '{}')", path, result.config.rig_name);
  return std::move(result.config);
}

std::optional<config::SystemConfig> LoadConfig(const CommonOptions& options, spdlog::logger& log) {
  if (options.rig_overlays.empty()) return LoadConfig(options.rig_path, log);
  auto result = config::LoadSystemConfig(options.rig_path, options.rig_overlays);
  if (!result.ok) {
    log.error("rig file or rig overlay rejected:\n{}", result.error);
    return std::nullopt;
  }
  log.info("rig file {} loaded (rig '{}')", options.rig_path, result.config.rig_name);
  for (const config::RigOverlay& o : result.config.overlays) {
    std::string legs;
    for (std::size_t i = 0; i < o.leg.size(); ++i)
      if (!o.leg[i].empty()) legs += (legs.empty() ? "" : ",") + std::to_string(i + 1);
    log.info("rig overlay {} applied: legs {}, method '{}', date {}, source '{}'", o.source_path,
             legs.empty() ? "none" : legs, o.provenance.method, o.provenance.date,
             o.provenance.source_recording);
    if (o.platform.mass_kg) log.info("rig overlay {}: platform mass {} kg (payload included)", o.source_path, *o.platform.mass_kg);
  }
  return std::move(result.config);
}

StatusPublisher::StatusPublisher(const comm::Participant& participant,
                                 const std::string& node_name)
    : topic_(participant), writer_(participant, topic_) {
  CopyBounded(sample_.node_name, node_name.c_str());
}

void StatusPublisher::Publish(hexa_msg_NodeState state, std::uint64_t tick, double sim_time_s,
                              std::uint32_t deadline_missed, std::uint32_t liveliness_changes,
                              std::uint64_t cycles, double cycle_median_s, double cycle_max_s,
                              const char* detail) {
  sample_.header.tick = tick;
  sample_.header.sim_time_s = sim_time_s;
  sample_.state = state;
  sample_.deadline_missed_total = deadline_missed;
  sample_.liveliness_changes_total = liveliness_changes;
  sample_.cycles_total = cycles;
  sample_.cycle_time_median_s = cycle_median_s;
  sample_.cycle_time_max_s = cycle_max_s;
  CopyBounded(sample_.detail, detail);
  writer_.WriteNow(sample_);
}

FaultPublisher::FaultPublisher(const comm::Participant& participant,
                               const std::string& node_name)
    : topic_(participant), writer_(participant, topic_) {
  CopyBounded(sample_.source_node, node_name.c_str());
}

void FaultPublisher::Publish(std::uint8_t leg_id, std::uint64_t tick, hexa_msg_FaultReason reason,
                             const char* detail) {
  sample_.leg_id = leg_id;
  sample_.tick = tick;
  sample_.reason = reason;
  CopyBounded(sample_.detail, detail);
  writer_.WriteNow(sample_);
}

PeerTracker::PeerTracker(const comm::Participant& participant)
    : topic_(participant),
      reader_(participant, topic_, comm::EndpointRole::kControlReader, comm::QosParams{}, 64) {}

void PeerTracker::Poll() {
  while (reader_.Take() > 0) {
    for (std::size_t i = 0; i < reader_.count(); ++i) {
      if (!reader_.info(i).valid_data) continue;
      const auto& s = reader_.sample(i);
      const std::string name = s.node_name;
      auto it = std::find_if(states_.begin(), states_.end(),
                             [&](const Peer& e) { return e.name == name; });
      if (it == states_.end()) states_.push_back(Peer{name, s.state, s.detail});
      else {
        it->state = s.state;
        it->detail = s.detail;
      }
    }
  }
}

std::optional<hexa_msg_NodeState> PeerTracker::StateOf(const std::string& name) const {
  for (const Peer& p : states_)
    if (p.name == name) return p.state;
  return std::nullopt;
}

std::string PeerTracker::DetailOf(const std::string& name) const {
  for (const Peer& p : states_)
    if (p.name == name) return p.detail;
  return {};
}

std::vector<std::string> PeerTracker::NotRunning(const std::vector<std::string>& expected) const {
  std::vector<std::string> missing;
  for (const auto& name : expected) {
    const auto s = StateOf(name);
    if (!s || *s != hexa_msg_NODE_RUNNING) missing.push_back(name);
  }
  return missing;
}

void CycleTimeWindow::Add(double seconds) {
  samples_[next_] = seconds;
  next_ = (next_ + 1) % kSize;
  count_ = std::min(count_ + 1, kSize);
  ++total_;
}

double CycleTimeWindow::Median() {
  if (count_ == 0) return 0.0;
  std::copy_n(samples_.begin(), count_, scratch_.begin());
  auto mid = scratch_.begin() + static_cast<std::ptrdiff_t>(count_ / 2);
  std::nth_element(scratch_.begin(), mid, scratch_.begin() + static_cast<std::ptrdiff_t>(count_));
  return *mid;
}

double CycleTimeWindow::Max() const {
  if (count_ == 0) return 0.0;
  return *std::max_element(samples_.begin(), samples_.begin() + static_cast<std::ptrdiff_t>(count_));
}

std::int64_t MonotonicNow_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}


bool InstallSessionKey(const std::string& path_option, spdlog::logger& log) {
  std::string path = path_option;
  const char* from = "--session-key";
  if (path.empty()) {
    const char* env = std::getenv(comm::kSessionKeyEnvironment);
    if (env != nullptr && *env != '\0') path = env;
    from = comm::kSessionKeyEnvironment;
  }
  if (path.empty()) {
    log.warn("no session key (--session-key or ${}): commands are NOT authenticated; any "
             "process on this DDS domain can command this one (docs/faults.md, \"Foreign "
             "commands\")", comm::kSessionKeyEnvironment);
    return true;
  }
  std::string error;
  const auto key = comm::ReadSessionKey(path, error);
  if (!key) {
    log.error("{} ({})", error, from);
    return false;
  }
  comm::InstallSessionKey(*key);
  log.info("commands authenticated with the session key {} ({})", path, from);
  return true;
}

}  // namespace hexa::node
