#include "hexa/core/command_arbitration.hpp"

#include <algorithm>

namespace hexa {

FaultReason FaultOf(CommandCheck check) {
  switch (check) {
    case CommandCheck::kMissing: return FaultReason::kCommandDeadlineMissed;
    case CommandCheck::kStale: return FaultReason::kCommandStale;
    case CommandCheck::kNotFinite: return FaultReason::kCommandNotFinite;
    case CommandCheck::kOutOfRange: return FaultReason::kCommandOutOfRange;
    case CommandCheck::kOk:
    case CommandCheck::kAwaitingFirst: break;
  }
  return FaultReason::kNone;
}

FaultReason FaultOf(SilentLegVerdict verdict) {
  switch (verdict) {
    case SilentLegVerdict::kLivelinessLost: return FaultReason::kLivelinessLost;
    case SilentLegVerdict::kWriterGone: return FaultReason::kWriterGone;
    case SilentLegVerdict::kProcessEnded: return FaultReason::kWriterGone;
    case SilentLegVerdict::kWait: break;
  }
  return FaultReason::kNone;
}

const char* ToString(ArbitrationEventKind kind) {
  switch (kind) {
    case ArbitrationEventKind::kCommandFault: return "command fault";
    case ArbitrationEventKind::kNoLiveWriter: return "no live writer";
    case ArbitrationEventKind::kStillFaulty: return "still faulty";
    case ArbitrationEventKind::kEpisodeEnded: return "episode ended";
    case ArbitrationEventKind::kHostOverload: return "host overload";
    case ArbitrationEventKind::kComputeOverrun: return "compute overrun";
    case ArbitrationEventKind::kComputeRecovered: return "compute recovered";
    case ArbitrationEventKind::kLegDead: return "leg dead";
    case ArbitrationEventKind::kLapseWaited: return "lapse waited";
    case ArbitrationEventKind::kWriterGone: return "writer gone";
    case ArbitrationEventKind::kInterlock: return "interlock";
    case ArbitrationEventKind::kLinkReleased: return "link released";
  }
  return "unknown";
}

CommandArbitration::CommandArbitration(const ArbitrationParams& params) : params_(params) {
  forced_reason_.fill(FaultReason::kNone);
}

std::int64_t CommandArbitration::CommandAge(int leg, std::uint64_t tick) const {
  const LatestCommand& l = latest_[static_cast<std::size_t>(leg - 1)];
  return l.received ? static_cast<std::int64_t>(tick) - static_cast<std::int64_t>(l.answered_tick) : -1;
}

bool CommandArbitration::Accept(const CommandSample& s, std::uint64_t tick, ArbitrationEvents& events) {
  const std::size_t i = static_cast<std::size_t>(s.leg - 1);
  // The applying writer's compute time, older answers included: a slow primary's answers are
  // older than its standby's, and they are what shows it is slow.
  WriterComputeBudgets& m = compute_[i];
  switch (m.Update(s.writer, s.answered_tick, s.compute_s, params_.compute_budget)) {
    case ComputeBudgetMonitor::Event::kStarted: {
      ArbitrationEvent e;
      e.kind = ArbitrationEventKind::kComputeOverrun;
      e.leg = s.leg;
      e.reason = FaultReason::kComputeOverrun;
      e.tick = tick;
      e.answered_tick = s.answered_tick;
      e.compute_s = m.last_run_max_s();
      events.Add(e);
      break;
    }
    case ComputeBudgetMonitor::Event::kEnded: {
      ArbitrationEvent e;
      e.kind = ArbitrationEventKind::kComputeRecovered;
      e.leg = s.leg;
      e.tick = tick;
      events.Add(e);
      break;
    }
    case ComputeBudgetMonitor::Event::kNone: break;
  }
  LatestCommand& latest = latest_[i];
  if (latest.received && s.answered_tick < latest.answered_tick) return false;  // older
  latest = LatestCommand{true, s.answered_tick, s.valve_v};
  return true;
}

void CommandArbitration::Interlock(int leg, std::uint64_t tick, ArbitrationEvents& events) {
  if (leg < 1 || leg > static_cast<int>(kNumLegs)) return;
  const std::size_t i = static_cast<std::size_t>(leg - 1);
  if (interlock_[i]) return;
  // The leg's length reading is wrong: its controller drives the leg on a false length (a
  // stuck potentiometer runs it into its end stop). Its valve closes, for good.
  interlock_[i] = true;
  if (forced_reason_[i] == FaultReason::kNone) forced_reason_[i] = FaultReason::kSensorInconsistent;
  ArbitrationEvent e;
  e.kind = ArbitrationEventKind::kInterlock;
  e.leg = leg;
  e.tick = tick;
  events.Add(e);
}

LegMask CommandArbitration::JudgeSilentLegs(std::uint64_t tick, LegMask missing,
                                            const LegArray<SilentLegFacts>& facts,
                                            std::int64_t silent_ns, ArbitrationEvents& events) {
  LegMask dead = 0;
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    if (!(missing & LegBit(leg))) continue;
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    const SilentLegFacts& f = facts[i];
    const SilentLegVerdict v = JudgeSilentLegLockstep(f);
    if (v == SilentLegVerdict::kWait) {
      // A lapsed lease of a process not shown dead or stuck (stopped, not scheduled): waited
      // through, counted once per leg and tick, reported once per leg.
      if (f.writers.alive == 0 && lapse_waited_tick_[i] != tick + 1) {
        ++lapses_waited_;
        if (lapse_waited_tick_[i] == 0) {
          ArbitrationEvent e;
          e.kind = ArbitrationEventKind::kLapseWaited;
          e.leg = leg;
          e.tick = tick;
          e.facts = f;
          events.Add(e);
        }
        lapse_waited_tick_[i] = tick + 1;
      }
      continue;
    }
    dead |= LegBit(leg);
    link_dead_[i] = true;
    forced_reason_[i] = FaultOf(v);
    ArbitrationEvent e;
    e.kind = ArbitrationEventKind::kLegDead;
    e.leg = leg;
    e.reason = FaultOf(v);
    e.tick = tick;
    e.verdict = v;
    e.facts = f;
    e.silent_ns = silent_ns;
    events.Add(e);
    gone_reported_[i] = v != SilentLegVerdict::kLivelinessLost;
  }
  dropped_ |= dead;
  return dead;
}

void CommandArbitration::ReportGoneWriters(std::uint64_t tick, const LegArray<LegWriterCounts>& writers,
                                           ArbitrationEvents& events) {
  // A leg declared dead because its lease lapsed is reported again, once, when its writers
  // are gone too: the process (or its participant) no longer exists - a crash, not a hang.
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    if (!link_dead_[i] || gone_reported_[i]) continue;
    const LegWriterCounts& c = writers[i];
    if (c.alive != 0 || c.not_alive != 0) continue;
    gone_reported_[i] = true;
    ArbitrationEvent e;
    e.kind = ArbitrationEventKind::kWriterGone;
    e.leg = leg;
    e.reason = FaultReason::kWriterGone;
    e.tick = tick;
    e.count = static_cast<std::uint64_t>(c.gone);
    events.Add(e);
  }
}

void CommandArbitration::CheckLinks(const ArbitrationInput& in, ArbitrationEvents& events) {
  // Real time: a leg without a live writer is held at null from this tick (its last commands
  // come from a controller whose loop no longer runs) and reported once (ReportEpisodes); it
  // is released after a writer has been alive for release_after_alive_ticks in a row (a
  // flickering lease stays one episode). A lapse while the leg's commands are still fresh
  // (newer than the lease; after a slip of the plant's schedule, than the stale-command
  // tolerance) is the host delaying the renewal, not the leg (RealtimeLapseMeansDead): it is
  // counted and judged again next tick.
  for (int leg = 1; leg <= params_.expected_legs; ++leg) {
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    const LegWriterCounts& c = in.writers[i];
    if (c.alive > 0) link_armed_[i] = true;
    if (!link_armed_[i]) continue;  // no command yet: the start-up grace covers it
    if (c.alive == 0) {
      link_alive_run_[i] = 0;
      if (link_dead_[i]) continue;
      const std::int64_t confirm =
          in.after_slip ? std::max(params_.lapse_confirm_ticks,
                                   static_cast<std::int64_t>(params_.hygiene.stale_tolerance_ticks))
                        : params_.lapse_confirm_ticks;
      if (!RealtimeLapseMeansDead(c, CommandAge(leg, in.tick), confirm)) {
        if (!lapse_while_fresh_[i]) ++lapses_while_fresh_;
        lapse_while_fresh_[i] = true;
        continue;
      }
      link_dead_[i] = true;
      forced_reason_[i] = FaultOf(JudgeSilentLeg(c));
    } else {
      lapse_while_fresh_[i] = false;
      if (link_dead_[i] && ++link_alive_run_[i] >= params_.release_after_alive_ticks) {
        link_dead_[i] = false;
        forced_reason_[i] = interlock_[i] ? FaultReason::kSensorInconsistent : FaultReason::kNone;
        ArbitrationEvent e;
        e.kind = ArbitrationEventKind::kLinkReleased;
        e.leg = leg;
        e.tick = in.tick;
        events.Add(e);
      }
    }
  }
}

void CommandArbitration::Update(const ArbitrationInput& in, ArbitrationOutput& out) {
  out.events.Clear();
  if (params_.realtime && in.writers_valid) CheckLinks(in, out.events);
  if (in.report_gone_writers) ReportGoneWriters(in.tick, in.writers, out.events);
  int stale_legs = 0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int leg = static_cast<int>(i) + 1;
    out.command_age_ticks[i] = CommandAge(leg, in.tick);
    CommandCheck check = CheckCommand(latest_[i], in.tick, params_.hygiene);
    out.valve_v[i] = SafeValveVoltage(latest_[i], check, params_.hygiene);
    // A dead leg (no live writer; lockstep: no longer awaited) or one whose length reading
    // the supervisor found wrong: valve at null whatever its last command says.
    out.forced[i] = link_dead_[i] || interlock_[i];
    if (out.forced[i]) {
      out.valve_v[i] = params_.hygiene.null_voltage_v;
      if (!IsCommandFault(check)) check = CommandCheck::kMissing;  // keeps the episode open
    }
    out.checks[i] = check;
    if (leg <= params_.expected_legs && (check == CommandCheck::kStale || link_dead_[i])) ++stale_legs;
  }
  // Every awaited leg stale (or without a live writer) in the same tick is not six controller
  // faults: the host did not run the loop (the plant's own wake-ups, the legs or the network
  // were descheduled). Said once, instead of six leg faults.
  out.host_overload = params_.realtime && params_.expected_legs > 1 && stale_legs == params_.expected_legs;
  if (out.host_overload && !host_overload_reported_) {
    host_overload_reported_ = true;
    ArbitrationEvent e;
    e.kind = ArbitrationEventKind::kHostOverload;
    e.leg = 0;
    e.reason = FaultReason::kHostOverload;
    e.tick = in.tick;
    for (int k = 0; k < params_.expected_legs; ++k)
      e.answered_tick = std::max(e.answered_tick, latest_[static_cast<std::size_t>(k)].answered_tick);
    e.count = static_cast<std::uint64_t>(params_.expected_legs);
    out.events.Add(e);
  }
  ReportEpisodes(in, out);
}

void CommandArbitration::ReportEpisodes(const ArbitrationInput& in, ArbitrationOutput& out) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int leg = static_cast<int>(i) + 1;
    const CommandCheck check = out.checks[i];
    switch (episodes_[i].Update(check)) {
      case CommandEpisode::Event::kStarted: {
        ++faults_per_leg_[i];
        if (out.host_overload) break;  // reported once as the host's
        ArbitrationEvent e;
        e.leg = leg;
        e.tick = in.tick;
        e.check = check;
        e.valve_v = latest_[i].valve_v;
        e.answered_tick = latest_[i].answered_tick;
        if (out.forced[i] && (dropped_ & LegBit(leg))) {
          break;  // lockstep: reported when the leg was judged dead (JudgeSilentLegs)
        } else if (out.forced[i] && link_dead_[i]) {
          e.kind = ArbitrationEventKind::kNoLiveWriter;
          e.reason = forced_reason_[i];
          gone_reported_[i] = e.reason == FaultReason::kWriterGone;
        } else if (out.forced[i]) {
          break;  // the interlock: the supervisor reported it
        } else {
          e.kind = ArbitrationEventKind::kCommandFault;
          e.reason = FaultOf(check);
        }
        out.events.Add(e);
        break;
      }
      case CommandEpisode::Event::kEnded: {
        ArbitrationEvent e;
        e.kind = ArbitrationEventKind::kEpisodeEnded;
        e.leg = leg;
        e.tick = in.tick;
        e.count = episodes_[i].fault_ticks();
        out.events.Add(e);
        break;
      }
      case CommandEpisode::Event::kNone: break;
    }
  }
}

void CommandArbitration::EndTick(std::uint64_t next_tick, ArbitrationEvents& events) const {
  // An episode still in effect is repeated at the repeat period (one event per leg, whatever
  // the command does meanwhile), so that a supervisor reset while the cause persists sees
  // the fault again.
  if (params_.repeat_every_ticks == 0 || next_tick % params_.repeat_every_ticks != 0) return;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!episodes_[i].active()) continue;
    ArbitrationEvent e;
    e.kind = ArbitrationEventKind::kStillFaulty;
    e.leg = static_cast<int>(i) + 1;
    e.tick = next_tick;
    e.forced = link_dead_[i] || interlock_[i];
    e.check = episodes_[i].latest();
    e.reason = e.forced ? forced_reason_[i] : FaultOf(episodes_[i].latest());
    e.count = episodes_[i].fault_ticks();
    events.Add(e);
  }
}

}  // namespace hexa
