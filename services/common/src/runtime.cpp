#include "hexa/services/runtime.hpp"

#include <sys/resource.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <stdexcept>

#include "hexa/comm/config.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/logging.hpp"
#include "hexa/services/scheduling.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::services {

int UsageError(const cli::Parser& parser, const char* program) {
  if (program != nullptr)
    std::fprintf(stderr, "%s: error: %s\n(see --help)\n", program, parser.error().c_str());
  else
    std::fprintf(stderr, "error: %s\n(see --help)\n", parser.error().c_str());
  return exit_code::kUsage;
}

int RunControlService(const ControlService& service, const node::CommonOptions& common,
                      const ControlBody& body) {
  auto log = logging::Init(service.name, common.log_file, common.log_level);
  try {
    comm::EnsureDdsConfig(common.dds_config);
    if (!node::InstallSessionKey(common.session_key_path, *log)) return exit_code::kUsage;
    auto config = node::LoadConfig(common, *log);
    if (!config) return exit_code::kRunError;
    // Before the participant exists: Cyclone's threads inherit the policy
    // (docs/platform_notes.md).
    auto latency_hold = node::ApplyScheduling(common, service.default_rt_priority, *log);
    const int rc = body(*config, log);
    // The loop is over: its teardown must not starve the processes still running (real time).
    node::LeaveRealtimeScheduling(common, latency_hold, *log);
    return rc;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return exit_code::kRunError;
  }
}

int RunService(const std::string& name, const std::string& log_file, const std::string& log_level,
               const std::optional<std::string>& dds_config, const ServiceBody& body) {
  auto log = logging::Init(name, log_file, log_level);
  try {
    comm::EnsureDdsConfig(dds_config);
    return body(log);
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return exit_code::kRunError;
  }
}

void ApplyBackgroundScheduling(const std::vector<int>& cpus, int nice, spdlog::logger& log) {
  std::string message;
  if (!cpus.empty()) {
    const bool ok = sched::SetCpuAffinity(cpus, message);
    if (ok) log.info("{}", message);
    else log.warn("{}", message);
  }
  if (nice > 0 && setpriority(PRIO_PROCESS, 0, nice) != 0)
    log.warn("niceness {} not applied: {}", nice, std::strerror(errno));
  else if (nice > 0)
    log.info("niceness {}", nice);
}

namespace {

node::PeerProcesses ParsePeerProcesses(const std::vector<std::string>& specs) {
  node::PeerProcesses processes;
  for (const std::string& spec : specs) {
    std::string error;
    if (!processes.Add(spec, error)) throw std::invalid_argument(error);
  }
  return processes;
}

}  // namespace

Runtime::Runtime(const node::CommonOptions& common, std::string node_name,
                 std::shared_ptr<spdlog::logger> log, comm::WriteBatching batching,
                 StatusTopic status)
    : common_(common),
      name_(std::move(node_name)),
      log_(std::move(log)),
      peer_processes_(ParsePeerProcesses(common.peer_pids)),
      participant_(static_cast<dds_domainid_t>(common.domain_id), batching),
      shutdown_(participant_),
      waitset_(participant_) {
  waitset_.Attach(shutdown_.guard_condition(), kShutdownToken);
  if (status == StatusTopic::kPublished) status_.emplace(participant_, name_);
}

void Runtime::Enter(Phase phase) {
  if (!CanEnter(phase_, phase))
    throw std::logic_error(name_ + ": lifecycle cannot go from " + ToString(phase_) + " to " +
                           ToString(phase));
  phase_ = phase;
}

void Runtime::PublishStatus(hexa_msg_NodeState state, const StatusFigures& f, const char* detail) {
  if (!status_) return;
  status_->Publish(state, f.tick, f.sim_time_s, f.deadline_missed, f.liveliness_changes, f.cycles,
                  f.cycle_median_s, f.cycle_max_s, detail);
}

void Runtime::Start(const StatusFigures& figures, const char* detail) {
  if (phase_ != Phase::kStarting)
    throw std::logic_error(name_ + ": Start in phase " + std::string(ToString(phase_)));
  PublishStatus(hexa_msg_NODE_STARTING, figures, detail);
}

std::string Runtime::DescribeProcesses(const std::vector<std::string>& names) const {
  std::string text;
  for (const std::string& name : names) {
    if (!peer_processes_.Known(name)) continue;  // another host's, or not started by a launcher
    text += text.empty() ? "; processes: " : "; ";
    const node::PeerProcessState state = peer_processes_.State(name);
    text += peer_processes_.Describe(name);
    if (state == node::PeerProcessState::kStopped) text += " (it cannot answer until it is continued)";
    if (state == node::PeerProcessState::kEnded) text += " (it will never match: the launcher's log says how it ended)";
  }
  return text;
}

PeerWaitResult Runtime::WaitForPeers(const PeerWait& wait) {
  PeerWaitRule rule(wait.rule, node::MonotonicNow_ns());
  std::string missing;
  while (!shutdown_.requested()) {
    missing.clear();
    const bool matched = wait.matched(missing);
    if (!matched && wait.fail_when_a_process_ends) {
      for (const std::string& name : wait.processes) {
        if (peer_processes_.State(name) != node::PeerProcessState::kEnded) continue;
        log_->error("peers not ready: {}'s process has ended (the launcher's log says how); "
                    "waited {:.1f} s", name, rule.waited_s());
        return PeerWaitResult::kProcessEnded;
      }
    }
    switch (rule.Look(node::MonotonicNow_ns(), matched)) {
      case PeerWaitRule::Verdict::kMatched:
        Enter(Phase::kPeersMatched);
        return PeerWaitResult::kMatched;
      case PeerWaitRule::Verdict::kTimedOut:
        log_->error("peers not matched after {} s: {}{}", wait.rule.timeout_s, missing,
                    DescribeProcesses(wait.processes));
        return PeerWaitResult::kTimedOut;
      case PeerWaitRule::Verdict::kReport:
        // After a few seconds, every second: which peer is missing and why.
        log_->warn("waiting for peers for {:.1f} s: {}{}", rule.waited_s(), missing,
                   DescribeProcesses(wait.processes));
        break;
      case PeerWaitRule::Verdict::kWait: break;
    }
    waitset_.Wait(static_cast<dds_duration_t>(wait.recheck_ns));
  }
  return PeerWaitResult::kShutdown;
}

int Runtime::FailStart(const StatusFigures& figures, const char* detail, int code) {
  Enter(Phase::kFailed);
  PublishStatus(hexa_msg_NODE_FAULT, figures, detail);
  return shutdown_.requested() ? exit_code::kOk : code;
}

void Runtime::Running(const StatusFigures& figures, const char* detail, const char* ready_status) {
  Enter(Phase::kRunning);
  PublishStatus(hexa_msg_NODE_RUNNING, figures, detail);
  node::service_manager::Ready(ready_status);
}

bool Runtime::Publish(hexa_msg_NodeState state, const StatusFigures& figures, const char* detail) {
  // A state its phase does not allow is a programming error; in the cycle it is dropped, not
  // thrown (the status writer keeps the last good one).
  if (!MayPublish(phase_, state)) return false;
  PublishStatus(state, figures, detail);
  return true;
}

void Runtime::Stop(const StatusFigures& figures, const char* detail, const char* stopping_status) {
  Enter(Phase::kStopping);
  PublishStatus(hexa_msg_NODE_STOPPING, figures, detail);
  node::service_manager::Stopping(stopping_status != nullptr ? stopping_status : detail);
}

}  // namespace hexa::services
