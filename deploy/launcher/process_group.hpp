// Starts and supervises child processes so that none outlives its parent: each child is
// put in its own process group, gets PR_SET_PDEATHSIG(SIGTERM) (it dies if this process
// dies, even by SIGKILL), and is terminated (SIGTERM, then SIGKILL after a grace period)
// when the group is stopped or destroyed. Used by the session launcher and by the
// integration tests.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hexa::deploy {

struct ChildSpec {
  std::string name;                          // for logs and lookups
  std::vector<std::string> argv;             // argv[0] = executable path
  std::map<std::string, std::string> env;    // added to / overriding the environment
  std::string log_path;                      // stdout + stderr go here; empty = inherit
  // CPU affinity set in the child before exec (systemd's CPUAffinity=); empty = inherited.
  // A CPU the machine does not have fails the child (exit 126, message in its log).
  std::vector<int> cpus{};
};

struct ChildExit {
  std::string name;
  pid_t pid = -1;
  int exit_code = -1;    // valid when !signaled
  int signal = 0;        // terminating signal, 0 if exited normally
  double cpu_user_s = 0.0;    // CPU time of the child over its life (wait4 rusage)
  double cpu_system_s = 0.0;
  long max_rss_kb = 0;
  std::string Describe() const;
};

class ProcessGroup {
 public:
  // Blocks SIGCHLD, SIGINT and SIGTERM in the calling thread so that WaitEvent can
  // receive them synchronously. Create it before any other thread is started.
  ProcessGroup();
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  // Returns the pid, or -1 with a message in `error`.
  pid_t Start(const ChildSpec& spec, std::string& error);

  struct Event {
    enum Kind { kTimeout, kChildExited, kInterrupted } kind = kTimeout;
    ChildExit exit;      // for kChildExited
    int signal = 0;      // for kInterrupted (SIGINT / SIGTERM received by this process)
  };
  // Waits until a child exits, this process is asked to stop, or the timeout passes.
  Event WaitEvent(std::chrono::milliseconds timeout);

  // SIGTERM to one running child, wait up to `grace`, then SIGKILL. Returns its exit.
  std::optional<ChildExit> Stop(const std::string& name, std::chrono::milliseconds grace);
  // Stops every running child in reverse start order.
  std::vector<ChildExit> StopAll(std::chrono::milliseconds grace);
  // SIGTERM to every named running child at once, one shared `grace`, then SIGKILL to those
  // still running: the stop takes as long as the slowest child, not the sum. Exits in the
  // order the names are given (names not running are skipped).
  std::vector<ChildExit> StopTogether(const std::vector<std::string>& names,
                                      std::chrono::milliseconds grace);

  bool Running(const std::string& name) const;
  std::vector<std::string> RunningNames() const;

 private:
  struct Child {
    ChildSpec spec;
    pid_t pid;
  };
  std::optional<ChildExit> Reap(pid_t pid, bool block);
  std::vector<Child> running_;
  sigset_t* old_mask_;
};

}  // namespace hexa::deploy
