// LockstepClock (core/lockstep_clock.hpp): the recorder's flow control around the barrier, and
// what a silent leg calls for (the plant and the replay act on the same decisions).
#include "hexa/core/lockstep_clock.hpp"

#include <gtest/gtest.h>

#include <vector>

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

TEST(LockstepClock, SilentLegsAreAskedAgainThenGivenUpAndTheSupervisorBacksOff) {
  hexa::LockstepClockParams p;
  p.barrier.reask_after_ns = 50'000'000;
  p.barrier.timeout_ns = 1'000'000'000;
  p.supervisor_reask_max_ns = 200'000'000;
  LockstepClock c(p);
  c.Run(100);
  c.Begin(7, hexa::kAllLegs, 0);
  for (int leg : {1, 2, 4, 6}) c.Answer(leg, 7);
  using Action = hexa::LockstepBarrier::Action;
  const hexa::LegMask silent = static_cast<hexa::LegMask>(hexa::LegBit(3) | hexa::LegBit(5));

  LockstepClock::Silence s = c.CheckSilence(10'000'000);
  EXPECT_EQ(s.action, Action::kWait);
  EXPECT_EQ(s.next_check_ns, 50'000'000);
  // Legs 3 and 5 are asked again every 50 ms; the supervisor at 50, then 100 and 200 ms apart.
  std::vector<std::int64_t> supervisor_reasks_ms;
  for (std::int64_t t_ms = 50; t_ms < 1000; t_ms += 50) {
    s = c.CheckSilence(t_ms * 1'000'000);
    ASSERT_EQ(s.action, Action::kReask) << t_ms;
    EXPECT_EQ(s.legs, silent) << t_ms;
    if (s.reask_supervisor) supervisor_reasks_ms.push_back(t_ms);
  }
  EXPECT_EQ(supervisor_reasks_ms, (std::vector<std::int64_t>{50, 150, 350, 550, 750, 950}));
  // Leg 3 answers; leg 5 stays silent until the last resort.
  c.Answer(3, 7);
  s = c.CheckSilence(1'000'000'000);
  EXPECT_EQ(s.action, Action::kTimeout);
  EXPECT_EQ(s.legs, hexa::LegBit(5));
  EXPECT_FALSE(c.ReadyToStep());
  c.Answer(5, 7);
  EXPECT_TRUE(c.ReadyToStep());
  EXPECT_EQ(c.CheckSilence(1'100'000'000).action, Action::kWait);
}

}  // namespace
