// What every control service shares: the common command-line options, the QoS parameters
// of each time mode, status and fault publishing, the peer tracker used for start-up
// readiness, and the optional real-time scheduling attempt. Setup code: may allocate and
// throw; the per-cycle calls (Publish*) do not allocate.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "hexa/comm/comm.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/scheduling.hpp"
#include "hexa/services/text.hpp"

namespace hexa::node {

enum class TimeMode { kLockstep, kRealtime };

struct CommonOptions {
  std::string rig_path;
  // --rig-overlay, in order: the controllers' and supervisor's corrections of the rig file
  // (docs/config.md, "Rig overlays"). The plant ignores them (it simulates its truth).
  std::vector<std::string> rig_overlays;
  int domain_id = 0;
  TimeMode mode = TimeMode::kLockstep;
  std::optional<std::string> dds_config;  // --dds-config; else CYCLONEDDS_URI; else loopback
  std::string log_file;
  std::string log_level = "info";
  double lockstep_timeout_s = 10.0;       // a peer silent this long in lockstep is a fault
  // Liveliness lease of the leg controllers' ValveCommand writers (MANUAL_BY_TOPIC, asserted
  // by the control loop; docs/faults.md) in lockstep and in real time; the lockstep one is
  // also the supervisor's setpoint writer's (AUTOMATIC) in both modes.
  double lockstep_lease_s = 0.2;
  double realtime_lease_s = 0.01;
  // Deadline period of the 1 ms topics in real time: the nominal rate is 1 ms, but this
  // VM's scheduling jitter (docs/platform_notes.md) makes a bare 1 ms deadline fire spuriously;
  // the deadline still states the rate and every miss is counted and reported.
  double realtime_deadline_1ms_topics_s = 0.001;
  double realtime_deadline_5ms_topics_s = 0.005;
  bool try_realtime_scheduling = true;
  int realtime_priority = 0;   // --rt-priority: SCHED_FIFO priority; 0 = the service's default
  // --cpu-latency-us: the CPU wake-up latency limit held while the loop runs, both modes (PM
  // QoS, sched::CpuLatencyHold); -1 = none (leave the machine's setting).
  int cpu_latency_us = 0;
  // --rt-dds-event-thread: Cyclone's timed-event thread ("tev") at normal scheduling (true) or
  // at the process's SCHED_FIFO like every other thread (false).
  bool realtime_dds_event_thread_normal = true;
  std::vector<int> cpus;       // --cpus: CPU affinity of every thread; empty = any CPU
  // --peer-pid NAME=PID (repeatable): the session's other processes on this host, as the
  // launcher started them (peer_processes.hpp): a peer that ended is dead at once.
  std::vector<std::string> peer_pids;
};

// Adds --rig --rig-overlay --domain --mode --dds-config --log-file --log-level
// --lockstep-timeout --lockstep-lease --rt-lease --rt-deadline-1ms --rt-deadline-5ms
// --no-rt-sched --rt-priority --cpus --peer-pid.
void AddCommonOptions(cli::Parser& parser);
// Reads them back; false with parser.error() set on a bad value.
bool ReadCommonOptions(cli::Parser& parser, CommonOptions& options);

// QoS parameters for a topic in this mode: lockstep readers are reliable and the deadline
// is the lockstep timeout (a stall detector); real time uses the nominal rates.
comm::QosParams QosFor(const CommonOptions& options, comm::TopicKind kind);

// Loads and validates the rig file; logs and returns nullopt on error (message names
// file, line, field, value and limit).
std::optional<config::SystemConfig> LoadConfig(const std::string& path, spdlog::logger& log);
// The rig file and the --rig-overlay files (applied in order, validated like the rig file).
std::optional<config::SystemConfig> LoadConfig(const CommonOptions& options, spdlog::logger& log);

// Scheduling of a service, applied before its DDS participant exists so that Cyclone's
// threads inherit it: CPU affinity (--cpus) in both modes; in real time SCHED_FIFO at
// --rt-priority (else `default_priority`) + mlockall unless --no-rt-sched, and then:
// - Cyclone's timed-event thread ("tev": deadline timers, heartbeats, acknacks, discovery)
//   at normal scheduling unless --rt-dds-event-thread fifo. Every endpoint with a 1 ms
//   deadline arms a timer that fires each millisecond on that thread; at SCHED_FIFO those
//   wake-ups (7-8 a tick in the plant) run at the loop's priority on the control CPU, ahead
//   of the control threads (docs/performance.md). Liveliness (leases) is on another thread.
// In both modes: the CPU wake-up latency limit (--cpu-latency-us, default 0) held until
// LeaveRealtimeScheduling.
// Logs what it did; a refusal (not root, CPU not present, no access to the PM QoS device)
// is logged and the service carries on. Returns the latency hold (empty if none).
[[nodiscard]] sched::CpuLatencyHold ApplyScheduling(const CommonOptions& options,
                                                    int default_priority, spdlog::logger& log);

// After a service's loop has ended, before its DDS entities are deleted: every thread back to
// normal scheduling (sched::LeaveRealtime) if ApplyScheduling made it SCHED_FIFO, so that the
// teardown does not starve the control processes still running on the same CPU; drops the
// CPU wake-up latency hold.
void LeaveRealtimeScheduling(const CommonOptions& options, sched::CpuLatencyHold& latency_hold,
                             spdlog::logger& log);

// NodeStatus writer for one node name.
class StatusPublisher {
 public:
  StatusPublisher(const comm::Participant& participant, const std::string& node_name);
  // `detail` is truncated to the wire size.
  void Publish(hexa_msg_NodeState state, std::uint64_t tick, double sim_time_s,
               std::uint32_t deadline_missed, std::uint32_t liveliness_changes,
               std::uint64_t cycles, double cycle_median_s, double cycle_max_s,
               const char* detail);
  comm::Writer<hexa_msg_NodeStatus>& writer() { return writer_; }

 private:
  comm::Topic<hexa_msg_NodeStatus> topic_;
  comm::Writer<hexa_msg_NodeStatus> writer_;
  hexa_msg_NodeStatus sample_{};
};

// FaultEvent writer.
class FaultPublisher {
 public:
  FaultPublisher(const comm::Participant& participant, const std::string& node_name);
  void Publish(std::uint8_t leg_id, std::uint64_t tick, hexa_msg_FaultReason reason,
               const char* detail);

 private:
  comm::Topic<hexa_msg_FaultEvent> topic_;
  comm::Writer<hexa_msg_FaultEvent> writer_;
  hexa_msg_FaultEvent sample_{};
};

// Tracks the NodeStatus of other nodes (transient-local: late joiners see the last one).
class PeerTracker {
 public:
  explicit PeerTracker(const comm::Participant& participant);
  // Takes new NodeStatus samples; call from the service loop or while waiting at start-up.
  void Poll();
  // State of a node by name; nullopt if never seen.
  std::optional<hexa_msg_NodeState> StateOf(const std::string& name) const;
  // The detail of the node's newest status ("" if never seen).
  std::string DetailOf(const std::string& name) const;
  // Names from `expected` that are not RUNNING (empty = all ready).
  std::vector<std::string> NotRunning(const std::vector<std::string>& expected) const;
  dds_entity_t data_condition() const { return reader_.data_condition(); }

 private:
  comm::Topic<hexa_msg_NodeStatus> topic_;
  comm::Reader<hexa_msg_NodeStatus> reader_;
  struct Peer {
    std::string name;
    hexa_msg_NodeState state;
    std::string detail;
  };
  std::vector<Peer> states_;
};

// Fixed-size window of cycle times with allocation-free median / max.
class CycleTimeWindow {
 public:
  void Add(double seconds);
  double Median();  // of the samples in the window
  double Max() const;
  std::uint64_t total() const { return total_; }

 private:
  static constexpr std::size_t kSize = 1000;
  std::array<double, kSize> samples_{};
  std::array<double, kSize> scratch_{};
  std::size_t count_ = 0;
  std::size_t next_ = 0;
  std::uint64_t total_ = 0;
};

// CLOCK_MONOTONIC in ns, for measuring compute time (never to decide what to compute).
std::int64_t MonotonicNow_ns();

// Copies free text into a bounded char array of the wire types: valid UTF-8, no control
// characters, cut at a character boundary with text::kCutMarker, always NUL-terminated.
template <std::size_t N>
void CopyBounded(char (&dst)[N], const char* src) {
  text::SanitizeInto(src == nullptr ? std::string_view() : std::string_view(src), dst);
}

}  // namespace hexa::node
