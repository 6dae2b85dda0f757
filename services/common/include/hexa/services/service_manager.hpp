// The systemd service-manager protocol (sd_notify, libsystemd): a unit of Type=notify learns
// that the node is RUNNING (READY=1), and with WatchdogSec= expects WATCHDOG=1 from the
// control loop at least once per interval, or systemd restarts the service: a hung control
// loop is restarted by systemd, not only noticed by the supervisor (docs/deployment.md).
//
// Outside systemd (no NOTIFY_SOCKET) every call is a no-op. The state is per process (the
// notification socket and the watchdog interval come from the environment systemd gives the
// process), hence free functions rather than an object each node would have to carry.
#pragma once

#include <cstdint>

namespace hexa::node::service_manager {

// READY=1 with STATUS=<status>: call when the node reports RUNNING. Also reads the watchdog
// interval (WATCHDOG_USEC) and arms Watchdog().
void Ready(const char* status);

// From the control loop, every cycle: sends WATCHDOG=1 when half the watchdog interval has
// passed since the last one. Otherwise one clock read and a compare (no system call).
void Watchdog();
// True when a WATCHDOG=1 is due (a thread that must first take the control lock to prove the
// loop is not stuck asks this, then takes the lock, then calls Watchdog()).
bool WatchdogDue();

// STOPPING=1 with STATUS=<status>: the node is shutting down on purpose.
void Stopping(const char* status);

// The watchdog interval systemd asked for, in ns (0 = none / not under systemd).
std::int64_t WatchdogInterval_ns();

}  // namespace hexa::node::service_manager
