// CommandArbitration (core/command_arbitration.hpp): every fault reason it emits, the standby
// hand-over, the lapse rule, the host-overload rule, dead legs and the interlock; each checks
// the voltages the valves get and the events (reason, leg). No process, no DDS, no clock.
#include "hexa/core/command_arbitration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

namespace {

using namespace hexa;

constexpr double kNullV = 5.0;
constexpr std::uint64_t kPrimary = 11, kStandby = 22;

ArbitrationParams Lockstep() {
  ArbitrationParams p;
  p.hygiene.null_voltage_v = kNullV;
  p.hygiene.min_voltage_v = 0.0;
  p.hygiene.max_voltage_v = 10.0;
  return p;
}

ArbitrationParams Realtime(std::uint64_t stale_ticks = 15) {
  ArbitrationParams p = Lockstep();
  p.realtime = true;
  p.hygiene.stale_tolerance_ticks = stale_ticks;
  p.hygiene.startup_grace_ticks = 500;
  p.lapse_confirm_ticks = 10;
  return p;
}

struct Liveliness {
  std::map<std::uint64_t, SourceLiveliness> state;
  auto Of() {
    return [this](std::uint64_t w) {
      auto it = state.find(w);
      return it == state.end() ? SourceLiveliness::kAlive : it->second;
    };
  }
};

// Feeds a leg's command the way the plant's reader does.
bool Offer(CommandArbitration& a, int leg, std::uint64_t answered, double v, std::uint64_t tick,
           ArbitrationEvents& events, std::uint64_t writer = kPrimary, bool standby = false,
           double compute_s = 0.0001, Liveliness* l = nullptr) {
  Liveliness alive;
  CommandSample s;
  s.leg = leg;
  s.writer = writer;
  s.standby = standby;
  s.answered_tick = answered;
  s.valve_v = v;
  s.compute_s = compute_s;
  return a.Offer(s, tick, (l != nullptr ? l : &alive)->Of(), events);
}

// Every leg answers `tick` with `v`.
void AllAnswer(CommandArbitration& a, std::uint64_t tick, double v) {
  ArbitrationEvents e;
  for (int leg = 1; leg <= 6; ++leg) Offer(a, leg, tick, v, tick, e);
}

std::size_t Count(const ArbitrationEvents& events, FaultReason reason, int leg) {
  std::size_t n = 0;
  for (const ArbitrationEvent& e : events) n += e.reason == reason && e.leg == leg ? 1 : 0;
  return n;
}

std::size_t Published(const ArbitrationEvents& events) {
  std::size_t n = 0;
  for (const ArbitrationEvent& e : events) n += e.publish() ? 1 : 0;
  return n;
}

ArbitrationOutput Tick(CommandArbitration& a, std::uint64_t tick, const ArbitrationInput* base = nullptr) {
  ArbitrationInput in = base != nullptr ? *base : ArbitrationInput{};
  in.tick = tick;
  ArbitrationOutput out;
  a.Update(in, out);
  return out;
}

// Real time: `ticks` ticks with every leg's writer alive and answering; the input used.
ArbitrationInput RunAllAlive(CommandArbitration& a, std::uint64_t ticks) {
  ArbitrationInput in;
  in.writers_valid = true;
  for (auto& w : in.writers) w.alive = 1;
  for (std::uint64_t t = 0; t < ticks; ++t) {
    AllAnswer(a, t, 6.0);
    Tick(a, t, &in);
  }
  return in;
}

TEST(CommandArbitration, ValidCommandsReachTheValvesWithoutEvents) {
  CommandArbitration a(Lockstep());
  for (std::uint64_t t = 0; t < 50; ++t) {
    AllAnswer(a, t, 6.25);
    const ArbitrationOutput out = Tick(a, t);
    for (double v : out.valve_v) EXPECT_EQ(v, 6.25);
    EXPECT_TRUE(out.events.empty()) << t;
  }
}

// One test per command check: the leg's valve at null, one event with the reason and leg.
struct BadCommand {
  const char* name;
  bool send;  // false: no command at all
  std::uint64_t answered_tick;
  double valve_v;
  FaultReason reason;
};

class CommandFaults : public ::testing::TestWithParam<BadCommand> {};

TEST_P(CommandFaults, NullAndOneEventNamingTheReasonAndTheLeg) {
  const BadCommand& b = GetParam();
  CommandArbitration a(Lockstep());
  ArbitrationEvents e;
  // Tick 0: legs answer validly, leg 4 too (except for `missing`: it never answers).
  for (int leg = 1; leg <= 6; ++leg)
    if (leg != 4 || b.send) Offer(a, leg, 0, 6.0, 0, e);
  Tick(a, 0);
  for (int leg = 1; leg <= 6; ++leg)
    if (leg != 4) Offer(a, leg, 1, 6.0, 1, e);
  if (b.send) Offer(a, 4, b.answered_tick, b.valve_v, 1, e);
  const ArbitrationOutput out = Tick(a, 1);
  EXPECT_EQ(out.valve_v[3], kNullV);
  EXPECT_EQ(out.valve_v[0], 6.0);
  ASSERT_EQ(Published(out.events), 1u) << b.name;
  EXPECT_EQ(out.events[0].leg, 4);
  EXPECT_EQ(out.events[0].reason, b.reason);
  EXPECT_EQ(out.events[0].kind, ArbitrationEventKind::kCommandFault);
  EXPECT_EQ(out.events[0].tick, 1u);
  // One event per episode: the same fault next tick is not reported again.
  for (int leg = 1; leg <= 6; ++leg)
    if (leg != 4) Offer(a, leg, 2, 6.0, 2, e);
  if (b.send) Offer(a, 4, b.answered_tick, b.valve_v, 2, e);
  const ArbitrationOutput next = Tick(a, 2);
  EXPECT_EQ(next.valve_v[3], kNullV);
  EXPECT_EQ(Published(next.events), 0u);
}

INSTANTIATE_TEST_SUITE_P(
    EveryCheck, CommandFaults,
    ::testing::Values(
        BadCommand{"missing", false, 0, 0.0, FaultReason::kCommandDeadlineMissed},
        BadCommand{"stale", true, 0, 6.0, FaultReason::kCommandStale},
        BadCommand{"not finite", true, 1, std::numeric_limits<double>::quiet_NaN(),
                   FaultReason::kCommandNotFinite},
        BadCommand{"out of range", true, 1, 42.0, FaultReason::kCommandOutOfRange}),
    [](const auto& info) {
      std::string n = info.param.name;
      for (char& c : n) c = c == ' ' ? '_' : c;
      return n;
    });

TEST(CommandArbitration, AnEpisodeInEffectIsRepeatedEveryHundredTicksAndEndsAfterAHundredGoodOnes) {
  CommandArbitration a(Lockstep());
  ArbitrationEvents e;
  std::uint64_t t = 0;
  for (; t < 90; ++t) {
    AllAnswer(a, t, 6.0);
    Offer(a, 2, t, 42.0, t, e);  // leg 2 out of range
    Tick(a, t);
  }
  ArbitrationEvents repeat;
  a.EndTick(99, repeat);
  EXPECT_TRUE(repeat.empty());  // not at the repeat period
  a.EndTick(100, repeat);
  ASSERT_EQ(repeat.size(), 1u);
  EXPECT_EQ(repeat[0].kind, ArbitrationEventKind::kStillFaulty);
  EXPECT_EQ(repeat[0].reason, FaultReason::kCommandOutOfRange);
  EXPECT_EQ(repeat[0].leg, 2);
  EXPECT_EQ(repeat[0].tick, 100u);
  // Valid again: the episode ends after 100 good ticks in a row (log only, no FaultEvent).
  bool ended = false;
  for (; t < 300 && !ended; ++t) {
    AllAnswer(a, t, 6.0);
    const ArbitrationOutput out = Tick(a, t);
    EXPECT_EQ(out.valve_v[1], 6.0);
    for (const ArbitrationEvent& ev : out.events) {
      ended = ended || (ev.kind == ArbitrationEventKind::kEpisodeEnded && ev.leg == 2 && !ev.publish());
    }
  }
  EXPECT_TRUE(ended);
  EXPECT_EQ(t, 190u);
  EXPECT_EQ(a.episodes(2), 1u);
}

TEST(CommandArbitration, ComputeOverrunIsReportedAfterTheLimitOfCyclesOverBudget) {
  ArbitrationParams p = Lockstep();
  p.compute_budget.budget_s = 0.0005;
  p.compute_budget.overrun_limit = 20;
  CommandArbitration a(p);
  std::size_t overruns = 0;
  for (std::uint64_t t = 0; t < 40; ++t) {
    ArbitrationEvents e;
    for (int leg = 1; leg <= 6; ++leg) Offer(a, leg, t, 6.0, t, e, kPrimary, false, leg == 5 ? 0.002 : 0.0001);
    for (const ArbitrationEvent& ev : e) {
      EXPECT_EQ(ev.reason, FaultReason::kComputeOverrun);
      EXPECT_EQ(ev.leg, 5);
      EXPECT_EQ(t, 19u);  // the 20th cycle over budget
      EXPECT_NEAR(ev.compute_s, 0.002, 1e-12);
      ++overruns;
    }
    const ArbitrationOutput out = Tick(a, t);
    EXPECT_EQ(out.valve_v[4], 6.0);  // slow, not wrong: the command still applies
  }
  EXPECT_EQ(overruns, 1u);
  EXPECT_EQ(a.compute(5).over_budget(), 40u);
}

TEST(CommandArbitration, TheStandbyTakesOverWhenThePrimaryLapsesWithoutAFault) {
  CommandArbitration a(Lockstep());
  Liveliness l;
  ArbitrationEvents e;
  for (std::uint64_t t = 0; t < 10; ++t) {
    AllAnswer(a, t, 6.0);
    Offer(a, 3, t, 7.0, t, e, kPrimary, false, 0.0001, &l);
    EXPECT_FALSE(Offer(a, 3, t, 3.0, t, e, kStandby, true, 0.0001, &l));  // not the owner
    EXPECT_EQ(Tick(a, t).valve_v[2], 7.0);
  }
  l.state[kPrimary] = SourceLiveliness::kNotAlive;  // the primary hangs: only its standby answers
  for (std::uint64_t t = 10; t < 20; ++t) {
    for (int leg = 1; leg <= 6; ++leg)
      if (leg != 3) Offer(a, leg, t, 6.0, t, e);
    EXPECT_TRUE(Offer(a, 3, t, 3.0, t, e, kStandby, true, 0.0001, &l));
    const ArbitrationOutput out = Tick(a, t);
    EXPECT_EQ(out.valve_v[2], 3.0);  // the standby's commands
    EXPECT_TRUE(out.events.empty());
  }
  EXPECT_TRUE(e.empty());
  EXPECT_EQ(a.episodes(3), 0u);
}

TEST(CommandArbitration, RealtimeLapseWithFreshCommandsIsTheHostAndTheValveFollows) {
  CommandArbitration a(Realtime());
  ArbitrationInput in = RunAllAlive(a, 5);
  // Leg 6's lease lapses, its commands keep coming (the host delayed the renewal).
  in.writers[5] = LegWriterCounts{0, 1, 0};
  for (std::uint64_t t = 5; t < 40; ++t) {
    AllAnswer(a, t, 6.0);
    const ArbitrationOutput out = Tick(a, t, &in);
    EXPECT_EQ(out.valve_v[5], 6.0);
    EXPECT_FALSE(out.forced[5]);
    EXPECT_EQ(Published(out.events), 0u);
  }
  EXPECT_EQ(a.lapses_while_fresh(), 1u);
  EXPECT_FALSE(a.dead(6));
}

TEST(CommandArbitration, RealtimeLapseWithStoppedCommandsIsLivelinessLostAndTheValveCloses) {
  CommandArbitration a(Realtime());
  ArbitrationInput in = RunAllAlive(a, 5);
  // Leg 6 stops answering at tick 4 and its lease lapses: dead once its newest answer is a
  // lease (10 ticks) old, not before.
  in.writers[5] = LegWriterCounts{0, 1, 0};
  ArbitrationEvents e;
  std::uint64_t dead_at = 0;
  for (std::uint64_t t = 5; t < 30 && dead_at == 0; ++t) {
    for (int leg = 1; leg <= 5; ++leg) Offer(a, leg, t, 6.0, t, e);
    const ArbitrationOutput out = Tick(a, t, &in);
    if (!out.forced[5]) {
      EXPECT_EQ(Published(out.events), 0u) << t;
      continue;
    }
    dead_at = t;
    EXPECT_EQ(out.valve_v[5], kNullV);
    ASSERT_EQ(Published(out.events), 1u);
    EXPECT_EQ(out.events[0].kind, ArbitrationEventKind::kNoLiveWriter);
    EXPECT_EQ(out.events[0].reason, FaultReason::kLivelinessLost);
    EXPECT_EQ(out.events[0].leg, 6);
  }
  EXPECT_EQ(dead_at, 14u);  // answered tick 4 + the 10-tick lease
  // After a slip of the schedule a lapse waits for the stale tolerance (15 ticks) instead.
  CommandArbitration b(Realtime());
  in.writers[5] = LegWriterCounts{1, 0, 0};
  for (std::uint64_t t = 0; t < 5; ++t) {
    AllAnswer(b, t, 6.0);
    Tick(b, t, &in);
  }
  in.writers[5] = LegWriterCounts{0, 1, 0};
  in.after_slip = true;
  for (std::uint64_t t = 5; t < 19; ++t) {
    for (int leg = 1; leg <= 5; ++leg) Offer(b, leg, t, 6.0, t, e);
    EXPECT_FALSE(Tick(b, t, &in).forced[5]) << t;
  }
}

TEST(CommandArbitration, RealtimeLegWithoutWritersIsWriterGoneAndReleasedAfterAHundredAliveTicks) {
  CommandArbitration a(Realtime());
  ArbitrationInput in;
  in.writers_valid = true;
  for (auto& w : in.writers) w.alive = 1;
  AllAnswer(a, 0, 6.0);
  Tick(a, 0, &in);
  in.writers[1] = LegWriterCounts{0, 0, 1};  // leg 2's writer is gone (its process ended)
  ArbitrationEvents e;
  std::uint64_t t = 1;
  for (; t < 20 && !a.dead(2); ++t) {
    for (int leg = 1; leg <= 6; ++leg)
      if (leg != 2) Offer(a, leg, t, 6.0, t, e);
    const ArbitrationOutput out = Tick(a, t, &in);
    if (a.dead(2)) {
      EXPECT_EQ(out.valve_v[1], kNullV);
      EXPECT_EQ(Count(out.events, FaultReason::kWriterGone, 2), 1u);
    }
  }
  ASSERT_TRUE(a.dead(2));
  // A restarted controller: released after 100 ticks alive in a row.
  in.writers[1] = LegWriterCounts{1, 0, 0};
  bool released = false;
  for (std::uint64_t k = 0; k < 100; ++k, ++t) {
    AllAnswer(a, t, 6.0);
    const ArbitrationOutput out = Tick(a, t, &in);
    for (const ArbitrationEvent& ev : out.events)
      released = released || (ev.kind == ArbitrationEventKind::kLinkReleased && ev.leg == 2);
    EXPECT_EQ(out.valve_v[1], released ? 6.0 : kNullV) << k;
  }
  EXPECT_TRUE(released);
}

TEST(CommandArbitration, HostOverloadIsOneEventOfTheHostNotSixLegFaults) {
  CommandArbitration a(Realtime(15));
  for (std::uint64_t t = 0; t < 10; ++t) {
    AllAnswer(a, t, 6.0);
    Tick(a, t);
  }
  // No leg answers for 30 ticks: every awaited leg stale at once (tick 9 + 15 + 1 = 25).
  std::size_t host = 0, legs = 0;
  for (std::uint64_t t = 10; t < 40; ++t) {
    const ArbitrationOutput out = Tick(a, t);
    if (t >= 25) {
      EXPECT_TRUE(out.host_overload);
      for (double v : out.valve_v) EXPECT_EQ(v, kNullV);
    }
    for (const ArbitrationEvent& ev : out.events) {
      if (!ev.publish()) continue;
      if (ev.reason == FaultReason::kHostOverload) {
        ++host;
        EXPECT_EQ(ev.leg, 0);
        EXPECT_EQ(ev.tick, 25u);
        EXPECT_EQ(ev.answered_tick, 9u);
        EXPECT_EQ(ev.count, 6u);
      } else {
        ++legs;
      }
    }
  }
  EXPECT_EQ(host, 1u);
  EXPECT_EQ(legs, 0u);
  for (int leg = 1; leg <= 6; ++leg) EXPECT_EQ(a.episodes(leg), 1u);  // counted, not reported
}

TEST(CommandArbitration, HostOverloadNeedsEveryAwaitedLegLate) {
  CommandArbitration a(Realtime(15));
  ArbitrationEvents e;
  for (std::uint64_t t = 0; t < 40; ++t) {
    for (int leg = 1; leg <= 5; ++leg) Offer(a, leg, t, 6.0, t, e);  // leg 6 stops after tick 9
    if (t < 10) Offer(a, 6, t, 6.0, t, e);
    const ArbitrationOutput out = Tick(a, t);
    EXPECT_FALSE(out.host_overload);
    if (t == 25) {
      EXPECT_EQ(Count(out.events, FaultReason::kCommandStale, 6), 1u);
    }
  }
  EXPECT_EQ(a.episodes(6), 1u);
}

TEST(CommandArbitration, LockstepSilentLegWhoseProcessEndedIsDroppedAndReportedOnce) {
  CommandArbitration a(Lockstep());
  AllAnswer(a, 0, 6.0);
  Tick(a, 0);
  LegArray<SilentLegFacts> facts{};
  facts[2].processes = 1;
  facts[2].processes_ended = 1;
  facts[2].writers.not_alive = 1;
  ArbitrationEvents e;
  const LegMask dead = a.JudgeSilentLegs(1, LegBit(3), facts, 20'000'000, e);
  EXPECT_EQ(dead, LegBit(3));
  EXPECT_EQ(a.dropped(), LegBit(3));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].kind, ArbitrationEventKind::kLegDead);
  EXPECT_EQ(e[0].reason, FaultReason::kWriterGone);
  EXPECT_EQ(e[0].verdict, SilentLegVerdict::kProcessEnded);
  EXPECT_EQ(e[0].leg, 3);
  // The tick completes without leg 3: its valve at null, its episode not reported again.
  for (int leg = 1; leg <= 6; ++leg)
    if (leg != 3) Offer(a, leg, 1, 6.0, 1, e);
  const ArbitrationOutput out = Tick(a, 1);
  EXPECT_EQ(out.valve_v[2], kNullV);
  EXPECT_EQ(out.valve_v[0], 6.0);
  EXPECT_EQ(Published(out.events), 0u);
  EXPECT_EQ(a.episodes(3), 1u);
  // Its writers gone later: already reported as gone, nothing more.
  LegArray<LegWriterCounts> writers{};
  writers[2].gone = 1;
  ArbitrationEvents gone;
  a.ReportGoneWriters(2, writers, gone);
  EXPECT_TRUE(gone.empty());
}

TEST(CommandArbitration, LockstepStuckControllerIsLivelinessLostThenWriterGoneWhenItsWritersGo) {
  CommandArbitration a(Lockstep());
  AllAnswer(a, 0, 6.0);
  Tick(a, 0);
  LegArray<SilentLegFacts> facts{};
  facts[0].processes = 1;
  facts[0].processes_stuck = 1;
  facts[0].writers.not_alive = 1;
  ArbitrationEvents e;
  EXPECT_EQ(a.JudgeSilentLegs(1, LegBit(1), facts, 20'000'000, e), LegBit(1));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].reason, FaultReason::kLivelinessLost);
  EXPECT_EQ(e[0].leg, 1);
  LegArray<LegWriterCounts> writers{};
  writers[0].gone = 1;
  ArbitrationEvents gone;
  a.ReportGoneWriters(1, writers, gone);
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_EQ(gone[0].reason, FaultReason::kWriterGone);
  EXPECT_EQ(gone[0].leg, 1);
  EXPECT_EQ(gone[0].count, 1u);
  gone.Clear();
  a.ReportGoneWriters(2, writers, gone);
  EXPECT_TRUE(gone.empty());  // once
}

TEST(CommandArbitration, LockstepLapseOfAStoppedProcessIsWaitedForNotAFault) {
  CommandArbitration a(Lockstep());
  LegArray<SilentLegFacts> facts{};
  facts[4].processes = 1;              // running (stopped, not scheduled): not ended, not stuck
  facts[4].writers.not_alive = 1;      // its lease lapsed
  ArbitrationEvents e;
  EXPECT_EQ(a.JudgeSilentLegs(7, LegBit(5), facts, 3'000'000'000, e), 0);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].kind, ArbitrationEventKind::kLapseWaited);
  EXPECT_FALSE(e[0].publish());
  e.Clear();
  a.JudgeSilentLegs(7, LegBit(5), facts, 3'010'000'000, e);  // the same tick: counted once
  a.JudgeSilentLegs(8, LegBit(5), facts, 10'000'000, e);     // a later one: counted, not logged
  EXPECT_TRUE(e.empty());
  EXPECT_EQ(a.lapses_waited(), 2u);
  EXPECT_FALSE(a.dead(5));
}

TEST(CommandArbitration, TheInterlockHoldsTheLegAtNullForGoodWithItsReasonInTheRepeats) {
  CommandArbitration a(Lockstep());
  ArbitrationEvents e;
  a.Interlock(4, 3, e);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].kind, ArbitrationEventKind::kInterlock);
  EXPECT_FALSE(e[0].publish());  // the supervisor reported it
  e.Clear();
  a.Interlock(4, 5, e);  // once
  a.Interlock(9, 5, e);  // no such leg
  EXPECT_TRUE(e.empty());
  for (std::uint64_t t = 0; t < 100; ++t) {
    AllAnswer(a, t, 6.0);
    const ArbitrationOutput out = Tick(a, t);
    EXPECT_EQ(out.valve_v[3], kNullV);
    EXPECT_TRUE(out.forced[3]);
    EXPECT_EQ(out.valve_v[2], 6.0);
    EXPECT_EQ(Published(out.events), 0u);
  }
  EXPECT_EQ(a.forced_reason(4), FaultReason::kSensorInconsistent);
  ArbitrationEvents repeat;
  a.EndTick(100, repeat);
  ASSERT_EQ(repeat.size(), 1u);
  EXPECT_EQ(repeat[0].reason, FaultReason::kSensorInconsistent);
  EXPECT_TRUE(repeat[0].forced);
  EXPECT_EQ(repeat[0].leg, 4);
}

TEST(CommandArbitration, AnOlderAnswerNeverReplacesANewerOne) {
  CommandArbitration a(Lockstep());
  ArbitrationEvents e;
  EXPECT_TRUE(Offer(a, 1, 5, 7.0, 5, e));
  EXPECT_FALSE(Offer(a, 1, 4, 3.0, 5, e));
  EXPECT_EQ(a.latest(1).answered_tick, 5u);
  EXPECT_EQ(a.latest(1).valve_v, 7.0);
}

TEST(ArbitrationEvents, KeepsItsCapacityAndCountsTheRest) {
  ArbitrationEvents e;
  for (std::size_t k = 0; k < ArbitrationEvents::kCapacity + 3; ++k) e.Add(ArbitrationEvent{});
  EXPECT_EQ(e.size(), ArbitrationEvents::kCapacity);
  EXPECT_EQ(e.dropped(), 3u);
}

}  // namespace
