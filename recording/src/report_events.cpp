#include "report_events.hpp"

#include <algorithm>
#include <fstream>
#include <stdexcept>

namespace hexa::recorder {
namespace {

constexpr double kTickS = 0.001;

std::string StateName(int s) {
  static const char* kNames[] = {"IDLE", "BLENDING", "TRACKING", "STOPPING", "HOLD"};
  return s >= 0 && s < 5 ? kNames[s] : "UNKNOWN";
}

// FAULT_COMMAND_NOT_FINITE -> COMMAND_NOT_FINITE
std::string ShortName(const std::string& enum_name, const std::string& prefix) {
  return enum_name.rfind(prefix, 0) == 0 ? enum_name.substr(prefix.size()) : enum_name;
}

std::string CsvText(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return out + "\"";
}

}  // namespace

void EventCollector::OnFault(const rec::FaultEvent& f) {
  const auto key = std::make_tuple(f.source_node(), f.leg_id(), static_cast<int>(f.reason()));
  if (!fault_keys_.insert(key).second) return;
  std::string label = ShortName(rec::FaultReason_Name(f.reason()), "FAULT_");
  if (f.leg_id() != 0) label = "leg " + std::to_string(f.leg_id()) + " " + label;
  faults_.push_back({static_cast<double>(f.tick()) * kTickS, "fault", static_cast<int>(f.leg_id()),
                     label + " (" + f.source_node() + ")"});
}

std::vector<SessionReport::Event> EventCollector::Finish(const std::vector<Takeover>& takeovers) {
  std::vector<SessionReport::Event> out;
  std::stable_sort(poses_.begin(), poses_.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  int state = -1;
  for (const auto& [tick, s] : poses_) {
    if (s == state) continue;
    state = s;
    out.push_back({static_cast<double>(tick) * kTickS, "state", 0, StateName(s)});
  }
  out.insert(out.end(), faults_.begin(), faults_.end());
  for (const Takeover& t : takeovers) {
    out.push_back({static_cast<double>(t.first_standby_tick) * kTickS, "takeover",
                   static_cast<int>(t.leg), "leg " + std::to_string(t.leg) + " standby takes over"});
  }
  // An operator command carries its wall-clock send time only: it is placed at the first tick
  // the plant wrote at or after it.
  std::sort(truth_times_.begin(), truth_times_.end());
  for (const auto& [time_ns, kind] : operator_commands_) {
    const auto it = std::lower_bound(truth_times_.begin(), truth_times_.end(),
                                     std::make_pair(time_ns, std::uint64_t{0}));
    if (it == truth_times_.end()) continue;
    out.push_back({static_cast<double>(it->second) * kTickS, "operator", 0,
                   "operator " + ShortName(rec::OperatorCommandKind_Name(
                                               static_cast<rec::OperatorCommandKind>(kind)),
                                           "OPERATOR_")});
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const auto& a, const auto& b) { return a.time_s < b.time_s; });
  return out;
}

void WriteEventsCsv(const std::vector<SessionReport::Event>& events, const std::string& path) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "time_s [s],kind [-],leg [1],label [-]\n";
  char buf[32];
  for (const auto& e : events) {
    std::snprintf(buf, sizeof buf, "%.3f", e.time_s);
    f << buf << "," << e.kind << "," << e.leg << "," << CsvText(e.label) << "\n";
  }
}

}  // namespace hexa::recorder
