// The plant's real-time clock: a 1 ms schedule on CLOCK_MONOTONIC (absolute wake-ups, so that
// a late tick does not shift the ones after it) and its slips. A wake-up later than
// slip_after_ns is a slip: the host stalled this process (and, on one machine, the
// controllers with it). The simulated rig stops with it: the schedule restarts from now
// instead of stepping the missed ticks in a burst that no controller could answer (their
// commands would all look stale: a fault of the simulation, not of the controllers). A real
// rig does not stop; docs/performance.md says what this hides and how often it happens.
// Every slip is kept with its tick (core::ScheduleSlips), so that a lapse can be matched to
// the stall before it. Used by the loop's thread only.
#pragma once

#include <time.h>

#include <cstdint>

#include "hexa/core/schedule_slips.hpp"

namespace hexa::plant_sim {

class RealtimeClock {
 public:
  struct Wake {
    std::int64_t late_ns = 0;  // how much later than scheduled this wake-up came
    bool slipped = false;      // later than the slip threshold: the schedule restarted
  };

  explicit RealtimeClock(std::int64_t period_ns = 1'000'000, std::int64_t slip_after_ns = 2'000'000)
      : period_ns_(period_ns), slips_(slip_after_ns) {}

  void Start();  // the schedule begins now
  void SleepUntilNext();  // until the next tick's scheduled time
  // At `tick`, once the tick's inputs are taken: how late the tick runs against its scheduled
  // time; a slip restarts the schedule from now.
  Wake Measure(std::uint64_t tick);

  std::uint32_t overruns() const { return overruns_; }  // wake-ups more than a period late
  const core::ScheduleSlips& slips() const { return slips_; }

 private:
  std::int64_t period_ns_;
  timespec next_{};
  core::ScheduleSlips slips_;
  std::uint32_t overruns_ = 0;
};

}  // namespace hexa::plant_sim
