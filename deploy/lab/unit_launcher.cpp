#include "unit_launcher.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hexa/services/scheduling.hpp"

namespace hexa::deploy {
namespace {

namespace fs = std::filesystem;

std::int64_t MonoNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

UnitLauncher::UnitLauncher(ProcessGroup& group, const NetnsLab& lab, std::string generated,
                           std::string work)
    : group_(group), lab_(lab), generated_(std::move(generated)), work_(std::move(work)) {
  fs::create_directories(work_);
}

UnitLauncher::~UnitLauncher() {
  for (auto& [name, s] : sockets_) {
    if (s.fd >= 0) close(s.fd);
    unlink(s.path.c_str());
  }
}

std::vector<std::string> UnitLauncher::UnitsOf(const std::string& host) const {
  std::vector<std::string> units;
  const fs::path dir = fs::path(generated_) / "hosts" / host / "lib/systemd/system";
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".service") units.push_back(e.path().filename().string());
  std::sort(units.begin(), units.end());
  return units;
}

bool UnitLauncher::Start(const std::string& host, const std::string& unit_name,
                         std::string& error, const std::map<std::string, std::string>& extra_env) {
  const std::string path =
      (fs::path(generated_) / "hosts" / host / "lib/systemd/system" / unit_name).string();
  UnitFile unit;
  if (!ParseUnitFile(path, unit, error)) return false;
  const std::string name = unit_name.substr(0, unit_name.rfind(".service"));
  if (unit.Get("Service.Type") != "notify") {
    error = path + ": Type is '" + unit.Get("Service.Type") + "', expected notify";
    return false;
  }
  std::map<std::string, std::string> env(unit.environment.begin(), unit.environment.end());
  for (const auto& [k, v] : extra_env) env[k] = v;

  // ExecStartPre: synchronously, in the host's namespace, must exit 0 (as systemd requires).
  int pre_index = 0;
  for (const auto& pre : unit.exec_start_pre) {
    ChildSpec s;
    s.name = name + "-pre" + std::to_string(pre_index);
    s.argv = lab_.InHost(host, pre);
    s.env = env;
    s.log_path = work_ + "/" + s.name + ".log";
    if (group_.Start(s, error) < 0) return false;
    const auto ev = group_.WaitEvent(std::chrono::seconds(60));
    if (ev.kind != ProcessGroup::Event::kChildExited || ev.exit.name != s.name) {
      error = name + ": ExecStartPre did not finish (see " + s.log_path + ")";
      return false;
    }
    if (ev.exit.signal != 0 || ev.exit.exit_code != 0) {
      error = name + ": ExecStartPre failed: " + ev.exit.Describe() + " (see " + s.log_path + ")";
      return false;
    }
    ++pre_index;
  }

  // systemd's end of sd_notify: a datagram socket per unit.
  Socket sock;
  sock.path = work_ + "/" + name + ".sock";
  unlink(sock.path.c_str());
  sock.fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (sock.path.size() >= sizeof addr.sun_path) {
    error = "notify socket path too long: " + sock.path;
    return false;
  }
  std::strcpy(addr.sun_path, sock.path.c_str());
  if (sock.fd < 0 || bind(sock.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    error = "cannot bind notify socket " + sock.path + ": " + std::strerror(errno);
    return false;
  }
  env["NOTIFY_SOCKET"] = sock.path;
  if (unit.watchdog_s > 0)
    env["WATCHDOG_USEC"] = std::to_string(static_cast<long long>(std::llround(unit.watchdog_s * 1e6)));
  sockets_[name] = sock;
  seen_[name] = NotifySeen{};

  ChildSpec s;
  s.name = name;
  s.argv = lab_.InHost(host, unit.exec_start);
  s.env = env;
  s.log_path = LogOf(name);
  // CPUAffinity= as systemd applies it: before exec, inherited by every thread (systemd.exec:
  // a list of CPU indices or ranges separated by blanks or commas).
  if (std::string affinity = unit.Get("Service.CPUAffinity"); !affinity.empty()) {
    std::replace(affinity.begin(), affinity.end(), ' ', ',');
    if (!sched::ParseCpuList(affinity, s.cpus)) {
      error = path + ": CPUAffinity '" + unit.Get("Service.CPUAffinity") + "' is not a CPU list";
      return false;
    }
  }
  const pid_t pid = group_.Start(s, error);
  if (pid < 0) return false;
  pids_[name] = pid;
  units_[name] = std::move(unit);
  return true;
}

void UnitLauncher::Poll() {
  char buf[4096];
  for (auto& [name, s] : sockets_) {
    NotifySeen& seen = seen_[name];
    while (true) {
      const ssize_t n = recv(s.fd, buf, sizeof buf - 1, 0);
      if (n <= 0) break;
      buf[n] = '\0';
      const std::int64_t now = MonoNs();
      std::string msg(buf, static_cast<std::size_t>(n));
      std::size_t pos = 0;
      while (pos < msg.size()) {
        std::size_t eol = msg.find('\n', pos);
        if (eol == std::string::npos) eol = msg.size();
        const std::string line = msg.substr(pos, eol - pos);
        pos = eol + 1;
        if (line == "READY=1") {
          seen.ready = true;
          seen.ready_mono_ns = now;
          seen.last_watchdog_mono_ns = now;
        } else if (line == "WATCHDOG=1") {
          ++seen.watchdog;
          if (seen.last_watchdog_mono_ns != 0)
            seen.max_watchdog_gap_ns = std::max(seen.max_watchdog_gap_ns, now - seen.last_watchdog_mono_ns);
          seen.last_watchdog_mono_ns = now;
        } else if (line == "STOPPING=1") {
          seen.stopping = true;
        } else if (line.rfind("STATUS=", 0) == 0) {
          seen.last_status = line.substr(7);
        }
      }
    }
  }
}

namespace {

// user + system seconds, the command name and the scheduling policy (SCHED_OTHER 0,
// SCHED_FIFO 1, ...) of a /proc/<pid>[/task/<tid>]/stat file; false when it cannot be read
// (the process or thread has ended).
bool ReadStat(const std::string& path, double& cpu_s, std::string& comm, int* policy = nullptr) {
  std::ifstream in(path);
  std::string text;
  if (!std::getline(in, text)) return false;
  // Fields after the command name (which may contain blanks) in parentheses: utime is the
  // 14th field, stime the 15th (proc(5)).
  const auto open = text.find('(');
  const auto close = text.rfind(')');
  if (open == std::string::npos || close == std::string::npos || close < open) return false;
  comm = text.substr(open + 1, close - open - 1);
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  const int last = policy != nullptr ? 41 : 15;
  for (int i = 3; i <= last && rest >> field; ++i) {
    if (i == 14) utime = std::stoull(field);
    if (i == 15) stime = std::stoull(field);
    if (i == 41) *policy = std::stoi(field);
  }
  cpu_s = static_cast<double>(utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
  return true;
}

}  // namespace

double UnitLauncher::CpuSeconds(const std::string& name) const {
  const auto it = pids_.find(name);
  if (it == pids_.end()) return -1;
  double cpu_s = 0;
  std::string comm;
  return ReadStat("/proc/" + std::to_string(it->second) + "/stat", cpu_s, comm) ? cpu_s : -1;
}

std::vector<UnitLauncher::ThreadStat> UnitLauncher::Threads(const std::string& name) const {
  std::vector<ThreadStat> threads;
  const auto it = pids_.find(name);
  if (it == pids_.end()) return threads;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/proc/" + std::to_string(it->second) + "/task", ec)) {
    ThreadStat t;
    if (ReadStat(e.path().string() + "/stat", t.cpu_s, t.name, &t.policy)) threads.push_back(t);
  }
  return threads;
}

std::map<std::string, double> UnitLauncher::ThreadCpuSeconds(const std::string& name) const {
  std::map<std::string, double> by_name;
  for (const auto& t : Threads(name)) by_name[t.name] += t.cpu_s;
  return by_name;
}

std::map<std::string, int> UnitLauncher::ThreadPolicies(const std::string& name) const {
  std::map<std::string, int> by_name;
  for (const auto& t : Threads(name)) by_name[t.name] = t.policy;
  return by_name;
}

std::string UnitLauncher::AllowedCpus(const std::string& name) const {
  const auto it = pids_.find(name);
  if (it == pids_.end()) return "";
  std::ifstream in("/proc/" + std::to_string(it->second) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Cpus_allowed_list:", 0) == 0) {
      const auto v = line.find_first_not_of(" \t", line.find(':') + 1);
      return v == std::string::npos ? "" : line.substr(v);
    }
  }
  return "";
}

const NotifySeen& UnitLauncher::Seen(const std::string& name) const {
  static const NotifySeen kNone{};
  const auto it = seen_.find(name);
  return it == seen_.end() ? kNone : it->second;
}

std::vector<std::string> UnitLauncher::Names() const {
  std::vector<std::string> names;
  for (const auto& [n, s] : sockets_) names.push_back(n);
  return names;
}

}  // namespace hexa::deploy
