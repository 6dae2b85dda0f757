// The take-over rule (recording/include/hexa/recording/takeover.hpp) that report.md,
// report.json and events.csv share: a standby takes over a leg at its first command after
// the primary's last one.
#include <gtest/gtest.h>

#include "hexa/recording/takeover.hpp"

using hexa::recorder::Takeover;
using hexa::recorder::TakeoverDetector;

TEST(Takeover, APrimaryThroughoutIsNoTakeover) {
  TakeoverDetector d;
  for (uint64_t tick = 0; tick < 100; ++tick) d.Add(2, tick, false);
  EXPECT_TRUE(d.Find().empty());
}

// Exclusive ownership lets a standby's sample in at tick 0 or while the primary is late: as
// long as the primary writes later ticks, the standby did not take over.
TEST(Takeover, AStandbySampleBeforeThePrimarysLastIsNoTakeover) {
  TakeoverDetector d;
  d.Add(4, 0, true);
  d.Add(4, 57, true);
  for (uint64_t tick = 0; tick <= 200; ++tick) d.Add(4, tick, false);
  EXPECT_TRUE(d.Find().empty());
}

TEST(Takeover, TheStandbysFirstCommandAfterThePrimarysLast) {
  TakeoverDetector d;
  // Out of order, as the recorder may receive them; the standby writes every tick while alive.
  for (uint64_t tick = 999; tick > 0; --tick) d.Add(3, tick, true);
  for (uint64_t tick = 1; tick <= 400; ++tick) d.Add(3, tick, false);
  const std::vector<Takeover> found = d.Find();
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].leg, 3u);
  EXPECT_EQ(found[0].first_standby_tick, 401u);
  ASSERT_TRUE(found[0].last_primary_tick.has_value());
  EXPECT_EQ(*found[0].last_primary_tick, 400u);
  EXPECT_EQ(found[0].standby_commands, 599u);  // ticks 401..999
}

TEST(Takeover, WithoutAPrimaryTheStandbyDrivesFromItsFirstCommand) {
  TakeoverDetector d;
  d.Add(6, 12, true);
  d.Add(6, 10, true);
  d.Add(6, 11, true);
  const std::vector<Takeover> found = d.Find();
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].first_standby_tick, 10u);
  EXPECT_FALSE(found[0].last_primary_tick.has_value());
  EXPECT_EQ(found[0].standby_commands, 3u);
}

TEST(Takeover, LegsAreJudgedApartAndListedByLeg) {
  TakeoverDetector d;
  d.Add(5, 30, false);
  d.Add(5, 31, true);  // leg 5: taken over at 31
  d.Add(1, 50, false);
  d.Add(1, 20, true);  // leg 1: the primary's last (50) is after the standby's: none
  d.Add(2, 7, true);   // leg 2: no primary
  d.Add(5, 32, true);
  const std::vector<Takeover> found = d.Find();
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].leg, 2u);
  EXPECT_EQ(found[0].first_standby_tick, 7u);
  EXPECT_EQ(found[1].leg, 5u);
  EXPECT_EQ(found[1].first_standby_tick, 31u);
  EXPECT_EQ(found[1].standby_commands, 2u);
}
