#include "run_figures.hpp"

#include <algorithm>
#include <cmath>

namespace hexa::plant_sim {

void CommandAgeHistogram::Add(std::int64_t age_ticks) {
  if (age_ticks < 0) {
    ++none;
    return;
  }
  const int bin = age_ticks <= 2 ? static_cast<int>(age_ticks) : (age_ticks < 8 ? 3 : (age_ticks < 16 ? 4 : 5));
  ++bins[static_cast<std::size_t>(bin)];
}

std::uint64_t CommandAgeHistogram::late() const {
  std::uint64_t n = 0;
  for (int k = 1; k < kBins; ++k) n += bins[static_cast<std::size_t>(k)];
  return n;
}

std::uint64_t CommandAgeHistogram::total() const { return bins[0] + late() + none; }

void DurationHistogram::Add(std::int64_t duration_ns) {
  const std::int64_t d = std::max<std::int64_t>(0, duration_ns);
  const std::size_t bin = std::min<std::size_t>(static_cast<std::size_t>(d / kBinNs), kBins);
  ++bins_[bin];
  ++count_;
  max_ns_ = std::max(max_ns_, d);
  sum_s_ += static_cast<double>(d) * 1e-9;
}

double DurationHistogram::Quantile_s(double q) const {
  if (count_ == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b <= kBins; ++b) {
    seen += bins_[b];
    if (seen >= rank) return b == kBins ? max_s() : static_cast<double>((b + 1) * kBinNs) * 1e-9;
  }
  return max_s();
}

}  // namespace hexa::plant_sim
