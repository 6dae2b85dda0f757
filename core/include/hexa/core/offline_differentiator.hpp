// The Gaussian-weighted differentiator of eq 40/41 applied offline to a whole recording
// (identification, docs/identification.md): the window is centred on the sample (zero
// phase, c of eq 40 at the window centre) and may be wider than the controller's 32.
//
// It is a linear filter D exact on straight lines, and it equals a smoothing S of the true
// derivative: D[x] = S[x'], where S weighs the derivative's mean over each sample interval
// (weights >= 0, sum 1; derivation in docs/identification.md). Applying S to the model's
// right-hand side makes the equation-error residual D[y] - S[f(x)] consistent: zero for
// noise-free data and the true parameters, up to the quadrature of the interval means (a
// fourth-order four-point rule), whatever the window.
//
// Setup may allocate; the filter calls write into caller-sized vectors.
#pragma once

#include <vector>

namespace hexa {

struct OfflineDifferentiatorParams {
  int window = 41;     // N, samples, odd (centred)
  double sigma = 6.0;  // standard deviation of w(x) of eq 41, samples
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

class OfflineGaussianDifferentiator {
 public:
  OfflineGaussianDifferentiator(const OfflineDifferentiatorParams& params, double period_s);

  // out[n] = D[x] at sample n (1/s units of x); NaN within half a window of either end or
  // where the window holds a NaN. out is resized to x.size().
  void Derivative(const std::vector<double>& x, std::vector<double>& out) const;
  // out[n] = S[f] at sample n: the interval weights applied to the means of f over the
  // intervals (four-point rule; NaN within half a window + 1 of either end).
  // NaN where D is.
  void Smooth(const std::vector<double>& f, std::vector<double>& out) const;

  // S applied twice as one centred kernel (2 half + 3 taps on each side of the sample:
  // index 2 half + 2 is the sample itself): what x'' = D[D[x]] smooths x'' with.
  std::vector<double> DoubleSmoothingKernel() const;
  // S of a product g x' from the sample values of g and the position differences:
  // sum_j w_j (g_a + g_b) / 2 (x_b - x_a) / h over the window's intervals (a, b). Exact for
  // g constant on each interval, whatever x does between samples. NaN where S is.
  void SmoothTimesDerivative(const std::vector<double>& g, const std::vector<double>& x,
                             std::vector<double>& out) const;

  int half_window() const { return half_; }
  // Standard deviation of D[x] for white noise of unit standard deviation on x (1/s).
  double NoiseGain() const;
  const std::vector<double>& coefficients() const { return coeff_; }       // k = 0 newest
  const std::vector<double>& interval_weights() const { return weight_; }  // sum 1
  // Smooth's per-sample weights, for samples m - half - 1 .. m + half + 1.
  const std::vector<double>& sample_weights() const { return sample_weight_; }

 private:
  int half_ = 20;
  double period_s_ = 0.001;
  std::vector<double> coeff_;   // N: D x_m = sum_k coeff_[k] x_{m + half - k}
  std::vector<double> weight_;  // N - 1: interval j = [m+h-j-1, m+h-j], mean of f' there
  std::vector<double> sample_weight_;  // N + 2: S f_m = sum_i w_i f_{m-h-1+i}
};

}  // namespace hexa
