#include "realtime_clock.hpp"

#include "hexa/services/node.hpp"

namespace hexa::plant_sim {

void RealtimeClock::Start() { clock_gettime(CLOCK_MONOTONIC, &next_); }

void RealtimeClock::SleepUntilNext() {
  next_.tv_nsec += period_ns_;
  while (next_.tv_nsec >= 1'000'000'000) {
    next_.tv_nsec -= 1'000'000'000;
    ++next_.tv_sec;
  }
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next_, nullptr);
}

RealtimeClock::Wake RealtimeClock::Measure(std::uint64_t tick) {
  Wake w;
  w.late_ns = node::MonotonicNow_ns() -
              (static_cast<std::int64_t>(next_.tv_sec) * 1'000'000'000 + next_.tv_nsec);
  if (w.late_ns > period_ns_) ++overruns_;
  w.slipped = slips_.Record(tick, w.late_ns);
  if (w.slipped) clock_gettime(CLOCK_MONOTONIC, &next_);
  return w;
}

}  // namespace hexa::plant_sim
