// The other processes of a session on this host, by name, as the launcher that started them
// names them (--peer-pid NAME=PID): whether each one still exists and whether it is stopped.
// The launcher knows its children; a process named here that ended is known to have ended at
// the next look, where DDS sees it only when its participant's lease expires (10 s). A
// stopped process (SIGSTOP, a debugger) or one the host does not schedule is alive: lockstep
// waits for it (docs/faults.md). Processes on other hosts are not named here: for them only
// DDS says anything. Reads /proc/PID/stat: no allocation after Add, no DDS.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hexa::node {

enum class PeerProcessState : std::uint8_t {
  kUnknown,  // no process id was given for this name
  kRunning,  // exists and is not stopped (running, runnable or sleeping)
  kStopped,  // stopped by a signal or traced (state T / t)
  kEnded,    // exited (a zombie not yet reaped, or gone, or its id now names another process)
};
const char* ToString(PeerProcessState state);

class PeerProcesses {
 public:
  // "name=pid"; false with `error` set on a malformed spec. A pid that no longer exists is a
  // process that has ended.
  bool Add(const std::string& spec, std::string& error);
  PeerProcessState State(const std::string& name) const;
  bool Known(const std::string& name) const;
  bool empty() const { return peers_.empty(); }
  // "leg3 (pid 123): stopped" for the log; allocates.
  std::string Describe(const std::string& name) const;

 private:
  struct Peer {
    std::string name;
    int pid = 0;
    std::uint64_t start_ticks = 0;  // /proc/PID/stat field 22: tells a reused pid apart
  };
  static constexpr std::uint64_t kEndedBeforeAdd = ~std::uint64_t{0};
  std::vector<Peer> peers_;
};

}  // namespace hexa::node
