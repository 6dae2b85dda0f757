// ScheduleSlips: the plant's record of its real-time schedule slips (core/schedule_slips.hpp).
#include "hexa/core/schedule_slips.hpp"

#include <gtest/gtest.h>

namespace {

using hexa::core::ScheduleSlips;

TEST(ScheduleSlips, CountsOnlyWakeUpsLaterThanTheThreshold) {
  ScheduleSlips s(2'000'000);
  EXPECT_FALSE(s.Record(1, 0));
  EXPECT_FALSE(s.Record(2, 1'999'999));
  EXPECT_FALSE(s.Record(3, 2'000'000));  // at the threshold: not a slip
  EXPECT_TRUE(s.Record(4, 2'000'001));
  EXPECT_EQ(s.count(), 1u);
  EXPECT_EQ(s.total_ns(), 2'000'001);
  ASSERT_EQ(s.kept_count(), 1u);
  EXPECT_EQ(s.kept(0).tick, 4u);
  EXPECT_EQ(s.kept(0).late_ns, 2'000'001);
}

TEST(ScheduleSlips, KeepsEveryTickInOrderAndTheWorst) {
  ScheduleSlips s(1'000'000);
  s.Record(100, 3'000'000);
  s.Record(250, 9'500'000);
  s.Record(251, 1'000'000);  // not a slip
  s.Record(7000, 4'000'000);
  EXPECT_EQ(s.count(), 3u);
  EXPECT_EQ(s.total_ns(), 16'500'000);
  EXPECT_EQ(s.worst().tick, 250u);
  EXPECT_EQ(s.worst().late_ns, 9'500'000);
  ASSERT_EQ(s.kept_count(), 3u);
  EXPECT_EQ(s.kept(0).tick, 100u);
  EXPECT_EQ(s.kept(1).tick, 250u);
  EXPECT_EQ(s.kept(2).tick, 7000u);
  EXPECT_EQ(s.kept(2).late_ns, 4'000'000);
}

TEST(ScheduleSlips, NoSlipLeavesAnEmptyRecord) {
  ScheduleSlips s(2'000'000);
  for (std::uint64_t t = 0; t < 1000; ++t) s.Record(t, 500'000);
  EXPECT_EQ(s.count(), 0u);
  EXPECT_EQ(s.kept_count(), 0u);
  EXPECT_EQ(s.worst().late_ns, 0);
  EXPECT_EQ(s.total_ns(), 0);
}

TEST(ScheduleSlips, KeepsTheFirstSlipsButCountsAndWeighsThemAll) {
  ScheduleSlips s(0);
  const std::uint64_t n = ScheduleSlips::kKept + 10;
  for (std::uint64_t t = 1; t <= n; ++t) s.Record(t, static_cast<std::int64_t>(t) * 1000);
  EXPECT_EQ(s.count(), n);
  EXPECT_EQ(s.kept_count(), ScheduleSlips::kKept);
  EXPECT_EQ(s.kept(ScheduleSlips::kKept - 1).tick, ScheduleSlips::kKept);
  // The worst is the last one, beyond the kept ones: still found.
  EXPECT_EQ(s.worst().tick, n);
  EXPECT_EQ(s.total_ns(), static_cast<std::int64_t>(n * (n + 1) / 2 * 1000));
}

}  // namespace
