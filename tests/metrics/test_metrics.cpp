#include <cmath>

#include <gtest/gtest.h>

#include "hexa/core/metrics.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(Metrics, RmseOfAConstantOffsetIsTheOffset) {
  AxisErrorAccumulator acc;
  for (int k = 0; k < 1000; ++k) {
    Vector6d d = Vector6d::Zero();
    d[0] = 0.08 * std::sin(2 * kPi * k / 1000.0);
    Vector6d a = d;
    a[0] -= 0.002;
    a[4] += 0.01;
    acc.Add(d, a);
  }
  const auto rmse = acc.Rmse();
  EXPECT_NEAR(rmse[0], 0.002, 1e-12);
  EXPECT_NEAR(rmse[4], 0.01, 1e-12);
  EXPECT_EQ(rmse[1], 0.0);
  const auto rel = acc.RelativeError();
  EXPECT_NEAR(rel[0], 0.002 / 0.16, 1e-6);  // peak-to-peak of an 8 cm sine
  EXPECT_LT(rel[1], 0.0);                    // no motion: undefined
}

TEST(Metrics, RmseOfASineErrorIsAmplitudeOverRootTwo) {
  ScalarErrorAccumulator acc;
  for (int k = 0; k < 10000; ++k) acc.Add(0.0, 0.003 * std::sin(2 * kPi * k / 100.0));
  EXPECT_NEAR(acc.Rmse(), 0.003 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(acc.MaxAbs(), 0.003, 1e-9);
}

TEST(Metrics, PercentilesNearestRank) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  const auto p = ComputePercentiles(v);
  EXPECT_EQ(p.count, 100u);
  EXPECT_EQ(p.median, 50.0);
  EXPECT_EQ(p.p99, 99.0);
  EXPECT_EQ(p.max, 100.0);
  EXPECT_EQ(ComputePercentiles({}).count, 0u);
}

}  // namespace
}  // namespace hexa
