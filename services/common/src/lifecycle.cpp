#include "hexa/services/lifecycle.hpp"

namespace hexa::services {

const char* ToString(Phase phase) {
  switch (phase) {
    case Phase::kStarting: return "starting";
    case Phase::kPeersMatched: return "peers matched";
    case Phase::kRunning: return "running";
    case Phase::kStopping: return "stopping";
    case Phase::kFailed: return "failed";
  }
  return "?";
}

bool CanEnter(Phase from, Phase to) {
  switch (from) {
    case Phase::kStarting:
      return to == Phase::kPeersMatched || to == Phase::kFailed || to == Phase::kStopping;
    case Phase::kPeersMatched: return to == Phase::kRunning || to == Phase::kStopping;
    case Phase::kRunning: return to == Phase::kStopping;
    case Phase::kStopping:
    case Phase::kFailed: return false;
  }
  return false;
}

hexa_msg_NodeState StateOf(Phase phase) {
  switch (phase) {
    case Phase::kStarting:
    case Phase::kPeersMatched: return hexa_msg_NODE_STARTING;
    case Phase::kRunning: return hexa_msg_NODE_RUNNING;
    case Phase::kStopping: return hexa_msg_NODE_STOPPING;
    case Phase::kFailed: return hexa_msg_NODE_FAULT;
  }
  return hexa_msg_NODE_FAULT;
}

bool MayPublish(Phase phase, hexa_msg_NodeState state) {
  switch (phase) {
    case Phase::kStarting:
    case Phase::kPeersMatched: return state == hexa_msg_NODE_STARTING;
    case Phase::kRunning:
      return state == hexa_msg_NODE_RUNNING || state == hexa_msg_NODE_HOLD ||
             state == hexa_msg_NODE_FAULT;
    case Phase::kStopping: return state == hexa_msg_NODE_STOPPING;
    case Phase::kFailed: return state == hexa_msg_NODE_FAULT;
  }
  return false;
}

PeerWaitRule::PeerWaitRule(const Params& params, std::int64_t start_ns)
    : params_(params),
      start_ns_(start_ns),
      next_report_ns_(start_ns + static_cast<std::int64_t>(params.report_after_s * 1e9)) {}

PeerWaitRule::Verdict PeerWaitRule::Look(std::int64_t now_ns, bool matched) {
  waited_s_ = static_cast<double>(now_ns - start_ns_) * 1e-9;
  if (matched) return Verdict::kMatched;
  if (waited_s_ > params_.timeout_s) return Verdict::kTimedOut;
  if (now_ns < next_report_ns_) return Verdict::kWait;
  next_report_ns_ = now_ns + static_cast<std::int64_t>(params_.report_every_s * 1e9);
  return Verdict::kReport;
}

}  // namespace hexa::services
