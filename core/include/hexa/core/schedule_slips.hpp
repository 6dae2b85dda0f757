#pragma once
// Accounting of a real-time loop's schedule slips (docs/measurements/deployment_lapses.md, "Where
// the lapses' milliseconds go"): every wake-up later than the threshold is a slip; the record keeps
// their count, total and worst lateness and, for the first kKept of them, the tick and the
// lateness, so that a fault at some tick can be matched to the stall before it. Pure: the caller
// measures the lateness; fixed storage, no allocation (it runs inside the 1 ms cycle).
#include <array>
#include <cstddef>
#include <cstdint>

namespace hexa::core {

class ScheduleSlips {
 public:
  static constexpr std::size_t kKept = 64;
  struct Slip {
    std::uint64_t tick = 0;
    std::int64_t late_ns = 0;
  };

  explicit ScheduleSlips(std::int64_t threshold_ns) : threshold_ns_(threshold_ns) {}

  // One wake-up, `late_ns` after its scheduled time, at `tick`. True if it is a slip (later
  // than the threshold).
  bool Record(std::uint64_t tick, std::int64_t late_ns) {
    if (late_ns <= threshold_ns_) return false;
    if (count_ < kKept) kept_[count_] = Slip{tick, late_ns};
    ++count_;
    total_ns_ += late_ns;
    if (late_ns > worst_.late_ns) worst_ = Slip{tick, late_ns};
    return true;
  }

  std::int64_t threshold_ns() const { return threshold_ns_; }
  std::uint64_t count() const { return count_; }
  std::int64_t total_ns() const { return total_ns_; }
  // The worst slip: tick 0 and 0 ns while there was none.
  Slip worst() const { return worst_; }
  // The first min(count, kKept) slips, in order.
  std::size_t kept_count() const { return count_ < kKept ? static_cast<std::size_t>(count_) : kKept; }
  const Slip& kept(std::size_t i) const { return kept_[i]; }

 private:
  std::int64_t threshold_ns_;
  std::uint64_t count_ = 0;
  std::int64_t total_ns_ = 0;
  Slip worst_{};
  std::array<Slip, kKept> kept_{};
};

}  // namespace hexa::core
