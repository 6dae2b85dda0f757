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
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  // Whichever writes first, once both are known only the primary's samples are applied.
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kApply);  // the only one known
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  for (int tick = 0; tick < 100; ++tick) {
    EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kNotOwner);
    EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  }
}

TEST(CommandSource, APrimaryWhoseLivelinessLapsesHandsTheLegToItsStandbyAndTakesItBack) {
  World w;
  CommandSourceSelector s;
  w.state = {{kPrimary, SourceLiveliness::kAlive}, {kStandby, SourceLiveliness::kAlive}};
  ASSERT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  ASSERT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kNotOwner);
  w.state[kPrimary] = SourceLiveliness::kNotAlive;  // hung or silent
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kApply);
  w.state[kPrimary] = SourceLiveliness::kAlive;     // asserts again (its next write)
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kNotOwner);
  w.state[kPrimary] = SourceLiveliness::kGone;      // crashed
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kApply);
}

TEST(CommandSource, AWriterThatJustDeliveredASampleCountsAsAliveUntilItsStateIsKnown) {
  World w;
  CommandSourceSelector s;
  // The liveliness callback has not run yet for either writer.
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kNotOwner);
  // A restarted primary (new writer) while the old one is gone: it owns the leg.
  w.state = {{kPrimary, SourceLiveliness::kGone}, {kStandby, SourceLiveliness::kAlive}};
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kRestarted, false, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kStandby, true, w.Of()), Verdict::kNotOwner);
}

TEST(CommandSource, TwoLivePrimariesTheFirstSeenOwns) {
  World w;
  CommandSourceSelector s;
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.Offer(kRestarted, false, w.Of()), Verdict::kNotOwner);
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
}

TEST(CommandSource, ATableFullOfWritersReplacesAGoneOneAndStaysBounded) {
  World w;
  CommandSourceSelector s;
  for (std::uint64_t k = 1; k <= CommandSourceSelector::kMaxSources; ++k) {
    w.state[k] = SourceLiveliness::kGone;
    s.Offer(k, true, w.Of());
  }
  EXPECT_EQ(s.count(), CommandSourceSelector::kMaxSources);
  w.state[kPrimary] = SourceLiveliness::kAlive;
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
  EXPECT_EQ(s.count(), CommandSourceSelector::kMaxSources);
  EXPECT_EQ(s.Offer(kPrimary, false, w.Of()), Verdict::kApply);
}

}  // namespace
