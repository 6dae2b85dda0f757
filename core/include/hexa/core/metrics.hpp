// Figures of merit of a session (paper Sec. 4, Tables 9 and 10): RMSE per task-space axis
// and relative error, leg-length RMSE, latency statistics. Offline analysis: these
// accumulate freely (not used inside the 1 ms cycle).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "hexa/core/pose.hpp"

namespace hexa {

// Accumulates desired and actual [x y z roll pitch yaw] samples (m, rad) and reports per
// axis RMSE and relative error. The paper does not define its "relative error" and its
// Table 9 / 10 figures match no single definition; we use RMSE divided by the desired
// motion's peak-to-peak range on that axis (docs/measurements/results.md).
class AxisErrorAccumulator {
 public:
  void Add(const Vector6d& desired, const Vector6d& actual);
  std::size_t count() const { return count_; }
  std::array<double, 6> Rmse() const;
  std::array<double, 6> PeakToPeak() const;        // of the desired motion
  // RMSE / peak-to-peak; a negative value means "no motion on this axis" (undefined).
  std::array<double, 6> RelativeError(double min_range_m = 1e-3,
                                      double min_range_rad = 1e-3) const;

 private:
  std::size_t count_ = 0;
  std::array<double, 6> sum_sq_{};
  std::array<double, 6> min_{};
  std::array<double, 6> max_{};
};

class ScalarErrorAccumulator {
 public:
  void Add(double desired, double actual);
  std::size_t count() const { return count_; }
  double Rmse() const;
  double MaxAbs() const { return max_abs_; }

 private:
  std::size_t count_ = 0;
  double sum_sq_ = 0.0;
  double max_abs_ = 0.0;
};

struct Percentiles {
  std::size_t count = 0;
  double median = 0.0;
  double p99 = 0.0;
  double max = 0.0;
};
// Nearest-rank percentiles; the input is copied and sorted.
Percentiles ComputePercentiles(std::vector<double> values);

}  // namespace hexa
