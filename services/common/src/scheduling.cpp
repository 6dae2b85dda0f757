#include "hexa/services/scheduling.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>

#include "proc_text.hpp"

namespace hexa::sched {
namespace {

bool ParseNumber(const std::string& text, int& out) {
  if (text.empty() || text.size() > 4 || text.find_first_not_of("0123456789") != std::string::npos)
    return false;
  out = std::stoi(text);
  return true;
}

}  // namespace

bool ParseCpuList(const std::string& text, std::vector<int>& cpus) {
  cpus.clear();
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    const std::size_t dash = item.find('-');
    int first = 0, last = 0;
    if (dash == std::string::npos) {
      if (!ParseNumber(item, first)) return false;
      last = first;
    } else if (!ParseNumber(item.substr(0, dash), first) ||
               !ParseNumber(item.substr(dash + 1), last) || last < first) {
      return false;
    }
    if (last >= CPU_SETSIZE) return false;
    for (int c = first; c <= last; ++c) cpus.push_back(c);
    pos = comma + 1;
  }
  return !cpus.empty();
}

std::vector<int> AllowedCpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<int> cpus;
  if (sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &set)) cpus.push_back(c);
  return cpus;
}

CpuSplit AutoCpuSplit() {
  const std::vector<int> allowed = AllowedCpus();
  if (allowed.size() < 2) return {};
  return {{allowed.back()}, std::vector<int>(allowed.begin(), allowed.end() - 1)};
}

std::string FormatCpuList(const std::vector<int>& cpus) {
  std::string list;
  for (int c : cpus) list += (list.empty() ? "" : ",") + std::to_string(c);
  return list;
}

bool SetCpuAffinity(const std::vector<int>& cpus, std::string& message) {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::string list;
  for (int c : cpus) {
    if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
    list += (list.empty() ? "" : ",") + std::to_string(c);
  }
  if (sched_setaffinity(0, sizeof set, &set) != 0) {
    message = "CPU affinity " + list + " not applied (" + std::strerror(errno) +
              "): running on any CPU";
    return false;
  }
  message = "CPU affinity: " + list;
  return true;
}

bool SetRealtime(int priority, std::string& message) {
  sched_param sp{};
  sp.sched_priority = priority;
  bool ok = true;
  if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
    message = "SCHED_FIFO priority " + std::to_string(priority) + " enabled";
  } else {
    message = std::string("SCHED_FIFO not available (") + std::strerror(errno) +
              "): running with normal scheduling";
    ok = false;
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    message += "; memory locked (mlockall)";
  } else {
    message += std::string("; mlockall not available (") + std::strerror(errno) + ")";
  }
  return ok;
}

bool LeaveRealtime(std::string& message) {
  DIR* dir = opendir("/proc/self/task");
  if (dir == nullptr) {
    message = std::string("cannot list this process's threads (") + std::strerror(errno) + ")";
    return false;
  }
  int changed = 0;
  int failed = 0;
  const sched_param normal{};
  while (const dirent* e = readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    const pid_t tid = static_cast<pid_t>(std::strtol(e->d_name, nullptr, 10));
    if (sched_getscheduler(tid) != SCHED_FIFO) continue;  // already normal (or gone)
    if (sched_setscheduler(tid, SCHED_OTHER, &normal) == 0) {
      ++changed;
    } else if (errno != ESRCH) {
      ++failed;
    }
  }
  closedir(dir);
  munlockall();
  message = "left SCHED_FIFO: " + std::to_string(changed) + " threads back to normal scheduling" +
            (failed > 0 ? ", " + std::to_string(failed) + " refused" : "") +
            "; memory unlocked";
  return failed == 0;
}

int CurrentThreadId() {
  thread_local const int tid = static_cast<int>(gettid());
  return tid;
}

bool ReadThreadSchedStat(int tid, std::uint64_t& run_ns, std::uint64_t& wait_ns) {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/self/task/%d/schedstat", tid);
  char text[96];
  if (!proc::ReadText(path, text, sizeof text)) return false;
  unsigned long long run = 0, wait = 0;
  if (std::sscanf(text, "%llu %llu", &run, &wait) != 2) return false;
  run_ns = run;
  wait_ns = wait;
  return true;
}

CpuLatencyHold::CpuLatencyHold(int latency_us, std::string& message, const std::string& device) {
  const int fd = open(device.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    message = "CPU wake-up latency not limited (" + device + ": " + std::strerror(errno) +
              "): idle CPUs may halt and every wake-up costs more; the service user needs write "
              "access to the device (docs/deployment.md), or pass --cpu-latency-us none";
    return;
  }
  const std::int32_t value = latency_us;
  if (write(fd, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) {
    message = "CPU wake-up latency not limited (writing " + std::to_string(latency_us) +
              " to " + device + ": " + std::strerror(errno) + ")";
    close(fd);
    return;
  }
  fd_ = fd;
  message = "CPU wake-up latency held at " + std::to_string(latency_us) + " us (" + device +
            (latency_us == 0 ? "): idle CPUs poll instead of halting while the loop runs"
                             : "): deeper idle states are off while the loop runs");
}

CpuLatencyHold::~CpuLatencyHold() { Release(); }

CpuLatencyHold::CpuLatencyHold(CpuLatencyHold&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

CpuLatencyHold& CpuLatencyHold::operator=(CpuLatencyHold&& other) noexcept {
  if (this != &other) {
    Release();
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

void CpuLatencyHold::Release() {
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

}  // namespace hexa::sched
