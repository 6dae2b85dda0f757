#include "process_group.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace hexa::deploy {

std::string ChildExit::Describe() const {
  if (signal != 0) return name + " (pid " + std::to_string(pid) + ") killed by signal " +
                          std::to_string(signal) + " (" + strsignal(signal) + ")";
  return name + " (pid " + std::to_string(pid) + ") exited with code " +
         std::to_string(exit_code);
}

ProcessGroup::ProcessGroup() : old_mask_(new sigset_t) {
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGCHLD);
  sigaddset(&mask, SIGINT);
  sigaddset(&mask, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &mask, old_mask_);
}

ProcessGroup::~ProcessGroup() {
  StopAll(std::chrono::milliseconds(2000));
  pthread_sigmask(SIG_SETMASK, old_mask_, nullptr);
  delete old_mask_;
}

pid_t ProcessGroup::Start(const ChildSpec& spec, std::string& error) {
  if (spec.argv.empty()) {
    error = spec.name + ": empty command line";
    return -1;
  }
  if (access(spec.argv[0].c_str(), X_OK) != 0) {
    error = spec.name + ": cannot execute '" + spec.argv[0] + "': " + std::strerror(errno);
    return -1;
  }
  int log_fd = -1;
  if (!spec.log_path.empty()) {
    log_fd = open(spec.log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (log_fd < 0) {
      error = spec.name + ": cannot open log '" + spec.log_path + "': " + std::strerror(errno);
      return -1;
    }
  }
  // Everything the child needs is prepared before fork: after fork only
  // async-signal-safe calls are made.
  std::vector<char*> argv;
  for (const auto& a : spec.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    std::string entry = *e;
    const std::string key = entry.substr(0, entry.find('='));
    if (spec.env.count(key) == 0) env_strings.push_back(entry);
  }
  for (const auto& [k, v] : spec.env) env_strings.push_back(k + "=" + v);
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  const pid_t parent = getpid();
  cpu_set_t cpu_set;
  CPU_ZERO(&cpu_set);
  for (int cpu : spec.cpus) {
    if (cpu < 0 || cpu >= CPU_SETSIZE) {
      error = spec.name + ": CPU " + std::to_string(cpu) + " out of range";
      if (log_fd >= 0) close(log_fd);
      return -1;
    }
    CPU_SET(cpu, &cpu_set);
  }
  static constexpr char kAffinityFailed[] = "process_group: sched_setaffinity failed\n";

  const pid_t pid = fork();
  if (pid < 0) {
    error = spec.name + ": fork failed: " + std::strerror(errno);
    if (log_fd >= 0) close(log_fd);
    return -1;
  }
  if (pid == 0) {
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);  // the parent died before prctl took effect
    sigset_t empty;
    sigemptyset(&empty);
    sigprocmask(SIG_SETMASK, &empty, nullptr);
    // An ignored SIGPIPE (the launcher ignores it) would be inherited across execve.
    struct sigaction default_action {};
    default_action.sa_handler = SIG_DFL;
    sigaction(SIGPIPE, &default_action, nullptr);
    if (log_fd >= 0) {
      dup2(log_fd, STDOUT_FILENO);
      dup2(log_fd, STDERR_FILENO);
    }
    if (!spec.cpus.empty() && sched_setaffinity(0, sizeof cpu_set, &cpu_set) != 0) {
      (void)!write(STDERR_FILENO, kAffinityFailed, sizeof kAffinityFailed - 1);
      _exit(126);
    }
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  setpgid(pid, pid);  // also from the parent, to close the race with kill(-pgid)
  if (log_fd >= 0) close(log_fd);
  running_.push_back(Child{spec, pid});
  return pid;
}

std::optional<ChildExit> ProcessGroup::Reap(pid_t pid, bool block) {
  int status = 0;
  rusage usage{};
  const pid_t r = wait4(pid, &status, block ? 0 : WNOHANG, &usage);
  if (r != pid) return std::nullopt;
  auto it = std::find_if(running_.begin(), running_.end(),
                         [pid](const Child& c) { return c.pid == pid; });
  ChildExit exit;
  exit.pid = pid;
  if (it != running_.end()) {
    exit.name = it->spec.name;
    running_.erase(it);
  }
  if (WIFSIGNALED(status)) exit.signal = WTERMSIG(status);
  else exit.exit_code = WEXITSTATUS(status);
  exit.cpu_user_s = static_cast<double>(usage.ru_utime.tv_sec) + usage.ru_utime.tv_usec * 1e-6;
  exit.cpu_system_s = static_cast<double>(usage.ru_stime.tv_sec) + usage.ru_stime.tv_usec * 1e-6;
  exit.max_rss_kb = usage.ru_maxrss;
  return exit;
}

ProcessGroup::Event ProcessGroup::WaitEvent(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    for (const auto& c : std::vector<Child>(running_)) {
      if (auto e = Reap(c.pid, false)) {
        Event ev;
        ev.kind = Event::kChildExited;
        ev.exit = *e;
        return ev;
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return Event{};
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - now);
    timespec ts{static_cast<time_t>(left.count() / 1000000000),
                static_cast<long>(left.count() % 1000000000)};
    sigset_t mask;
    sigemptyset(&mask);
    sigaddset(&mask, SIGCHLD);
    sigaddset(&mask, SIGINT);
    sigaddset(&mask, SIGTERM);
    const int sig = sigtimedwait(&mask, nullptr, &ts);
    if (sig == SIGINT || sig == SIGTERM) {
      Event ev;
      ev.kind = Event::kInterrupted;
      ev.signal = sig;
      return ev;
    }
    // SIGCHLD, timeout or EINTR: loop and reap.
  }
}

std::optional<ChildExit> ProcessGroup::Stop(const std::string& name,
                                            std::chrono::milliseconds grace) {
  std::vector<ChildExit> exits = StopTogether({name}, grace);
  if (exits.empty()) return std::nullopt;
  return exits.front();
}

std::vector<ChildExit> ProcessGroup::StopAll(std::chrono::milliseconds grace) {
  std::vector<ChildExit> exits;
  while (!running_.empty()) {
    const std::string name = running_.back().spec.name;
    if (auto e = Stop(name, grace)) exits.push_back(*e);
  }
  return exits;
}

std::vector<ChildExit> ProcessGroup::StopTogether(const std::vector<std::string>& names,
                                                  std::chrono::milliseconds grace) {
  std::vector<pid_t> pids;
  for (const auto& name : names) {
    auto it = std::find_if(running_.begin(), running_.end(),
                           [&](const Child& c) { return c.spec.name == name; });
    if (it == running_.end()) continue;
    pids.push_back(it->pid);
    kill(it->pid, SIGTERM);
  }
  std::map<pid_t, ChildExit> done;
  const auto deadline = std::chrono::steady_clock::now() + grace;
  sigset_t chld;
  sigemptyset(&chld);
  sigaddset(&chld, SIGCHLD);
  while (done.size() < pids.size()) {
    for (pid_t pid : pids) {
      if (done.count(pid) == 0) {
        if (auto e = Reap(pid, false)) done.emplace(pid, *e);
      }
    }
    if (done.size() == pids.size()) break;
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) break;
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - now);
    timespec ts{static_cast<time_t>(left.count() / 1000000000),
                static_cast<long>(left.count() % 1000000000)};
    sigtimedwait(&chld, nullptr, &ts);  // wakes on any child's exit; SIGINT stays pending
  }
  std::vector<ChildExit> exits;
  for (pid_t pid : pids) {
    if (done.count(pid) == 0) {
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      if (auto e = Reap(pid, true)) done.emplace(pid, *e);
    }
    if (done.count(pid)) exits.push_back(done.at(pid));
  }
  return exits;
}

bool ProcessGroup::Running(const std::string& name) const {
  return std::any_of(running_.begin(), running_.end(),
                     [&](const Child& c) { return c.spec.name == name; });
}

std::vector<std::string> ProcessGroup::RunningNames() const {
  std::vector<std::string> names;
  for (const auto& c : running_) names.push_back(c.spec.name);
  return names;
}

}  // namespace hexa::deploy
