#include "hexa/core/offline_differentiator.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "hexa/core/differentiator.hpp"

namespace hexa {

void OfflineDifferentiatorParams::Validate() const {
  if (window < 3 || window > 1001 || window % 2 == 0) {
    std::ostringstream m;
    m << "offline differentiator: window = " << window << " must be odd and in [3, 1001]";
    throw std::invalid_argument(m.str());
  }
  if (!(sigma > 0.0) || !std::isfinite(sigma)) {
    std::ostringstream m;
    m << "offline differentiator: sigma = " << sigma << " must be finite and > 0 (samples)";
    throw std::invalid_argument(m.str());
  }
}

OfflineGaussianDifferentiator::OfflineGaussianDifferentiator(const OfflineDifferentiatorParams& p,
                                                             double period_s)
    : half_((p.window - 1) / 2), period_s_(period_s) {
  p.Validate();
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("offline differentiator: period_s must be finite and > 0");
  }
  coeff_.assign(static_cast<std::size_t>(p.window), 0.0);
  // Eq 40/41 with the Gaussian at the window centre: zero phase.
  GaussianDifferentiatorCoefficients(p.window, p.sigma, static_cast<double>(half_), period_s,
                                     coeff_.data());
  // sum_k c_k x_{n-k} = sum_j s_j (x_{n-j} - x_{n-j-1}),  s_j = sum_{k <= j} c_k  (sum c = 0):
  // each difference is h times the mean derivative over its interval, so the interval
  // weights are s_j h (they sum to 1: the filter is exact on lines).
  weight_.assign(coeff_.size() - 1, 0.0);
  double cumulative = 0.0;
  for (std::size_t j = 0; j + 1 < coeff_.size(); ++j) {
    cumulative += coeff_[j];
    weight_[j] = cumulative * period_s;
  }
  // Per-sample weights of S for samples m - half - 1 .. m + half + 1 (interval j runs from
  // sample m + half - j - 1 to m + half - j; its mean by the four-point rule).
  sample_weight_.assign(coeff_.size() + 2, 0.0);
  for (std::size_t j = 0; j < weight_.size(); ++j) {
    const std::size_t lo = coeff_.size() - 1 - j;  // index of the interval's older sample (+1 shift)
    sample_weight_[lo - 1] += -weight_[j] / 24.0;
    sample_weight_[lo] += 13.0 * weight_[j] / 24.0;
    sample_weight_[lo + 1] += 13.0 * weight_[j] / 24.0;
    sample_weight_[lo + 2] += -weight_[j] / 24.0;
  }
}

void OfflineGaussianDifferentiator::Derivative(const std::vector<double>& x,
                                               std::vector<double>& out) const {
  const std::size_t n = x.size();
  out.assign(n, std::numeric_limits<double>::quiet_NaN());
  const std::size_t h = static_cast<std::size_t>(half_);
  for (std::size_t m = h; m + h < n; ++m) {
    double sum = 0.0;
    const std::size_t newest = m + h;
    for (std::size_t k = 0; k < coeff_.size(); ++k) sum += coeff_[k] * x[newest - k];
    out[m] = sum;  // a NaN in the window propagates
  }
}

void OfflineGaussianDifferentiator::Smooth(const std::vector<double>& f,
                                           std::vector<double>& out) const {
  // The mean of f over interval [i, i+1] from the cubic through samples i-1 .. i+2:
  // (-f[i-1] + 13 f[i] + 13 f[i+1] - f[i+2]) / 24 (fourth order; the trapezoid rule's
  // second-order error is visible on the spool's 3 ms transients). Per-sample weights.
  const std::size_t n = f.size();
  out.assign(n, std::numeric_limits<double>::quiet_NaN());
  const std::size_t h = static_cast<std::size_t>(half_);
  for (std::size_t m = h + 1; m + h + 1 < n; ++m) {
    double sum = 0.0;
    const std::size_t first = m - h - 1;  // sample weight_per_sample_[0] applies to
    for (std::size_t j = 0; j < sample_weight_.size(); ++j) sum += sample_weight_[j] * f[first + j];
    out[m] = sum;
  }
}

std::vector<double> OfflineGaussianDifferentiator::DoubleSmoothingKernel() const {
  std::vector<double> k(2 * sample_weight_.size() - 1, 0.0);
  for (std::size_t i = 0; i < sample_weight_.size(); ++i)
    for (std::size_t j = 0; j < sample_weight_.size(); ++j) k[i + j] += sample_weight_[i] * sample_weight_[j];
  return k;
}

void OfflineGaussianDifferentiator::SmoothTimesDerivative(const std::vector<double>& g,
                                                          const std::vector<double>& x,
                                                          std::vector<double>& out) const {
  const std::size_t n = std::min(g.size(), x.size());
  out.assign(n, std::numeric_limits<double>::quiet_NaN());
  const std::size_t h = static_cast<std::size_t>(half_);
  for (std::size_t m = h + 1; m + h + 1 < n; ++m) {
    double sum = 0.0;
    const std::size_t newest = m + h;
    for (std::size_t j = 0; j < weight_.size(); ++j) {
      const std::size_t b = newest - j, a = b - 1;
      sum += weight_[j] * 0.5 * (g[a] + g[b]) * (x[b] - x[a]);
    }
    out[m] = sum / period_s_;
  }
}

double OfflineGaussianDifferentiator::NoiseGain() const {
  double s = 0.0;
  for (double c : coeff_) s += c * c;
  return std::sqrt(s);
}

}  // namespace hexa
