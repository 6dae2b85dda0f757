// CommandSourceSelector: the reader-side ownership of a leg's commands (core/command_source.hpp).
#include "hexa/core/command_source.hpp"

#include <gtest/gtest.h>

#include <map>

namespace {

using hexa::CommandSourceSelector;
using hexa::SourceLiveliness;
using Verdict = CommandSourceSelector::Verdict;

struct World {
  std::map<std::uint64_t, SourceLiveliness> state;
  auto Of() {
    return [this](std::uint64_t w) {
      auto it = state.find(w);
      return it == state.end() ? SourceLiveliness::kUnknown : it->second;
    };
  }
};

constexpr std::uint64_t kPrimary = 101, kStandby = 202, kRestarted = 303;

TEST(CommandSource, TheLivePrimaryOwnsTheLegAndItsStandbyIsNotApplied) {
  World w;
  CommandSourceSelector s;
  std::uint64_t tick = 0;
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  // Whichever writes first, once both are known only the primary's samples are applied.
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kApply);  // the only one known
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  for (std::uint64_t tick = 1; tick < 100; ++tick) {
    EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
    EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  }
}

TEST(CommandSource, APrimaryWhoseLivelinessLapsesHandsTheLegToItsStandbyAndTakesItBackInStep) {
  World w;
  CommandSourceSelector s;
  std::uint64_t tick = 0;
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  ASSERT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  ASSERT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
  w.state[kPrimary] = SourceLiveliness::kNotAlive;  // hung or silent
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kApply);
  w.state[kPrimary] = SourceLiveliness::kAlive;     // asserts again (its next write)
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
  w.state[kPrimary] = SourceLiveliness::kGone;      // crashed
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kApply);
}

TEST(CommandSource, AWriterThatJustDeliveredASampleCountsAsAliveUntilItsStateIsKnown) {
  World w;
  CommandSourceSelector s;
  std::uint64_t tick = 0;
  // The liveliness callback has not run yet for either writer.
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
  // A restarted primary (new writer) while the old one is gone: it owns the leg.
  w.state = {{kPrimary, SourceLiveliness::kGone}, {kStandby, SourceLiveliness::kAlive}};
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kRestarted, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
}

TEST(CommandSource, TwoLivePrimariesTheFirstSeenOwns) {
  World w;
  CommandSourceSelector s;
  std::uint64_t tick = 0;
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kRestarted, false, {tick, 1.0}, w.Of()), Verdict::kNotOwner);
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
}

TEST(CommandSource, ATableFullOfWritersReplacesAGoneOneAndStaysBounded) {
  World w;
  CommandSourceSelector s;
  std::uint64_t tick = 0;
  for (std::uint64_t k = 1; k <= CommandSourceSelector::kMaxSources; ++k) {
    w.state[k] = SourceLiveliness::kGone;
    s.Offer(k, true, {tick, 1.0}, w.Of());
  }
  EXPECT_EQ(s.count(), CommandSourceSelector::kMaxSources);
  w.state[kPrimary] = SourceLiveliness::kAlive;
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.count(), CommandSourceSelector::kMaxSources);
  EXPECT_EQ(s.Offer(kPrimary, false, {tick, 1.0}, w.Of()), Verdict::kApply);
}

// A primary stopped longer than its queue of ticks comes back computing from another state:
// its commands differ from the standby's for the same ticks, and the standby keeps the leg
// (before, the primary took it back as soon as it was alive and drove it with them). Once a
// command of it equals the standby's for the same tick, it is in step and owns the leg again.
TEST(CommandSource, APrimaryBackOutOfStepDoesNotTakeTheLegBackUntilItsCommandsAreTheStandbys) {
  World w;
  CommandSourceSelector s;
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  for (std::uint64_t tick = 1; tick <= 10; ++tick) {
    ASSERT_EQ(s.Offer(kPrimary, false, {tick, 0.1 * tick}, w.Of()), Verdict::kApply);
    ASSERT_EQ(s.Offer(kStandby, true, {tick, 0.1 * tick}, w.Of()), Verdict::kNotOwner);
  }
  w.state[kPrimary] = SourceLiveliness::kNotAlive;  // stopped
  for (std::uint64_t tick = 11; tick <= 1500; ++tick)
    ASSERT_EQ(s.Offer(kStandby, true, {tick, 0.1 * tick}, w.Of()), Verdict::kApply);
  EXPECT_TRUE(s.OutOfStep(kPrimary));
  EXPECT_FALSE(s.OutOfStep(kStandby));
  // Alive again, answering the same ticks with other values (its state diverged).
  w.state[kPrimary] = SourceLiveliness::kAlive;
  for (std::uint64_t tick = 1501; tick <= 1600; ++tick) {
    // Either order of arrival.
    if (tick % 2 == 0) {
      EXPECT_EQ(s.Offer(kPrimary, false, {tick, -5.0}, w.Of()), Verdict::kNotOwner) << tick;
      EXPECT_EQ(s.Offer(kStandby, true, {tick, 0.1 * tick}, w.Of()), Verdict::kApply) << tick;
    } else {
      EXPECT_EQ(s.Offer(kStandby, true, {tick, 0.1 * tick}, w.Of()), Verdict::kApply) << tick;
      EXPECT_EQ(s.Offer(kPrimary, false, {tick, -5.0}, w.Of()), Verdict::kNotOwner) << tick;
    }
  }
  EXPECT_TRUE(s.OutOfStep(kPrimary));
  // Its command for tick 1601 equals the standby's: in step, the leg is the primary's again.
  EXPECT_EQ(s.Offer(kStandby, true, {1601, 160.1}, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kPrimary, false, {1601, 160.1}, w.Of()), Verdict::kApply);
  EXPECT_FALSE(s.OutOfStep(kPrimary));
  EXPECT_EQ(s.Offer(kStandby, true, {1602, 160.2}, w.Of()), Verdict::kNotOwner);
  EXPECT_EQ(s.Offer(kPrimary, false, {1602, 160.2}, w.Of()), Verdict::kApply);
}

// Out of step but the only live writer: its commands are applied (better than none).
TEST(CommandSource, AnOutOfStepPrimaryIsAppliedWhenItsStandbyIsGone) {
  World w;
  CommandSourceSelector s;
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  ASSERT_EQ(s.Offer(kPrimary, false, {1, 1.0}, w.Of()), Verdict::kApply);
  ASSERT_EQ(s.Offer(kStandby, true, {1, 1.0}, w.Of()), Verdict::kNotOwner);
  w.state[kPrimary] = SourceLiveliness::kNotAlive;
  ASSERT_EQ(s.Offer(kStandby, true, {2, 2.0}, w.Of()), Verdict::kApply);
  w.state[kPrimary] = SourceLiveliness::kAlive;
  ASSERT_EQ(s.Offer(kPrimary, false, {3, -1.0}, w.Of()), Verdict::kNotOwner);
  w.state[kStandby] = SourceLiveliness::kGone;
  EXPECT_EQ(s.Offer(kPrimary, false, {4, -1.0}, w.Of()), Verdict::kApply);
  EXPECT_TRUE(s.OutOfStep(kPrimary));
}

}  // namespace
