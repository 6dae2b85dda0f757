// Valve command hygiene (docs/design.md "Safety"): what the plant (or a hardware I/O node) does
// with each leg's latest command before applying it. A command that is missing, stale, not
// finite or outside the valve's range is replaced by the null voltage (valve closed) and
// reported. Pure, no clock: ticks are arguments.
#pragma once

#include <array>
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
  // VM's scheduling jitter exceeds 1 ms (docs/platform_notes.md).
  std::uint64_t stale_tolerance_ticks = 0;
  // Before a leg's first command: how long (ticks from the start) it may take to come before
  // it is missing. Real time: the first answers of a starting loop are slow (page faults,
  // first allocations in DDS); the stale check is armed by the first command, not by the
  // clock. At least stale_tolerance_ticks.
  std::uint64_t startup_grace_ticks = 0;

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

bool IsCommandFault(CommandCheck check);  // not kOk and not kAwaitingFirst

// Fault episodes of one leg's commands, for reporting: one report when an episode starts, not
// one per tick (a controller writing NaN and 42 V in turn changes its check every tick). An
// episode starts at the first faulty check and ends after `clear_after_ok_ticks` good ones in
// a row (a command that flickers between good and bad stays one episode).
class CommandEpisode {
 public:
  enum class Event : std::uint8_t { kNone, kStarted, kEnded };
  CommandEpisode() = default;
  explicit CommandEpisode(std::uint64_t clear_after_ok_ticks)
      : clear_after_ok_ticks_(clear_after_ok_ticks) {}
  Event Update(CommandCheck check);
  bool active() const { return active_; }
  CommandCheck first() const { return first_; }     // the check that started the episode
  CommandCheck latest() const { return latest_; }   // the newest faulty check
  std::uint64_t fault_ticks() const { return fault_ticks_; }  // faulty ticks in the episode
  std::uint64_t episodes() const { return episodes_; }

 private:
  std::uint64_t clear_after_ok_ticks_ = 100;
  bool active_ = false;
  CommandCheck first_ = CommandCheck::kOk;
  CommandCheck latest_ = CommandCheck::kOk;
  std::uint64_t fault_ticks_ = 0;
  std::uint64_t ok_run_ = 0;
  std::uint64_t episodes_ = 0;
};

// The compute time a leg controller reports with each command (ValveCommand.compute_time_s)
// against a budget (docs/faults.md): an overrun episode starts when `overrun_limit` cycles in
// a row exceed the budget (a single long cycle is the host preempting the process, not a
// slow controller) and ends after `clear_after_ok` cycles in a row within it. Counts every
// cycle over budget.
struct ComputeBudgetParams {
  double budget_s = 0.0005;            // half the 1 ms tick: the rest is for the transport
  std::uint64_t overrun_limit = 20;    // consecutive cycles over budget
  std::uint64_t clear_after_ok = 100;
};

class ComputeBudgetMonitor {
 public:
  enum class Event : std::uint8_t { kNone, kStarted, kEnded };
  Event Update(double compute_s, const ComputeBudgetParams& params);
  bool active() const { return active_; }
  std::uint64_t cycles() const { return cycles_; }
  std::uint64_t over_budget() const { return over_budget_; }  // cycles over budget, all time
  double max_s() const { return max_s_; }
  double run_max_s() const { return run_max_s_; }             // largest in the current run over budget

 private:
  bool active_ = false;
  std::uint64_t cycles_ = 0, over_budget_ = 0, over_run_ = 0, ok_run_ = 0;
  double max_s_ = 0.0, run_max_s_ = 0.0;
};

// The compute budget of one leg judged per writer. A primary and its hot standby both write
// the leg's commands; judged as one stream, a slow primary's long cycles interleave with the
// standby's short ones and never make a run (real time: a slow primary with a standby went
// unreported for 1.5-2.3 s; docs/faults.md). Each writer's ticks count once, in its own order
// (a repeated or older tick of the same writer is not a new cycle). Fixed slots, no allocation:
// a writer beyond kSlots takes the slot heard from least recently. The totals (cycles, over
// budget, largest) are over every writer.
class WriterComputeBudgets {
 public:
  static constexpr std::size_t kSlots = 4;
  // `writer` identifies the writer (its DDS publication handle).
  ComputeBudgetMonitor::Event Update(std::uint64_t writer, std::uint64_t tick, double compute_s,
                                     const ComputeBudgetParams& params);
  // Largest compute time in the current over-budget run of the writer last updated.
  double last_run_max_s() const { return slots_[last_].monitor.run_max_s(); }
  std::uint64_t cycles() const { return cycles_; }
  std::uint64_t over_budget() const { return over_budget_; }
  double max_s() const { return max_s_; }

 private:
  struct Slot {
    bool used = false;
    std::uint64_t writer = 0;
    std::uint64_t last_tick = 0;
    std::uint64_t heard = 0;  // update count when last heard from
    ComputeBudgetMonitor monitor;
  };
  std::array<Slot, kSlots> slots_{};
  std::size_t last_ = 0;
  std::uint64_t updates_ = 0, cycles_ = 0, over_budget_ = 0;
  double max_s_ = 0.0;
};

}  // namespace hexa
