// Gaussian-weighted numerical differentiator (eq 40, 41), causal, for uniformly sampled
// signals. The estimate is a fixed linear filter over the last N samples:
//
//   xdot(t_n) = sum_{i<j} w(m_ij - c) (x_j - x_i) / (t_j - t_i)  /  sum_{i<j} w(m_ij - c)
//
// with m_ij = (t_i + t_j) / 2, w the Gaussian of eq 41 and c = t_n - centre_lag * h.
// Dividing by the weight sum (the paper's eq 40 does not) makes every pair's slope count
// as a weighted mean: the estimate is exact on a straight line (polynomials of degree <= 1),
// for any c, sigma and N. docs/controller.md gives its delay and noise gain.
//
// Fixed-size ring buffer, no allocation; Update neither throws nor allocates.
#pragma once

#include <array>
#include <cstddef>

#include "hexa/core/control_params.hpp"

namespace hexa {

struct DifferentiatorConfig {
  DifferentiatorParams params;
  double sample_period_s = 0.001;  // h: the samples are uniformly spaced
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

// Coefficients of eq 40/41 (normalised) for a window of `samples` uniformly spaced samples:
// estimate = sum_k coefficient[k] * x[newest - k], k = 0 .. samples-1 (k = 0 the newest),
// with the Gaussian centred `centre_lag_samples` before the newest sample. Writes `samples`
// values to `coefficient` (1/s). The one implementation of the weights, used by the causal
// controller filter below and by the offline (centred) filter of the identification.
void GaussianDifferentiatorCoefficients(int samples, double sigma_samples, double centre_lag_samples,
                                        double period_s, double* coefficient);

class GaussianDifferentiator {
 public:
  static constexpr int kMaxWindow = 32;

  // Validates the config (throws std::invalid_argument) and precomputes the weights.
  explicit GaussianDifferentiator(const DifferentiatorConfig& config = {});

  // Forget every sample (e.g. after a hold or a bad sensor sample).
  void Reset();

  // Push the newest sample and return the derivative estimate [unit/s] at its time, using
  // the samples held so far (0 until two samples are held). Never throws or allocates.
  double Update(double value);

  // Number of samples currently held (<= window).
  int fill() const { return fill_; }
  bool full() const { return fill_ == window_; }

  // Filter coefficients for a full window: estimate = sum_k coefficient(k) * x[n-k],
  // k = 0 newest. In 1/s.
  double coefficient(int k) const;

  // Low-frequency group delay of the estimate for a full window, in samples: for
  // x(t) = t^2 the estimate is 2 (t_n - delay * h). Computed from the coefficients.
  double GroupDelaySamples() const;

  // White-noise gain for a full window: std(estimate) = NoiseGain() * std(x), in 1/s.
  double NoiseGain() const;

 private:
  int window_ = 15;
  // coeff_[n][k]: coefficients when n + 1 samples are held (n = 1 .. window-1).
  std::array<std::array<double, kMaxWindow>, kMaxWindow> coeff_{};
  std::array<double, kMaxWindow> ring_{};
  int newest_ = -1;  // index of the newest sample in ring_
  int fill_ = 0;
  double period_s_ = 0.001;
};

}  // namespace hexa
