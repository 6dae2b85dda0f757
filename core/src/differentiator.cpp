#include "hexa/core/differentiator.hpp"

#include "hexa/core/param_checks.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hexa {

void DifferentiatorConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckDifferentiatorParams(c, params, "differentiator");
  c.Positive("sample_period_s", sample_period_s, "sample period");
  ThrowIfIssues(issues, "DifferentiatorConfig");
}

void GaussianDifferentiatorCoefficients(int samples, double sigma, double lag, double period_s,
                                        double* coefficient) {
  // Sample k (0 = newest) sits at time -k h. Pair (older a, newer b), a > b:
  // midpoint -(a + b) / 2, baseline (a - b) h. Eq 41's normalising constant cancels in the
  // weighted mean, so only the exponential is kept.
  const int n = samples - 1;
  for (int k = 0; k <= n; ++k) coefficient[k] = 0.0;
  double weight_sum = 0.0;
  for (int a = 1; a <= n; ++a) {
    for (int b = 0; b < a; ++b) {
      const double offset = -0.5 * (a + b) + lag;  // midpoint - c, in samples
      const double w = std::exp(-offset * offset / (2.0 * sigma * sigma));  // eq 41
      const double inv_dt = 1.0 / ((a - b) * period_s);
      coefficient[b] += w * inv_dt;  // eq 40: w (x_j - x_i) / (t_j - t_i), x_j the newer
      coefficient[a] -= w * inv_dt;
      weight_sum += w;
    }
  }
  // weight_sum > 0 always: a Gaussian is positive (it can underflow only for absurd lags,
  // excluded by the callers' validation).
  for (int k = 0; k <= n; ++k) coefficient[k] /= weight_sum;
}

GaussianDifferentiator::GaussianDifferentiator(const DifferentiatorConfig& config) {
  config.Validate();
  window_ = config.params.window;
  period_s_ = config.sample_period_s;
  const double sigma = config.params.sigma;
  const double lag = config.params.centre_lag_samples;
  for (int n = 1; n < window_; ++n) {  // n + 1 samples held
    GaussianDifferentiatorCoefficients(n + 1, sigma, lag, period_s_, coeff_[n].data());
  }
  Reset();
}

void GaussianDifferentiator::Reset() {
  ring_.fill(0.0);
  newest_ = -1;
  fill_ = 0;
}

double GaussianDifferentiator::Update(double value) {
  newest_ = (newest_ + 1) % window_;
  ring_[newest_] = value;
  if (fill_ < window_) ++fill_;
  if (fill_ < 2) return 0.0;
  const auto& c = coeff_[fill_ - 1];
  double sum = 0.0;
  int idx = newest_;
  for (int k = 0; k < fill_; ++k) {
    sum += c[k] * ring_[idx];
    idx = (idx == 0) ? window_ - 1 : idx - 1;
  }
  return sum;
}

double GaussianDifferentiator::coefficient(int k) const {
  if (k < 0 || k >= window_) return 0.0;
  return coeff_[window_ - 1][k];
}

double GaussianDifferentiator::GroupDelaySamples() const {
  // For x = (k h)^2 sampled at t = -k h: estimate = h^2 sum c_k k^2 = 2 (0 - d h)
  // (sum c_k = 0 and sum c_k (-k h) = 1 by exactness on lines).
  double s = 0.0;
  for (int k = 0; k < window_; ++k) s += coeff_[window_ - 1][k] * k * k;
  return -s * period_s_ / 2.0;
}

double GaussianDifferentiator::NoiseGain() const {
  double s = 0.0;
  for (int k = 0; k < window_; ++k) s += coeff_[window_ - 1][k] * coeff_[window_ - 1][k];
  return std::sqrt(s);
}

}  // namespace hexa
