// A helper process started by a test: fork + execve of tests/comm's helper binary, stdout on
// a pipe. The destructor kill()s it by PID (SIGKILL) and waitpid()s, so a failing assertion
// never leaves a process behind; PR_SET_PDEATHSIG kills it too if the test process dies.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hexa::comm::test {

class ChildProcess {
 public:
  // `env`: the complete environment of the child ("KEY=value"); built before fork because
  // only async-signal-safe calls are allowed between fork and exec in a threaded parent.
  ChildProcess(const std::string& path, const std::vector<std::string>& args,
               const std::vector<std::string>& env) {
    std::vector<std::string> argv_storage{path};
    argv_storage.insert(argv_storage.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& s : argv_storage) argv.push_back(s.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_storage = env;
    std::vector<char*> envp;
    for (std::string& s : env_storage) envp.push_back(s.data());
    envp.push_back(nullptr);
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(111);
      dup2(fds[1], STDOUT_FILENO);
      execve(argv[0], argv.data(), envp.data());
      _exit(112);
    }
    close(fds[1]);
    out_fd_ = fds[0];
  }
  ~ChildProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
    if (out_fd_ >= 0) close(out_fd_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  void Signal(int signo) {
    if (pid_ > 0 && !exited_) kill(pid_, signo);
  }

  // Reads stdout lines until one starts with `prefix` (returned) or `timeout` passes.
  std::optional<std::string> WaitForLine(const std::string& prefix,
                                         std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      for (std::size_t nl; (nl = buffer_.find('\n')) != std::string::npos;) {
        std::string line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        lines_.push_back(line);
        if (line.rfind(prefix, 0) == 0) return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd pfd{out_fd_, POLLIN, 0};
      if (poll(&pfd, 1, static_cast<int>(left.count())) <= 0) continue;
      char chunk[4096];
      const ssize_t n = read(out_fd_, chunk, sizeof chunk);
      if (n <= 0) return std::nullopt;  // EOF: the child closed stdout (exited)
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }

  // Every stdout line read so far plus whatever is still buffered (after exit).
  std::vector<std::string> AllLines() {
    WaitForLine("\x01never", std::chrono::milliseconds(0));
    char chunk[4096];
    for (;;) {
      pollfd pfd{out_fd_, POLLIN, 0};
      if (poll(&pfd, 1, 0) <= 0) break;
      const ssize_t n = read(out_fd_, chunk, sizeof chunk);
      if (n <= 0) break;
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
    WaitForLine("\x01never", std::chrono::milliseconds(0));
    return lines_;
  }

  // Waits for exit up to `timeout`; returns the raw waitpid status, nullopt if still running.
  // Bounded wait for a test (blocking waitpid with SIGCHLD would need a handler).
  std::optional<int> WaitExit(std::chrono::milliseconds timeout) {
    if (exited_) return status_;
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      int status = 0;
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exited_ = true;
        status_ = status;
        return status;
      }
      if (std::chrono::steady_clock::now() >= end) return std::nullopt;
      const timespec ts{0, 1000000};  // 1 ms
      nanosleep(&ts, nullptr);
    }
  }

 private:
  pid_t pid_ = -1;
  int out_fd_ = -1;
  bool exited_ = false;
  int status_ = 0;
  std::string buffer_;
  std::vector<std::string> lines_;
};

// The current environment without CYCLONEDDS_URI (so the child falls back on the built-in
// loopback default), optionally with extra entries.
inline std::vector<std::string> EnvironmentWithoutCycloneUri() {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::strncmp(*e, "CYCLONEDDS_URI=", 15) != 0) env.emplace_back(*e);
  }
  return env;
}

}  // namespace hexa::comm::test
