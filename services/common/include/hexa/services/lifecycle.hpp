// The lifecycle every service goes through, as plain units without DDS or a clock (runtime.hpp
// puts them on the wire): starting -> peers matched -> running -> stopping, and the rule that
// decides how long a service waits for its peers and when it says which one is missing.
//
//   phase          NodeStatus state it publishes    systemd (service_manager.hpp)
//   kStarting      STARTING (what it waits for)     -
//   kPeersMatched  (none: still STARTING)           -
//   kRunning       RUNNING, HOLD or FAULT           READY=1 on entry
//   kStopping      STOPPING                         STOPPING=1 on entry
//   kFailed        FAULT (why it could not start)   -
//
// A service that fails to start (peers not matched in time) publishes FAULT and exits; one
// asked to stop while it starts leaves without running.
#pragma once

#include <cstdint>

#include "hexa/comm/comm.hpp"

namespace hexa::services {

enum class Phase : std::uint8_t { kStarting, kPeersMatched, kRunning, kStopping, kFailed };
const char* ToString(Phase phase);

// The legal transitions: kStarting -> kPeersMatched | kFailed | kStopping;
// kPeersMatched -> kRunning | kStopping; kRunning -> kStopping. Nothing leaves kStopping or
// kFailed.
bool CanEnter(Phase from, Phase to);

// The NodeStatus state a phase publishes on entry (kPeersMatched: STARTING).
hexa_msg_NodeState StateOf(Phase phase);

// Whether `state` may be published while in `phase`: RUNNING, HOLD and FAULT only while
// running; STARTING while starting or matched; STOPPING while stopping; FAULT when failed.
bool MayPublish(Phase phase, hexa_msg_NodeState state);

// What a NodeStatus carries besides its state and detail (idl/hexa.idl NodeStatus): each
// service fills it from its own counters (the leg: its last answered tick and the sensor
// reader's deadline misses; the plant's liveliness rule reads `cycles`; docs/faults.md).
struct StatusFigures {
  std::uint64_t tick = 0;
  double sim_time_s = 0.0;
  std::uint32_t deadline_missed = 0;
  std::uint32_t liveliness_changes = 0;
  std::uint64_t cycles = 0;
  double cycle_median_s = 0.0;
  double cycle_max_s = 0.0;
};

// The start-up wait for peers, as a rule of time: the caller passes the monotonic time of
// each look and whether everything was matched then.
//   kMatched   every peer matched: go on
//   kWait      keep waiting, nothing to say
//   kReport    keep waiting, and say which peer is missing and why (first after
//              report_after_s, then every report_every_s)
//   kTimedOut  timeout_s passed without a match: the service cannot start
class PeerWaitRule {
 public:
  enum class Verdict : std::uint8_t { kMatched, kWait, kReport, kTimedOut };
  struct Params {
    double timeout_s = 30.0;
    double report_after_s = 3.0;
    double report_every_s = 1.0;
  };
  PeerWaitRule(const Params& params, std::int64_t start_ns);
  Verdict Look(std::int64_t now_ns, bool matched);
  // Seconds waited at the last look.
  double waited_s() const { return waited_s_; }

 private:
  Params params_;
  std::int64_t start_ns_;
  std::int64_t next_report_ns_;
  double waited_s_ = 0.0;
};

}  // namespace hexa::services
