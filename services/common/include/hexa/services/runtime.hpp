// The runtime every service runs on. A service's `main` parses its options and calls
// RunControlService (or RunService) with a function that builds its node and runs it; the
// node owns one Runtime (its DDS participant, shutdown guard, wait set and lifecycle with its
// NodeStatus) and does only read -> compute -> write.
//
//   main:  parse -> RunControlService: logging, DDS configuration (loopback unless told),
//          session key, rig file + overlays, scheduling (CPUs, SCHED_FIFO, CPU latency)
//          -> build the node, node.Run() -> scheduling back to normal -> exit code
//   node:  Start("waiting for ...") -> WaitForPeers -> Running(...) -> loop -> Stop(...)
//
// Exit codes: hexa/services/exit_code.hpp. Setup code: may allocate and throw; Publish does
// not allocate.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "hexa/comm/comm.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/lifecycle.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/peer_processes.hpp"

namespace hexa::services {

// Prints "error: <the parser's error>\n(see --help)" on stderr (prefixed with the program's
// name when given) and returns exit_code::kUsage: for a value found bad after parsing.
int UsageError(const cli::Parser& parser, const char* program = nullptr);

// How main starts a control service (leg controller, supervisor, plant).
struct ControlService {
  std::string name;              // the logger's and the node's name ("leg3", "supervisor")
  int default_rt_priority = 0;   // SCHED_FIFO priority unless --rt-priority says otherwise
};
using ControlBody =
    std::function<int(const config::SystemConfig& config, std::shared_ptr<spdlog::logger> log)>;

// Logging (--log-file, --log-level), the DDS configuration (--dds-config, else
// $CYCLONEDDS_URI, else loopback only), the session key, the rig file and its overlays, then
// the scheduling (node::ApplyScheduling, before any DDS thread exists so that Cyclone's
// threads inherit it); runs `body` and afterwards leaves real-time scheduling, so that the
// node's teardown does not starve the processes still running. Returns body's exit code, or
// kUsage (bad session key file), kRunError (rig file, or an exception, logged).
int RunControlService(const ControlService& service, const node::CommonOptions& common,
                      const ControlBody& body);

// The same for a process without a rig file or real-time scheduling (the bridge): logging,
// DDS configuration and `body`; an exception is logged and returns kRunError.
using ServiceBody = std::function<int(std::shared_ptr<spdlog::logger> log)>;
int RunService(const std::string& name, const std::string& log_file, const std::string& log_level,
               const std::optional<std::string>& dds_config, const ServiceBody& body);

// Scheduling of a process that must stay out of the control loop's way (the bridge): CPU
// affinity (`cpus`, empty = any) and niceness (0 = normal), for every thread it has and
// creates; logged; a refusal leaves it as it was.
void ApplyBackgroundScheduling(const std::vector<int>& cpus, int nice, spdlog::logger& log);

// What a node waits for at start-up (Runtime::WaitForPeers).
struct PeerWait {
  PeerWaitRule::Params rule;  // timeout_s: the service's --startup-timeout
  // Called at every look (every `recheck_ns` and on data): true once every peer is matched;
  // otherwise `missing` says what is not (for the log). May also do what the node must do
  // while it waits (a leg asserts its writer's liveliness).
  std::function<bool(std::string& missing)> matched;
  // The session's processes this node waits for, as the launcher names them (--peer-pid):
  // the report says of each one given a process id whether it runs, is stopped or ended
  // (the others are on another host, or not started by a launcher: DDS alone speaks of them).
  std::vector<std::string> processes;
  // Whether the wait ends at once (kProcessEnded, logged) when one of `processes` has ended:
  // it will never match (the plant, which a session cannot run without any of its peers).
  bool fail_when_a_process_ends = false;
  std::int64_t recheck_ns = 20'000'000;  // match counts change without data: bounded re-check
};

enum class PeerWaitResult : std::uint8_t { kMatched, kShutdown, kTimedOut, kProcessEnded };

// Whether a node publishes its lifecycle on NodeStatus: the control services do (the plant,
// the launcher and hexa_operator read it); the bridge, which is no part of the control loop,
// walks the same lifecycle without a status.
enum class StatusTopic : std::uint8_t { kPublished, kNone };

// A node's share of the runtime: its participant, the shutdown guard (SIGINT / SIGTERM), a
// wait set with the guard attached (token kShutdownToken), the lifecycle and its NodeStatus.
class Runtime {
 public:
  static constexpr dds_attach_t kShutdownToken = 1;

  Runtime(const node::CommonOptions& common, std::string node_name,
          std::shared_ptr<spdlog::logger> log,
          comm::WriteBatching batching = comm::WriteBatching::kOff,
          StatusTopic status = StatusTopic::kPublished);

  const comm::Participant& participant() const { return participant_; }
  comm::WaitSet& waitset() { return waitset_; }
  comm::ShutdownGuard& shutdown() { return shutdown_; }
  bool shutdown_requested() const { return shutdown_.requested(); }
  const node::CommonOptions& common() const { return common_; }
  bool lockstep() const { return common_.mode == node::TimeMode::kLockstep; }
  const std::string& name() const { return name_; }
  spdlog::logger& log() const { return *log_; }
  const node::PeerProcesses& peer_processes() const { return peer_processes_; }
  Phase phase() const { return phase_; }

  // kStarting: NodeStatus STARTING with `detail` (what the node waits for).
  void Start(const StatusFigures& figures, const char* detail);
  // Waits until `wait.matched` says every peer is matched (kPeersMatched), shutdown is
  // requested or wait.rule.timeout_s passes. After report_after_s (3 s), every second, logs
  // which peer is missing and, for the processes named, why (running, stopped, ended, not
  // known on this host). On a timeout logs "peers not matched after ... s: <missing>".
  PeerWaitResult WaitForPeers(const PeerWait& wait);
  // A node with no peers to wait for (the bridge serves whatever the session publishes):
  // kPeersMatched at once.
  void NoPeersToWaitFor() { Enter(Phase::kPeersMatched); }
  // The start failed (peers not matched, or shutdown while starting; phase kFailed): NodeStatus
  // FAULT with `detail`; returns the exit code: kOk if shutdown was requested, else `code`.
  int FailStart(const StatusFigures& figures, const char* detail, int code);
  // kRunning: NodeStatus RUNNING with `detail`; systemd READY=1 with `ready_status`.
  void Running(const StatusFigures& figures, const char* detail, const char* ready_status);
  // While running: NodeStatus RUNNING, HOLD or FAULT (the node's own state and detail). False,
  // and nothing published, for a state the phase does not allow (lifecycle.hpp MayPublish).
  bool Publish(hexa_msg_NodeState state, const StatusFigures& figures, const char* detail);
  // kStopping: NodeStatus STOPPING with `detail`, systemd STOPPING=1 with `stopping_status`
  // (nullptr: `detail`).
  void Stop(const StatusFigures& figures, const char* detail,
            const char* stopping_status = nullptr);

  // The NodeStatus writer (tests); StatusTopic::kPublished only.
  comm::Writer<hexa_msg_NodeStatus>& status_writer() { return status_->writer(); }

 private:
  void Enter(Phase phase);
  void PublishStatus(hexa_msg_NodeState state, const StatusFigures& figures, const char* detail);
  std::string DescribeProcesses(const std::vector<std::string>& names) const;

  node::CommonOptions common_;
  std::string name_;
  std::shared_ptr<spdlog::logger> log_;
  node::PeerProcesses peer_processes_;
  comm::Participant participant_;
  comm::ShutdownGuard shutdown_;
  comm::WaitSet waitset_;
  std::optional<node::StatusPublisher> status_;
  Phase phase_ = Phase::kStarting;
};

}  // namespace hexa::services
