// Gaussian differentiator (eq 40, 41): exactness on the polynomials it claims (degree <= 1),
// the delay and noise figures of docs/controller.md as properties of the implementation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "hexa/core/differentiator.hpp"

namespace hexa {
namespace {

DifferentiatorConfig Config(int window, double sigma, double lag, double h = 0.001) {
  DifferentiatorConfig c;
  c.params.window = window;
  c.params.sigma = sigma;
  c.params.centre_lag_samples = lag;
  c.sample_period_s = h;
  return c;
}

TEST(GaussianDifferentiator, ExactOnStraightLinesAtEveryFillLevel) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double lag : {0.0, 1.0, 2.0, 3.5, 7.0, 14.0}) {
    for (int trial = 0; trial < 20; ++trial) {
      const double h = 0.0005 + 0.002 * (u(rng) + 1.0);
      GaussianDifferentiator d(Config(15, 0.85, lag, h));
      const double slope = 3.0 * u(rng), offset = 0.5 * u(rng);
      for (int n = 0; n < 40; ++n) {
        const double est = d.Update(offset + slope * n * h);
        if (n == 0) {
          EXPECT_EQ(est, 0.0);  // one sample: no slope yet
        } else {
          EXPECT_NEAR(est, slope, 1e-9 * (1.0 + std::abs(slope))) << "lag " << lag << " n " << n;
        }
      }
    }
  }
}

TEST(GaussianDifferentiator, QuadraticGivesSlopeDelayedByTheGroupDelay) {
  // For x = q t^2 the estimate is 2 q (t_n - d h), d = GroupDelaySamples (exactly, since the
  // filter is exact on degree 1 and the quadratic's error term is constant).
  for (double lag : {0.0, 2.0, 7.0}) {
    const double h = 0.001, q = 1.7;
    GaussianDifferentiator d(Config(15, 0.85, lag, h));
    double est = 0;
    for (int n = 0; n < 30; ++n) est = d.Update(q * (n * h) * (n * h));
    const double t_n = 29 * h;
    EXPECT_NEAR(est, 2 * q * (t_n - d.GroupDelaySamples() * h), 1e-9);
  }
}

TEST(GaussianDifferentiator, SymmetricCentreIsExactOnQuadraticsAtTheCentre) {
  // c at the window centre: antisymmetric coefficients, delay (N-1)/2 exactly.
  GaussianDifferentiator d(Config(15, 0.85, 7.0));
  EXPECT_NEAR(d.GroupDelaySamples(), 7.0, 1e-9);
  for (int k = 0; k < 15; ++k) EXPECT_NEAR(d.coefficient(k), -d.coefficient(14 - k), 1e-9);
}

TEST(GaussianDifferentiator, DocumentedDelayAndNoiseFiguresForTheDefaults) {
  // docs/controller.md table: N 15, sigma 0.85, c 2 samples before the newest.
  GaussianDifferentiator d(Config(15, 0.85, 2.0));
  EXPECT_NEAR(d.GroupDelaySamples(), 2.320, 0.001);
  EXPECT_NEAR(d.NoiseGain() * 0.001, 0.2801, 0.0005);  // in 1/h
  // c 1: the default (docs/controller.md).
  GaussianDifferentiator one(Config(15, 0.85, 1.0));
  EXPECT_NEAR(one.GroupDelaySamples(), 1.538, 0.001);
  EXPECT_NEAR(one.NoiseGain() * 0.001, 0.4200, 0.0005);
  GaussianDifferentiator newest(Config(15, 0.85, 0.0));
  EXPECT_NEAR(newest.GroupDelaySamples(), 0.995, 0.001);
  EXPECT_NEAR(newest.NoiseGain() * 0.001, 0.7233, 0.0005);
}

TEST(GaussianDifferentiator, MeasuredNoiseMatchesTheAnalyticGain) {
  GaussianDifferentiator d(Config(15, 0.85, 2.0));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 1e-4);
  double sum = 0, sum_sq = 0;
  const int n = 200000;
  for (int i = 0; i < n + 15; ++i) {
    const double est = d.Update(noise(rng));
    if (i >= 15) {
      sum += est;
      sum_sq += est * est;
    }
  }
  const double std_est = std::sqrt(sum_sq / n - (sum / n) * (sum / n));
  EXPECT_NEAR(std_est / (d.NoiseGain() * 1e-4), 1.0, 0.02);
}

TEST(GaussianDifferentiator, DelayGrowsAndNoiseFallsWithTheCentreLag) {
  double last_delay = -1, last_gain = 1e300;
  for (double lag : {0.0, 1.0, 2.0, 3.0, 4.0, 7.0}) {
    GaussianDifferentiator d(Config(15, 0.85, lag));
    EXPECT_GT(d.GroupDelaySamples(), last_delay);
    EXPECT_LT(d.NoiseGain(), last_gain);
    last_delay = d.GroupDelaySamples();
    last_gain = d.NoiseGain();
  }
}

TEST(GaussianDifferentiator, ResetForgetsTheHistory) {
  GaussianDifferentiator d(Config(15, 0.85, 2.0));
  for (int i = 0; i < 20; ++i) d.Update(100.0 * i);
  d.Reset();
  EXPECT_EQ(d.fill(), 0);
  EXPECT_EQ(d.Update(5.0), 0.0);
  EXPECT_NEAR(d.Update(5.0), 0.0, 1e-12);
}

TEST(GaussianDifferentiator, RejectsInvalidConfig) {
  EXPECT_THROW(GaussianDifferentiator(Config(1, 0.85, 0.0)), std::invalid_argument);
  EXPECT_THROW(GaussianDifferentiator(Config(33, 0.85, 2.0)), std::invalid_argument);
  EXPECT_THROW(GaussianDifferentiator(Config(15, 0.0, 2.0)), std::invalid_argument);
  EXPECT_THROW(GaussianDifferentiator(Config(15, 0.85, 14.5)), std::invalid_argument);
  EXPECT_THROW(GaussianDifferentiator(Config(15, 0.85, 2.0, 0.0)), std::invalid_argument);
  EXPECT_THROW(GaussianDifferentiator(Config(15, NAN, 2.0)), std::invalid_argument);
}

}  // namespace
}  // namespace hexa
