// The offline Gaussian differentiator (eq 40/41, centred) and its matching smoothing:
// D[x] = S[x'] for any signal (up to the trapezoid rule), exact on lines, zero phase.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hexa/core/differentiator.hpp"
#include "hexa/core/offline_differentiator.hpp"

namespace hexa {
namespace {

TEST(OfflineDifferentiator, ExactOnLinesAndZeroPhaseOnParabolas) {
  const OfflineGaussianDifferentiator d({41, 6.0}, 0.001);
  std::vector<double> x(500), q(500), out;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double t = 0.001 * static_cast<double>(k);
    x[k] = 3.0 - 2.5 * t;
    q[k] = t * t;
  }
  d.Derivative(x, out);
  for (std::size_t k = 20; k + 20 < x.size(); ++k) EXPECT_NEAR(out[k], -2.5, 1e-9);
  EXPECT_TRUE(std::isnan(out[19]));
  EXPECT_TRUE(std::isnan(out[x.size() - 20]));
  d.Derivative(q, out);  // symmetric weights: the derivative of t^2 at t exactly
  for (std::size_t k = 20; k + 20 < q.size(); ++k) EXPECT_NEAR(out[k], 2.0 * 0.001 * static_cast<double>(k), 1e-9);
  double sum = 0.0;
  for (double w : d.interval_weights()) {
    EXPECT_GE(w, 0.0);
    sum += w;
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
}

TEST(OfflineDifferentiator, DerivativeEqualsTheSmoothedTrueDerivative) {
  // A signal with fast and slow content: D[x] vs S[x'] to the trapezoid rule's accuracy.
  const OfflineGaussianDifferentiator d({41, 6.0}, 0.001);
  std::vector<double> x(3000), dx(3000), dd, sd;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double t = 0.001 * static_cast<double>(k);
    x[k] = std::sin(2 * 3.14159265358979 * 3 * t) + 0.2 * std::sin(2 * 3.14159265358979 * 40 * t);
    dx[k] = 2 * 3.14159265358979 * 3 * std::cos(2 * 3.14159265358979 * 3 * t) +
            0.2 * 2 * 3.14159265358979 * 40 * std::cos(2 * 3.14159265358979 * 40 * t);
  }
  d.Derivative(x, dd);
  d.Smooth(dx, sd);
  double worst = 0.0, scale = 0.0;
  for (std::size_t k = 21; k + 21 < x.size(); ++k) {
    worst = std::max(worst, std::abs(dd[k] - sd[k]));
    scale = std::max(scale, std::abs(dd[k]));
  }
  // The four-point rule on 1 ms intervals: (w h)^4 11/720 of the 40 Hz part, ~6e-5.
  EXPECT_LT(worst, 1e-4 * scale);
}

TEST(OfflineDifferentiator, UsesTheControllersWeights) {
  // Same eq 40/41 weights as the causal controller filter for the same window and centre.
  DifferentiatorConfig c;
  c.params.window = 15;
  c.params.sigma = 0.85;
  c.params.centre_lag_samples = 7.0;
  const GaussianDifferentiator causal(c);
  const OfflineGaussianDifferentiator offline({15, 0.85}, 0.001);
  for (int k = 0; k < 15; ++k) EXPECT_DOUBLE_EQ(offline.coefficients()[static_cast<std::size_t>(k)], causal.coefficient(k));
}

}  // namespace
}  // namespace hexa
