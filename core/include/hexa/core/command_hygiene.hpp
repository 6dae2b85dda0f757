// Valve command hygiene (DESIGN.md "Safety"): what the plant (or a hardware I/O node) does
// with each leg's latest command before applying it. A command that is missing, stale, not
// finite or outside the valve's range is replaced by the null voltage (valve closed) and
// reported. Pure, no clock: ticks are arguments.
#pragma once

#include <cstdint>

#include "hexa/core/rig.hpp"

namespace hexa {

enum class CommandCheck : std::uint8_t {
  kOk,
  kAwaitingFirst,  // no command yet, still within the tolerance after start: null, no fault
  kMissing,     // no command for this leg beyond the tolerance after start
  kStale,       // the command answers a tick older than the tolerance
  kNotFinite,   // NaN or infinite voltage
  kOutOfRange,  // outside [min_voltage_v, max_voltage_v]
};
const char* ToString(CommandCheck check);

struct CommandHygieneParams {
  double min_voltage_v = 0.0;
  double max_voltage_v = 10.0;
  double null_voltage_v = 5.0;
  // A command answering tick m is still usable at tick n when n - m <= this many ticks.
  // Lockstep: 0 (every tick is answered). Real time: a few ticks of tolerance because this
  // VM's scheduling jitter exceeds 1 ms (PLATFORM_NOTES.md).
  std::uint64_t stale_tolerance_ticks = 0;

  static CommandHygieneParams FromValve(const ValveParams& valve,
                                        std::uint64_t stale_tolerance_ticks);
};

struct LatestCommand {
  bool received = false;         // any command of this leg seen so far
  std::uint64_t answered_tick = 0;
  double valve_v = 0.0;
};

// Classifies the latest command of a leg at plant tick `current_tick`.
CommandCheck CheckCommand(const LatestCommand& command, std::uint64_t current_tick,
                          const CommandHygieneParams& params);

// The voltage to apply: the command when kOk, otherwise the null (closed) voltage.
double SafeValveVoltage(const LatestCommand& command, CommandCheck check,
                        const CommandHygieneParams& params);

}  // namespace hexa
