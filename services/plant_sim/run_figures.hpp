// The plant's figures of a run: command ages at apply, tick durations, and the JSON summary.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "hexa/core/rig.hpp"

namespace hexa::plant_sim {

// Age of the command the plant applied at a tick, in ticks (tick - answered tick; 0 = the
// command answered the sensors of this tick), per leg. Real time: a command older than the
// sensor sample just before it (age >= 1) arrived too late for its tick: a late tick.
struct CommandAgeHistogram {
  static constexpr int kBins = 6;  // 0, 1, 2, 3-7, 8-15, >= 16
  std::array<std::uint64_t, kBins> bins{};
  std::uint64_t none = 0;          // no command yet
  void Add(std::int64_t age_ticks);
  std::uint64_t late() const;      // age >= 1
  std::uint64_t total() const;
};

// Distribution of a duration (a lockstep tick's wall time; the real-time wake-up lateness)
// over a whole run, in 10 us bins up to 100 ms: allocation-free after construction.
class DurationHistogram {
 public:
  static constexpr std::int64_t kBinNs = 10'000;
  static constexpr std::size_t kBins = 10'000;
  void Add(std::int64_t duration_ns);
  std::uint64_t count() const { return count_; }
  // Upper edge of the bin holding the q-quantile (0 < q <= 1), in seconds; 0 when empty.
  double Quantile_s(double q) const;
  double max_s() const { return static_cast<double>(max_ns_) * 1e-9; }
  double mean_s() const { return count_ == 0 ? 0.0 : sum_s_ / static_cast<double>(count_); }

 private:
  std::array<std::uint32_t, kBins + 1> bins_{};  // the last one: beyond 100 ms
  std::uint64_t count_ = 0;
  std::int64_t max_ns_ = 0;
  double sum_s_ = 0.0;
};

// The figures of one run that the plant reports at its end (log and --summary JSON).
struct RunFigures {
  LegArray<CommandAgeHistogram> command_age{};
  DurationHistogram tick_wall;  // lockstep: publish -> complete; real time: wake-up lateness
  std::int64_t loop_started_ns = 0;
  std::int64_t loop_ended_ns = 0;
  std::uint64_t resent_samples = 0;  // lockstep: sensor samples re-published to silent legs
};

}  // namespace hexa::plant_sim
