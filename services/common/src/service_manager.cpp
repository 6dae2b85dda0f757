#include "hexa/services/service_manager.hpp"

#include <systemd/sd-daemon.h>
#include <time.h>

#include <atomic>
#include <cstdio>

namespace hexa::node::service_manager {
namespace {

std::int64_t MonotonicNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Written once by Ready() before the loop starts; the loop may ping from another thread
// (Cyclone's receive thread): relaxed atomics, a ping more or less does not matter.
std::atomic<std::int64_t> g_interval_ns{0};
std::atomic<std::int64_t> g_next_ping_ns{0};

}  // namespace

void Ready(const char* status) {
  std::uint64_t usec = 0;
  // 0 = unset, > 0 = enabled (and WATCHDOG_PID, if set, is this process).
  if (sd_watchdog_enabled(0, &usec) > 0) {
    g_interval_ns.store(static_cast<std::int64_t>(usec) * 1000, std::memory_order_relaxed);
    g_next_ping_ns.store(MonotonicNs(), std::memory_order_relaxed);
  }
  sd_notifyf(0, "READY=1\nSTATUS=%s", status);
  Watchdog();
}

void Watchdog() {
  const std::int64_t interval = g_interval_ns.load(std::memory_order_relaxed);
  if (interval <= 0) return;
  const std::int64_t now = MonotonicNs();
  if (now < g_next_ping_ns.load(std::memory_order_relaxed)) return;
  g_next_ping_ns.store(now + interval / 2, std::memory_order_relaxed);
  sd_notify(0, "WATCHDOG=1");
}

bool WatchdogDue() {
  const std::int64_t interval = g_interval_ns.load(std::memory_order_relaxed);
  return interval > 0 && MonotonicNs() >= g_next_ping_ns.load(std::memory_order_relaxed);
}

void Stopping(const char* status) { sd_notifyf(0, "STOPPING=1\nSTATUS=%s", status); }

std::int64_t WatchdogInterval_ns() { return g_interval_ns.load(std::memory_order_relaxed); }

}  // namespace hexa::node::service_manager
