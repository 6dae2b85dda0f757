// What happened in a session, as marks for the plots: the supervisor's state changes (the
// tracking window, HOLD), fault events, hot-standby take-overs and operator commands, each at
// the simulated time of its tick. Collected while the report reads the recording.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "hexa/recording/report.hpp"
#include "hexa/recording/takeover.hpp"
#include "recording.pb.h"

namespace hexa::recorder {

class EventCollector {
 public:
  void OnPose(std::uint64_t tick, int state) { poses_.emplace_back(tick, state); }
  void OnFault(const rec::FaultEvent& fault);
  void OnOperator(const rec::OperatorCommand& command) {
    operator_commands_.emplace_back(command.source_time_ns(), command.kind());
  }
  void OnTruth(std::uint64_t tick, std::int64_t source_time_ns) {
    truth_times_.emplace_back(source_time_ns, tick);
  }
  // The events in time order, with a mark per take-over (TakeoverDetector, takeover.hpp).
  // Faults: the first of each (source, leg, reason) only.
  std::vector<SessionReport::Event> Finish(const std::vector<Takeover>& takeovers);

 private:
  std::vector<std::pair<std::uint64_t, int>> poses_;
  std::vector<SessionReport::Event> faults_;
  std::set<std::tuple<std::string, std::uint32_t, int>> fault_keys_;
  std::vector<std::pair<std::int64_t, int>> operator_commands_;
  std::vector<std::pair<std::int64_t, std::uint64_t>> truth_times_;  // source time -> tick
};

// events.csv: one row per event, columns "time_s [s]", "kind [-]", "leg [1]", "label [-]".
void WriteEventsCsv(const std::vector<SessionReport::Event>& events, const std::string& path);

}  // namespace hexa::recorder
