#include "hexa/core/metrics.hpp"

#include <algorithm>
#include <cmath>

namespace hexa {

void AxisErrorAccumulator::Add(const Vector6d& desired, const Vector6d& actual) {
  for (int i = 0; i < 6; ++i) {
    const double e = desired[i] - actual[i];
    sum_sq_[i] += e * e;
    if (count_ == 0) {
      min_[i] = max_[i] = desired[i];
    } else {
      min_[i] = std::min(min_[i], desired[i]);
      max_[i] = std::max(max_[i], desired[i]);
    }
  }
  ++count_;
}

std::array<double, 6> AxisErrorAccumulator::Rmse() const {
  std::array<double, 6> r{};
  if (count_ == 0) return r;
  for (int i = 0; i < 6; ++i) r[i] = std::sqrt(sum_sq_[i] / static_cast<double>(count_));
  return r;
}

std::array<double, 6> AxisErrorAccumulator::PeakToPeak() const {
  std::array<double, 6> r{};
  if (count_ == 0) return r;
  for (int i = 0; i < 6; ++i) r[i] = max_[i] - min_[i];
  return r;
}

std::array<double, 6> AxisErrorAccumulator::RelativeError(double min_range_m,
                                                          double min_range_rad) const {
  const auto rmse = Rmse();
  const auto range = PeakToPeak();
  std::array<double, 6> r{};
  for (int i = 0; i < 6; ++i) {
    const double min_range = i < 3 ? min_range_m : min_range_rad;
    r[i] = range[i] >= min_range ? rmse[i] / range[i] : -1.0;
  }
  return r;
}

void ScalarErrorAccumulator::Add(double desired, double actual) {
  const double e = desired - actual;
  sum_sq_ += e * e;
  max_abs_ = std::max(max_abs_, std::abs(e));
  ++count_;
}

double ScalarErrorAccumulator::Rmse() const {
  return count_ == 0 ? 0.0 : std::sqrt(sum_sq_ / static_cast<double>(count_));
}

Percentiles ComputePercentiles(std::vector<double> values) {
  Percentiles p;
  p.count = values.size();
  if (values.empty()) return p;
  std::sort(values.begin(), values.end());
  auto rank = [&](double q) {
    const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
    return values[std::min(values.size() - 1, k == 0 ? 0 : k - 1)];
  };
  p.median = rank(0.5);
  p.p99 = rank(0.99);
  p.max = values.back();
  return p;
}

}  // namespace hexa
