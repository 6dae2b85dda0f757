#include "hexa/services/peer_processes.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "proc_text.hpp"

namespace hexa::node {
namespace {

// State letter and start time (clock ticks after boot) of /proc/PID/stat; false if the
// process does not exist. The command name (field 2) may hold spaces and parentheses: the
// fields after it start after the last ')'.
bool ReadStat(int pid, char& state, std::uint64_t& start_ticks) {
  char path[32];
  std::snprintf(path, sizeof path, "/proc/%d/stat", pid);
  char buf[1024];
  if (!proc::ReadText(path, buf, sizeof buf)) return false;
  const char* p = std::strrchr(buf, ')');
  if (p == nullptr || p[1] != ' ') return false;
  p += 2;
  state = *p;
  // Field 3 is the state; the start time is field 22: 19 more fields after the state.
  for (int field = 3; field < 22 && p != nullptr; ++field) {
    p = std::strchr(p, ' ');
    if (p != nullptr) ++p;
  }
  if (p == nullptr) return false;
  start_ticks = std::strtoull(p, nullptr, 10);
  return true;
}

}  // namespace

const char* ToString(PeerProcessState state) {
  switch (state) {
    case PeerProcessState::kUnknown: return "unknown (no process id)";
    case PeerProcessState::kRunning: return "running";
    case PeerProcessState::kStopped: return "stopped (by a signal or a debugger)";
    case PeerProcessState::kEnded: return "ended";
  }
  return "?";
}

bool PeerProcesses::Add(const std::string& spec, std::string& error) {
  const auto eq = spec.find('=');
  char* end = nullptr;
  const long pid = eq == std::string::npos ? 0 : std::strtol(spec.c_str() + eq + 1, &end, 10);
  if (eq == 0 || eq == std::string::npos || end == nullptr || *end != '\0' || pid <= 0 ||
      pid > 4'194'304) {
    error = "--peer-pid '" + spec + "': expected NAME=PID, e.g. leg3=12345";
    return false;
  }
  Peer p{spec.substr(0, eq), static_cast<int>(pid), 0};
  char state = 0;
  // The launcher started it: a process that no longer exists has ended already.
  if (!ReadStat(p.pid, state, p.start_ticks)) p.start_ticks = kEndedBeforeAdd;
  peers_.push_back(p);
  return true;
}

bool PeerProcesses::Known(const std::string& name) const {
  for (const Peer& p : peers_)
    if (p.name == name) return true;
  return false;
}

PeerProcessState PeerProcesses::State(const std::string& name) const {
  for (const Peer& p : peers_) {
    if (p.name != name) continue;
    char state = 0;
    std::uint64_t start = 0;
    if (p.start_ticks == kEndedBeforeAdd || !ReadStat(p.pid, state, start) || start != p.start_ticks)
      return PeerProcessState::kEnded;
    if (state == 'Z' || state == 'X' || state == 'x') return PeerProcessState::kEnded;
    if (state == 'T' || state == 't') return PeerProcessState::kStopped;
    return PeerProcessState::kRunning;
  }
  return PeerProcessState::kUnknown;
}

std::string PeerProcesses::Describe(const std::string& name) const {
  for (const Peer& p : peers_)
    if (p.name == name)
      return name + " (pid " + std::to_string(p.pid) + "): " + ToString(State(name));
  return name + ": " + ToString(PeerProcessState::kUnknown);
}

}  // namespace hexa::node
