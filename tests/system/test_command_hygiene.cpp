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

// A slow primary beside a hot standby (docs/faults.md): the leg's commands come from both, the
// slow ones interleaved with fast ones. Judged as one stream no run ever forms; judged per
// writer the primary's overrun starts at its 20th slow cycle, whatever the standby does.
TEST(ComputeBudget, ASlowWriterIsFoundBesideAFastOneOfTheSameLeg) {
  ComputeBudgetParams p;  // 0.5 ms budget, 20 in a row
  ComputeBudgetMonitor one_stream;
  WriterComputeBudgets per_writer;
  const std::uint64_t primary = 0x1111, standby = 0x2222;
  int started_at = -1;
  for (int k = 0; k < 40; ++k) {
    const auto tick = static_cast<std::uint64_t>(1000 + k);
    EXPECT_EQ(one_stream.Update(0.00001, p), ComputeBudgetMonitor::Event::kNone);
    EXPECT_EQ(one_stream.Update(0.005, p), ComputeBudgetMonitor::Event::kNone);
    EXPECT_EQ(per_writer.Update(standby, tick, 0.00001, p), ComputeBudgetMonitor::Event::kNone);
    // The standby's tick again (a repeated answer) is not a new cycle.
    EXPECT_EQ(per_writer.Update(standby, tick, 0.00001, p), ComputeBudgetMonitor::Event::kNone);
    if (per_writer.Update(primary, tick, 0.005, p) == ComputeBudgetMonitor::Event::kStarted) {
      EXPECT_EQ(started_at, -1) << "one report per episode";
      started_at = k;
      EXPECT_DOUBLE_EQ(per_writer.last_run_max_s(), 0.005);
    }
  }
  EXPECT_FALSE(one_stream.active()) << "the interleaved stream hides the slow writer";
  EXPECT_EQ(started_at, 19);
  EXPECT_EQ(per_writer.cycles(), 80u);
  EXPECT_EQ(per_writer.over_budget(), 40u);
  EXPECT_DOUBLE_EQ(per_writer.max_s(), 0.005);
  // An older tick of the slow writer is not counted either (its answers arrive in order).
  EXPECT_EQ(per_writer.Update(primary, 1005, 0.005, p), ComputeBudgetMonitor::Event::kNone);
  EXPECT_EQ(per_writer.cycles(), 80u);
}

// More writers than slots: a new one takes the slot heard from least recently; the others
// keep their runs.
TEST(ComputeBudget, AWriterBeyondTheSlotsReplacesTheLeastRecentlyHeard) {
  ComputeBudgetParams p;
  p.overrun_limit = 3;
  WriterComputeBudgets m;
  for (std::uint64_t w = 1; w <= WriterComputeBudgets::kSlots; ++w) m.Update(w, 1, 0.00001, p);
  // Writer 1 runs over budget twice; the others are heard again, writer 2 last of all before.
  m.Update(1, 2, 0.005, p);
  m.Update(1, 3, 0.005, p);
  for (std::uint64_t w = 3; w <= WriterComputeBudgets::kSlots; ++w) m.Update(w, 2, 0.00001, p);
  // A fifth writer replaces writer 2 (least recently heard), not writer 1 ...
  EXPECT_EQ(m.Update(99, 1, 0.00001, p), ComputeBudgetMonitor::Event::kNone);
  // ... whose run goes on to its third cycle over budget.
  EXPECT_EQ(m.Update(1, 4, 0.005, p), ComputeBudgetMonitor::Event::kStarted);
}

}  // namespace
}  // namespace hexa
