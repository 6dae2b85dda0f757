#include "hexa/comm/shutdown.hpp"

#include <errno.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hexa::comm {
namespace {

// The one piece of process-wide mutable state this layer has: a signal handler cannot be
// given a context pointer, so the eventfd and the received signal live here. Lock-free
// atomics are async-signal-safe (checked below); only one ShutdownGuard owns them at a time.
std::atomic<int> g_wake_fd{-1};
std::atomic<int> g_signal{0};
std::atomic<bool> g_guard_alive{false};
static_assert(std::atomic<int>::is_always_lock_free);

struct sigaction g_previous_int;
struct sigaction g_previous_term;

extern "C" void OnShutdownSignal(int signo) {
  const int saved_errno = errno;
  int expected = 0;
  if (!g_signal.compare_exchange_strong(expected, signo)) {
    _exit(128 + signo);  // second signal: the first one has not brought the process down
  }
  const int fd = g_wake_fd.load();
  if (fd >= 0) {
    const uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = write(fd, &one, sizeof one);
  }
  errno = saved_errno;
}

}  // namespace

ShutdownGuard::ShutdownGuard(const Participant& participant) : guard_(participant) {
  bool expected = false;
  if (!g_guard_alive.compare_exchange_strong(expected, true)) {
    throw std::runtime_error("ShutdownGuard: only one may exist per process");
  }
  event_fd_ = eventfd(0, EFD_CLOEXEC);
  if (event_fd_ < 0) {
    g_guard_alive.store(false);
    throw std::runtime_error(std::string("ShutdownGuard: eventfd failed: ") + std::strerror(errno));
  }
  g_signal.store(0);
  g_wake_fd.store(event_fd_);
  watcher_ = std::thread([this] { WatchLoop(); });

  struct sigaction action {};
  action.sa_handler = OnShutdownSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  if (sigaction(SIGINT, &action, &g_previous_int) != 0 ||
      sigaction(SIGTERM, &action, &g_previous_term) != 0) {
    const int err = errno;
    stopping_.store(true);
    const uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = write(event_fd_, &one, sizeof one);
    watcher_.join();
    close(event_fd_);
    g_wake_fd.store(-1);
    g_guard_alive.store(false);
    throw std::runtime_error(std::string("ShutdownGuard: sigaction failed: ") + std::strerror(err));
  }
}

ShutdownGuard::~ShutdownGuard() {
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
  stopping_.store(true);
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = write(event_fd_, &one, sizeof one);
  watcher_.join();
  g_wake_fd.store(-1);
  close(event_fd_);
  g_guard_alive.store(false);
}

void ShutdownGuard::WatchLoop() {
  for (;;) {
    uint64_t value = 0;
    const ssize_t n = read(event_fd_, &value, sizeof value);
    if (n < 0 && errno == EINTR) continue;
    if (g_signal.load() != 0) {
      requested_.store(true);
      guard_.Set(true);
    }
    if (stopping_.load() || n < 0) return;
  }
}

bool ShutdownGuard::requested() const { return requested_.load(); }

int ShutdownGuard::signal_number() const { return g_signal.load(); }

void ShutdownGuard::RequestShutdown() {
  requested_.store(true);
  guard_.Set(true);
}

}  // namespace hexa::comm
