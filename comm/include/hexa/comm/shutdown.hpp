// Clean shutdown on SIGINT / SIGTERM. The signal handler only does async-signal-safe things:
// it records the signal number in a lock-free atomic and write()s to an eventfd. A watcher
// thread blocked in read() on that eventfd then sets a DDS guard condition, which wakes
// every WaitSet it is attached to: a service blocked in dds_waitset_wait returns at once and
// leaves its loop. No polling. A second SIGINT / SIGTERM while the first is being handled
// ends the process at once (_exit(128 + signal)) so a hung service can still be stopped.
//
// One ShutdownGuard may exist at a time (signal dispositions are per process). Declare it
// after the Participant and before the WaitSets that attach guard_condition().
#pragma once

#include <dds/dds.h>

#include <atomic>
#include <thread>

#include "hexa/comm/participant.hpp"
#include "hexa/comm/waitset.hpp"

namespace hexa::comm {

class ShutdownGuard {
 public:
  // Installs the handlers (restored by the destructor). Throws std::runtime_error if another
  // ShutdownGuard is alive or the eventfd / sigaction fails.
  explicit ShutdownGuard(const Participant& participant);
  ~ShutdownGuard();
  ShutdownGuard(const ShutdownGuard&) = delete;
  ShutdownGuard& operator=(const ShutdownGuard&) = delete;

  // Attach this to every WaitSet of the service.
  dds_entity_t guard_condition() const { return guard_.get(); }
  // True once a signal arrived or RequestShutdown() was called.
  bool requested() const;
  // The signal that asked for shutdown (SIGINT, SIGTERM), 0 if none / programmatic.
  int signal_number() const;
  // Programmatic shutdown (e.g. an OPERATOR_SHUTDOWN command); safe from any normal thread.
  void RequestShutdown();

 private:
  void WatchLoop();

  GuardCondition guard_;
  int event_fd_ = -1;
  std::atomic<bool> requested_{false};
  std::atomic<bool> stopping_{false};
  std::thread watcher_;
};

}  // namespace hexa::comm
