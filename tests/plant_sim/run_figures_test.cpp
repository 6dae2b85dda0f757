// The plant's figures of a run, known values: command ages binned as the summary lists them,
// and the duration histogram's quantiles (upper bin edges) and its overflow bin.
#include <gtest/gtest.h>

#include "run_figures.hpp"

namespace hexa::plant_sim {
namespace {

TEST(CommandAgeHistogram, BinsAreZeroOneTwoThreeToSevenEightToFifteenAndSixteenOn) {
  CommandAgeHistogram h;
  for (std::int64_t age : {-1, 0, 1, 2, 3, 7, 8, 15, 16, 1000}) h.Add(age);
  EXPECT_EQ(h.none, 1u);
  EXPECT_EQ(h.bins[0], 1u);
  EXPECT_EQ(h.bins[1], 1u);
  EXPECT_EQ(h.bins[2], 1u);
  EXPECT_EQ(h.bins[3], 2u);
  EXPECT_EQ(h.bins[4], 2u);
  EXPECT_EQ(h.bins[5], 2u);
  EXPECT_EQ(h.late(), 8u);   // every age >= 1
  EXPECT_EQ(h.total(), 10u);  // the ticks without a command too
}

TEST(DurationHistogram, QuantilesAreUpperBinEdgesAndTheOverflowBinReportsTheMax) {
  DurationHistogram h;
  EXPECT_EQ(h.Quantile_s(0.5), 0.0);
  for (int i = 0; i < 98; ++i) h.Add(25'000);  // 25 us: the bin [20, 30) us
  h.Add(-5);                                     // clamped to 0
  h.Add(250'000'000);                            // 250 ms: beyond the last bin
  EXPECT_EQ(h.count(), 100u);
  EXPECT_DOUBLE_EQ(h.Quantile_s(0.5), 30e-6);
  EXPECT_DOUBLE_EQ(h.Quantile_s(0.98), 30e-6);
  EXPECT_DOUBLE_EQ(h.Quantile_s(1.0), 0.25);
  EXPECT_DOUBLE_EQ(h.max_s(), 0.25);
  EXPECT_NEAR(h.mean_s(), (98 * 25e-6 + 0.25) / 100, 1e-12);
}

}  // namespace
}  // namespace hexa::plant_sim
