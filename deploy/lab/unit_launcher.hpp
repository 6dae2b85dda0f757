// Starts the processes of a generated deployment (hexa_deploy generate --in-place) in the
// namespaces of a NetnsLab, each exactly as its systemd unit says: the unit's Environment,
// its ExecStartPre (must exit 0), its ExecStart; and plays systemd's side of the
// notification protocol: a socket per unit (NOTIFY_SOCKET) and WATCHDOG_USEC from the unit's
// WatchdogSec, so that READY=1, WATCHDOG=1 and STOPPING=1 from each process are seen and
// counted. A test harness, not a service manager: no restarts, no dependencies.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "netns_lab.hpp"
#include "process_group.hpp"
#include "unit_file.hpp"

namespace hexa::deploy {

struct NotifySeen {
  bool ready = false;
  int watchdog = 0;
  bool stopping = false;
  std::string last_status;
  std::int64_t ready_mono_ns = 0;
  std::int64_t last_watchdog_mono_ns = 0;
  std::int64_t max_watchdog_gap_ns = 0;  // longest silence between pings after READY
};

class UnitLauncher {
 public:
  // `generated`: the --out directory of hexa_deploy generate; `work`: logs and notify sockets
  // (keep it short: a socket path has at most 107 characters).
  UnitLauncher(ProcessGroup& group, const NetnsLab& lab, std::string generated, std::string work);
  ~UnitLauncher();

  // Every unit of `host` (hosts/<host>/lib/systemd/system/*.service), sorted by name.
  std::vector<std::string> UnitsOf(const std::string& host) const;
  // Runs the unit's ExecStartPre lines, then starts its ExecStart in the host's namespace.
  // The process is named after the unit without ".service". Extra environment is added.
  bool Start(const std::string& host, const std::string& unit, std::string& error,
             const std::map<std::string, std::string>& extra_env = {});

  // Reads what arrived on the notification sockets.
  void Poll();
  const NotifySeen& Seen(const std::string& name) const;
  std::vector<std::string> Names() const;
  std::string LogOf(const std::string& name) const { return work_ + "/" + name + ".log"; }
  // CPU time (user + system, all threads) a running unit's process has used so far, from
  // /proc/<pid>/stat; -1 when it no longer runs.
  double CpuSeconds(const std::string& name) const;
  // The same per thread, summed by thread name (Cyclone names its threads: recvUC, tev, gc,
  // dq.builtins, ...; the process's own threads carry the program's name); empty when the
  // process no longer runs. A thread that has ended is no longer listed.
  std::map<std::string, double> ThreadCpuSeconds(const std::string& name) const;
  // Each thread's scheduling policy by thread name (0 SCHED_OTHER, 1 SCHED_FIFO; threads of
  // one name that differ: the last one read); empty when the process no longer runs.
  std::map<std::string, int> ThreadPolicies(const std::string& name) const;
  // The CPUs the running process may use (/proc/<pid>/status Cpus_allowed_list, e.g. "1" or
  // "0-1"); "" when it no longer runs.
  std::string AllowedCpus(const std::string& name) const;
  const UnitFile& Unit(const std::string& name) const { return units_.at(name); }
  // The process id of a started unit (-1 if never started).
  pid_t Pid(const std::string& name) const {
    const auto it = pids_.find(name);
    return it == pids_.end() ? -1 : it->second;
  }

 private:
  struct ThreadStat {
    std::string name;
    double cpu_s = 0;
    int policy = -1;
  };
  std::vector<ThreadStat> Threads(const std::string& name) const;  // /proc/<pid>/task/*/stat
  struct Socket {
    int fd = -1;
    std::string path;
  };
  ProcessGroup& group_;
  const NetnsLab& lab_;
  std::string generated_, work_;
  std::map<std::string, Socket> sockets_;
  std::map<std::string, NotifySeen> seen_;
  std::map<std::string, UnitFile> units_;
  std::map<std::string, pid_t> pids_;
};

}  // namespace hexa::deploy
