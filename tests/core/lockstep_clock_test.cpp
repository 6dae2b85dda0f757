// LockstepClock (core/lockstep_clock.hpp): the recorder's flow control around the barrier.
#include "hexa/core/lockstep_clock.hpp"

#include <gtest/gtest.h>

namespace {

using hexa::LockstepClock;
using Flow = LockstepClock::Flow;

LockstepClock MakeClock() {
  hexa::LockstepClockParams p;
  p.sync_every_ticks = 100;
  p.sync_window_ticks = 1200;
  LockstepClock c(p);
  c.Run(100000);
  return c;
}

TEST(LockstepClock, AsksForAnAcknowledgementWaitEverySyncPeriodAndBlocksAWindowLater) {
  LockstepClock c = MakeClock();
  for (std::uint64_t t = 1; t < 100; ++t) EXPECT_EQ(c.AfterTick(t, 0), Flow::kStart);
  EXPECT_EQ(c.AfterTick(100, 0), Flow::kStartAndWake);
  EXPECT_TRUE(c.TakeAckWaitRequest());
  EXPECT_FALSE(c.TakeAckWaitRequest());
  EXPECT_TRUE(c.ack_wait_active());
  // The wait does not end: the loop runs on for the window, then stands still.
  for (std::uint64_t t = 101; t < 1300; ++t) EXPECT_EQ(c.AfterTick(t, 0), Flow::kStart) << t;
  EXPECT_EQ(c.AfterTick(1300, 5'000), Flow::kBlocked);
  EXPECT_FALSE(c.ReadyToStep());
  EXPECT_EQ(c.sync_blocks(), 1u);
  // Not acknowledged yet, not given up: still blocked.
  EXPECT_FALSE(c.AckWaitEnded(false, false, 1300, 10'000).resume);
  EXPECT_TRUE(c.sync_pending());
  // Acknowledged: the loop resumes and the next wait starts at once.
  const LockstepClock::AckOutcome o = c.AckWaitEnded(true, false, 1300, 20'000'000);
  EXPECT_TRUE(o.acknowledged);
  EXPECT_TRUE(o.resume);
  EXPECT_FALSE(c.sync_pending());
  EXPECT_TRUE(c.TakeAckWaitRequest());
  EXPECT_EQ(c.syncs(), 1u);
  EXPECT_NEAR(c.sync_wait_s(), 0.019995, 1e-9);
}

TEST(LockstepClock, AGivenUpSyncNeverBlocksAgainUntilAWaitSucceeds) {
  LockstepClock c = MakeClock();
  EXPECT_EQ(c.AfterTick(100, 0), Flow::kStartAndWake);
  c.TakeAckWaitRequest();
  EXPECT_EQ(c.AfterTick(1300, 0), Flow::kBlocked);
  const LockstepClock::AckOutcome o = c.AckWaitEnded(false, true, 1300, 1'000'000'000);
  EXPECT_TRUE(o.given_up);
  EXPECT_TRUE(o.resume);
  EXPECT_TRUE(c.sync_suspended());
  EXPECT_FALSE(c.TakeAckWaitRequest());  // no new wait while suspended
  for (std::uint64_t t = 1301; t < 5000; ++t) EXPECT_NE(c.AfterTick(t, 0), Flow::kBlocked) << t;
  // The old wait ends after all: acknowledged again, the flow control is back.
  const LockstepClock::AckOutcome again = c.AckWaitEnded(true, false, 5000, 2'000'000'000);
  EXPECT_TRUE(again.acknowledged_again);
  EXPECT_FALSE(c.sync_suspended());
  EXPECT_EQ(c.syncs_given_up(), 1u);
}

TEST(LockstepClock, WithoutARecorderItNeverWaits) {
  LockstepClock c;  // sync_every_ticks 0
  c.Run(10);
  c.Begin(0, hexa::kAllLegs, 0);
  for (int leg = 1; leg <= 6; ++leg) c.Answer(leg, 0);
  EXPECT_TRUE(c.ReadyToStep());
  for (std::uint64_t t = 1; t < 3000; ++t) EXPECT_EQ(c.AfterTick(t, 0), Flow::kStart);
  c.Stop();
  EXPECT_FALSE(c.ReadyToStep());
}

}  // namespace
