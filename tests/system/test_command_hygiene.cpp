#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hexa/core/command_hygiene.hpp"

namespace hexa {
namespace {

CommandHygieneParams Params(std::uint64_t tolerance) {
  return CommandHygieneParams::FromValve(ValveParams{}, tolerance);
}

TEST(CommandHygiene, GoodCommandPassesThrough) {
  const LatestCommand c{true, 100, 7.5};
  EXPECT_EQ(CheckCommand(c, 100, Params(0)), CommandCheck::kOk);
  EXPECT_EQ(SafeValveVoltage(c, CommandCheck::kOk, Params(0)), 7.5);
  EXPECT_EQ(CheckCommand({true, 100, 0.0}, 100, Params(0)), CommandCheck::kOk);   // ends of
  EXPECT_EQ(CheckCommand({true, 100, 10.0}, 100, Params(0)), CommandCheck::kOk);  // the range
}

TEST(CommandHygiene, EveryBadCommandGivesNull) {
  const auto p = Params(3);
  struct Case {
    LatestCommand cmd;
    std::uint64_t tick;
    CommandCheck expected;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Case cases[] = {
      {{false, 0, 6.0}, 10, CommandCheck::kMissing},
      {{false, 0, 6.0}, 3, CommandCheck::kAwaitingFirst},  // start-up, within tolerance
      {{true, 6, 6.0}, 10, CommandCheck::kStale},       // 4 ticks old, tolerance 3
      {{true, 11, 6.0}, 10, CommandCheck::kStale},      // from the future
      {{true, 10, nan}, 10, CommandCheck::kNotFinite},
      {{true, 10, inf}, 10, CommandCheck::kNotFinite},
      {{true, 10, -0.01}, 10, CommandCheck::kOutOfRange},
      {{true, 10, 10.01}, 10, CommandCheck::kOutOfRange},
  };
  for (const auto& c : cases) {
    const CommandCheck check = CheckCommand(c.cmd, c.tick, p);
    EXPECT_EQ(check, c.expected) << ToString(c.expected);
    EXPECT_EQ(SafeValveVoltage(c.cmd, check, p), 5.0) << ToString(c.expected);
  }
  EXPECT_EQ(CheckCommand({true, 7, 6.0}, 10, p), CommandCheck::kOk);  // 3 ticks: tolerated
}

// Real time: a leg's first command may take the start-up grace; after it, the stale check is
// armed with the normal tolerance.
TEST(CommandHygiene, StartupGraceCoversOnlyTheFirstCommand) {
  auto p = Params(15);
  p.startup_grace_ticks = 500;
  EXPECT_EQ(CheckCommand({false, 0, 6.0}, 400, p), CommandCheck::kAwaitingFirst);
  EXPECT_EQ(CheckCommand({false, 0, 6.0}, 501, p), CommandCheck::kMissing);
  EXPECT_EQ(CheckCommand({true, 380, 6.0}, 400, p), CommandCheck::kStale);  // armed: 20 > 15
  EXPECT_EQ(CheckCommand({true, 390, 6.0}, 400, p), CommandCheck::kOk);
  p.startup_grace_ticks = 3;  // a grace below the tolerance is the tolerance
  EXPECT_EQ(CheckCommand({false, 0, 6.0}, 15, p), CommandCheck::kAwaitingFirst);
}

// A controller that writes NaN and 42 V in turn changes its check every tick: one episode,
// one report, not one per tick.
TEST(CommandEpisode, FlippingBadCommandsAreOneEpisode) {
  CommandEpisode e(100);
  EXPECT_EQ(e.Update(CommandCheck::kOk), CommandEpisode::Event::kNone);
  EXPECT_EQ(e.Update(CommandCheck::kAwaitingFirst), CommandEpisode::Event::kNone);
  int started = 0;
  for (int k = 0; k < 1000; ++k) {
    const auto check = k % 2 == 0 ? CommandCheck::kNotFinite : CommandCheck::kOutOfRange;
    started += e.Update(check) == CommandEpisode::Event::kStarted ? 1 : 0;
  }
  EXPECT_EQ(started, 1);
  EXPECT_TRUE(e.active());
  EXPECT_EQ(e.first(), CommandCheck::kNotFinite);
  EXPECT_EQ(e.latest(), CommandCheck::kOutOfRange);
  EXPECT_EQ(e.fault_ticks(), 1000u);
}

// Good ticks in between do not end an episode until `clear_after_ok_ticks` come in a row.
TEST(CommandEpisode, EndsOnlyAfterAGoodRun) {
  CommandEpisode e(10);
  EXPECT_EQ(e.Update(CommandCheck::kStale), CommandEpisode::Event::kStarted);
  for (int k = 0; k < 50; ++k) {  // flicker: good, bad, good, bad ...
    EXPECT_EQ(e.Update(k % 2 ? CommandCheck::kStale : CommandCheck::kOk),
              CommandEpisode::Event::kNone);
  }
  for (int k = 0; k < 9; ++k) EXPECT_EQ(e.Update(CommandCheck::kOk), CommandEpisode::Event::kNone);
  EXPECT_EQ(e.Update(CommandCheck::kOk), CommandEpisode::Event::kEnded);
  EXPECT_FALSE(e.active());
  EXPECT_EQ(e.Update(CommandCheck::kMissing), CommandEpisode::Event::kStarted);
  EXPECT_EQ(e.episodes(), 2u);
}


// Compute budget (docs/faults.md): one long cycle is the host preempting the process; a run of
// `overrun_limit` cycles over budget is a controller that cannot keep 1 kHz.
TEST(ComputeBudget, SingleLongCyclesAreNotAnOverrunARunIs) {
  ComputeBudgetParams p;
  p.budget_s = 0.0005;
  p.overrun_limit = 20;
  p.clear_after_ok = 100;
  ComputeBudgetMonitor m;
  for (int k = 0; k < 1000; ++k) {  // a long cycle every 10th: never 20 in a row
    ASSERT_EQ(m.Update(k % 10 == 0 ? 0.004 : 0.00001, p), ComputeBudgetMonitor::Event::kNone) << k;
  }
  EXPECT_FALSE(m.active());
  EXPECT_EQ(m.over_budget(), 100u);
  for (int k = 0; k < 19; ++k) EXPECT_EQ(m.Update(0.005, p), ComputeBudgetMonitor::Event::kNone);
  EXPECT_EQ(m.Update(0.006, p), ComputeBudgetMonitor::Event::kStarted);
  EXPECT_TRUE(m.active());
  EXPECT_DOUBLE_EQ(m.run_max_s(), 0.006);
  EXPECT_EQ(m.Update(0.005, p), ComputeBudgetMonitor::Event::kNone);  // one report per episode
  for (int k = 0; k < 99; ++k) EXPECT_EQ(m.Update(0.0001, p), ComputeBudgetMonitor::Event::kNone);
  EXPECT_EQ(m.Update(0.0001, p), ComputeBudgetMonitor::Event::kEnded);
  EXPECT_FALSE(m.active());
  // Not finite is not within budget.
  ComputeBudgetMonitor n;
  p.overrun_limit = 2;
  n.Update(std::numeric_limits<double>::quiet_NaN(), p);
  EXPECT_EQ(n.Update(std::numeric_limits<double>::quiet_NaN(), p), ComputeBudgetMonitor::Event::kStarted);
}

}  // namespace
}  // namespace hexa
