// The plant node's command side: taking the leg controllers' valve commands into the
// arbitration, the supervisor's interlock reports, the facts lockstep judges silent legs by,
// and the wording of every fault event the arbitration emits (docs/faults.md).
#include <cstdio>
#include <cstring>

#include "plant_node.hpp"

namespace hexa::plant_sim {
namespace {

SourceLiveliness SourceLivelinessOf(comm::WriterLiveliness l) {
  switch (l) {
    case comm::WriterLiveliness::kAlive: return SourceLiveliness::kAlive;
    case comm::WriterLiveliness::kNotAlive: return SourceLiveliness::kNotAlive;
    case comm::WriterLiveliness::kGone: return SourceLiveliness::kGone;
    case comm::WriterLiveliness::kUnknown: break;
  }
  return SourceLiveliness::kUnknown;
}

hexa_msg_FaultReason WireReason(FaultReason reason) { return static_cast<hexa_msg_FaultReason>(reason); }

}  // namespace

void PlantNode::TakeCommands(bool feed_barrier) {
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    auto& reader = valve_readers_.leg(leg);
    while (reader.Take() > 0) {
      for (std::size_t k = 0; k < reader.count(); ++k) {
        if (!reader.info(k).valid_data) continue;
        const auto& c = reader.sample(k);
        const dds_sample_info_t& info = reader.info(k);
        // Only the session's own controllers command a valve (docs/faults.md, "Foreign
        // commands"): an unauthenticated sample is refused and its writer reported.
        const comm::CommandTrust trust = reader.Authenticate(k);
        if (!comm::Trusted(trust)) {
          refusals_.Refuse(reader.get(), info, trust, "ValveCommand", static_cast<uint8_t>(leg),
                           tick_, faults_, *log_);
          continue;
        }
        if (c.leg_id != leg) {  // a writer of leg `leg`'s partition wrote another leg's key
          RejectCommand(leg, c, info);
          continue;
        }
        // The reader's ownership: the live primary's samples, else the live standby's
        // (CommandArbitration::Offer, with the reader's per-writer liveliness).
        const comm::StatusCounters& status = reader.status();
        const auto liveliness = [&status](std::uint64_t writer) {
          return SourceLivelinessOf(status.LivelinessOf(writer));
        };
        CommandSample s;
        s.leg = leg;
        s.writer = info.publication_handle;
        s.standby = c.standby;
        s.answered_tick = c.header.tick;
        s.valve_v = c.valve_v;
        s.compute_s = c.compute_time_s;
        events_.Clear();
        if (arbitration_.Offer(s, tick_, liveliness, events_)) {
          relay_.Offer(leg, c.header.tick,
                       FeedbackPart{c.feedback_valid, c.feedback_force_n, c.feedback_rate_n_s});
          if (feed_barrier) lockstep_.Answer(leg, c.header.tick);
        }
        Report(events_);
      }
    }
  }
}

void PlantNode::RejectCommand(int reader_leg, const hexa_msg_ValveCommand& c,
                              const dds_sample_info_t& info) {
  // Leg N's partition is granted to leg N's identities only (DDS Security): a sample for
  // another leg from there is an attempt to command that leg. Refused, counted, and logged
  // at the first one and every 1000th (the writer's GUID lookup allocates: not per sample).
  const std::uint64_t n = ++rejected_per_leg_[static_cast<std::size_t>(reader_leg - 1)];
  if (n != 1 && n % 1000 != 0) return;
  log_->warn("REJECTED valve command for leg {} (tick {}, {:.6g} V) from a writer in partition "
             "{} [{}]: only leg {}'s identities may write there; {} rejected so far",
             static_cast<int>(c.leg_id), c.header.tick, c.valve_v, comm::LegPartition(reader_leg),
             valve_readers_.leg(reader_leg).DescribeWriter(info.publication_handle), reader_leg, n);
}

void PlantNode::TakeFaultEvents() {
  // Polled, never a data callback: this process writes FaultEvents while holding the cycle's mutex, and
  // Cyclone may deliver to a local reader's callback inside that write (self-deadlock).
  while (fault_reader_.Take() > 0) {
    for (std::size_t k = 0; k < fault_reader_.count(); ++k) {
      if (!fault_reader_.info(k).valid_data) continue;
      const hexa_msg_FaultEvent& f = fault_reader_.sample(k);
      if (f.reason == hexa_msg_FAULT_ESTOP && std::strcmp(f.source_node, "supervisor") == 0) {
        unsigned sequence = 0;
        if (std::sscanf(f.detail, "e-stop: operator command #%u", &sequence) == 1) LatchOperatorEstop(sequence);
        continue;
      }
      if (f.reason != hexa_msg_FAULT_SENSOR_INCONSISTENT) continue;
      events_.Clear();
      arbitration_.Interlock(f.leg_id, tick_, events_);  // the valve closes, for good
      if (!events_.empty())
        log_->error("leg {} tick {}: {} reports its length inconsistent: valve held at null from "
                    "now on", f.leg_id, tick_, f.source_node);
    }
  }
}

LegArray<LegWriterCounts> PlantNode::WriterCounts() const {
  LegArray<LegWriterCounts> c{};
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) c[static_cast<std::size_t>(leg - 1)] = writers_.Counts(leg);
  return c;
}

SilentLegFacts PlantNode::LegFacts(int leg) {
  const std::size_t i = static_cast<std::size_t>(leg - 1);
  SilentLegFacts f;
  f.writers = writers_.Counts(leg);
  auto add = [&](const std::string& name) {
    if (runtime_.peer_processes().Known(name)) {
      ++f.processes;
      if (runtime_.peer_processes().State(name) == node::PeerProcessState::kEnded) ++f.processes_ended;
    }
    // The controller's main thread says its cycle is stuck (leg_node: ControlCycleWatch).
    if (peers_.StateOf(name) == hexa_msg_NODE_FAULT) ++f.processes_stuck;
  };
  add(leg_name_[i]);
  if (options_.expect_standbys) add(standby_name_[i]);
  return f;
}

void PlantNode::JudgeSilentLegs(std::int64_t now_ns) {
  // Lockstep: facts about the legs' processes, never the wall clock alone
  // (JudgeSilentLegLockstep). A leg that is slow, stopped or not scheduled is waited for; the
  // lockstep timeout stays the last resort. A tick normally completes within a millisecond:
  // the processes are looked at (which reads /proc and NodeStatus under the loop's lock) only
  // once it has waited a few.
  const LockstepBarrier& barrier = lockstep_.barrier();
  const std::int64_t silent_ns = now_ns - barrier.began_ns();
  if (barrier.complete() || silent_ns < 5'000'000) return;
  writers_.Refresh(valve_readers_);
  peers_.Poll();
  LegArray<SilentLegFacts> facts{};
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
    if (barrier.missing() & LegBit(leg)) facts[static_cast<std::size_t>(leg - 1)] = LegFacts(leg);
  events_.Clear();
  const LegMask dead = arbitration_.JudgeSilentLegs(tick_, barrier.missing(), facts, silent_ns, events_);
  Report(events_);
  if (dead == 0) return;
  lockstep_.Release(dead);
  AdvanceIfComplete();
}

void PlantNode::ReportGoneWriters() {
  events_.Clear();
  arbitration_.ReportGoneWriters(tick_, WriterCounts(), events_);
  Report(events_);
}

void PlantNode::Report(const ArbitrationEvents& events) {
  for (const ArbitrationEvent& e : events) {
    const std::size_t i = e.leg > 0 ? static_cast<std::size_t>(e.leg - 1) : 0;
    const auto answered = static_cast<unsigned long long>(e.answered_tick);
    char detail[160] = "";
    // Published first, then logged: the event's timestamp is the detection's.
    const auto publish = [&] { faults_.Publish(static_cast<uint8_t>(e.leg), e.tick, WireReason(e.reason), detail); };
    switch (e.kind) {
      case ArbitrationEventKind::kCommandFault:
        std::snprintf(detail, sizeof detail, "valve command %s (%.6g V, answers tick %llu): valve held at null",
                      ToString(e.check), e.valve_v, answered);
        publish();
        log_->warn("leg {} tick {}: {}", e.leg, e.tick, detail);
        break;
      case ArbitrationEventKind::kNoLiveWriter:
        std::snprintf(detail, sizeof detail, "%s: no live writer of the leg's valve commands "
                      "(last answer: tick %llu): valve held at null",
                      e.reason == FaultReason::kWriterGone ? "writer gone" : "liveliness lost", answered);
        publish();
        log_->warn("leg {} tick {}: {}", e.leg, e.tick, detail);
        break;
      case ArbitrationEventKind::kStillFaulty:
        std::snprintf(detail, sizeof detail, "valve command still %s (%llu faulty ticks): valve held at null",
                      e.forced ? "forced to null" : ToString(e.check),
                      static_cast<unsigned long long>(e.count));
        publish();
        break;
      case ArbitrationEventKind::kEpisodeEnded:
        log_->info("leg {} tick {}: valve commands valid again ({} faulty ticks in the episode)",
                   e.leg, e.tick, e.count);
        break;
      case ArbitrationEventKind::kHostOverload:
        // Every awaited leg stale (or without a live writer) in the same tick is not six
        // controller faults: the host did not run the loop. Said once, with the lateness.
        std::snprintf(detail, sizeof detail,
                      "host overload: all %d legs' commands late at tick %llu (newest answers tick "
                      "%llu); plant wake-up late by up to %.1f ms: the host does not keep 1 ms",
                      static_cast<int>(e.count), static_cast<unsigned long long>(e.tick), answered,
                      figures_.tick_wall.max_s() * 1e3);
        publish();
        log_->error("tick {}: {}", e.tick, detail);
        break;
      case ArbitrationEventKind::kComputeOverrun:
        std::snprintf(detail, sizeof detail, "compute time over the %.3f ms budget for %llu cycles "
                      "in a row (up to %.3f ms, tick %llu): the controller cannot keep 1 kHz",
                      options_.compute_budget.budget_s * 1e3,
                      static_cast<unsigned long long>(options_.compute_budget.overrun_limit),
                      e.compute_s * 1e3, answered);
        publish();
        log_->warn("leg {} tick {}: {}", e.leg, e.tick, detail);
        break;
      case ArbitrationEventKind::kComputeRecovered:
        log_->info("leg {} tick {}: compute time within budget again", e.leg, e.tick);
        break;
      case ArbitrationEventKind::kLegDead:
        if (e.verdict == SilentLegVerdict::kLivelinessLost) {
          std::snprintf(detail, sizeof detail, "liveliness lost: no answer to tick %llu; %s",
                        static_cast<unsigned long long>(e.tick), peers_.DetailOf(leg_name_[i]).c_str());
        } else {
          std::snprintf(detail, sizeof detail, "%s: no answer to tick %llu for %.0f ms (writers: %d "
                        "alive, %d not alive, %d gone; processes ended %d of %d): no longer "
                        "awaited, valve held at null", ToString(e.verdict),
                        static_cast<unsigned long long>(e.tick), static_cast<double>(e.silent_ns) * 1e-6,
                        e.facts.writers.alive, e.facts.writers.not_alive, e.facts.writers.gone,
                        e.facts.processes_ended, e.facts.processes);
        }
        publish();
        log_->error("leg {} tick {}: {}", e.leg, e.tick, detail);
        break;
      case ArbitrationEventKind::kLapseWaited:
        log_->warn("tick {}: leg {}'s lease lapsed ({}): not a fault in lockstep, the plant "
                   "waits for it (logged once per leg, counted)", e.tick, e.leg,
                   runtime_.peer_processes().Known(leg_name_[i]) ? runtime_.peer_processes().Describe(leg_name_[i])
                                                       : "process not known on this host");
        break;
      case ArbitrationEventKind::kWriterGone:
        std::snprintf(detail, sizeof detail, "writer gone: the controller's writer (%d) no longer "
                      "exists: its process ended or its participant's lease expired",
                      static_cast<int>(e.count));
        publish();
        log_->error("leg {} tick {}: {}", e.leg, e.tick, detail);
        break;
      case ArbitrationEventKind::kInterlock: break;  // logged with its source (TakeFaultEvents)
      case ArbitrationEventKind::kLinkReleased:
        log_->info("leg {} tick {}: a writer has been alive for 100 ticks: valve released", e.leg, e.tick);
        break;
    }
  }
  if (events.dropped() > 0) log_->error("{} fault events beyond the list's capacity not reported", events.dropped());
}

}  // namespace hexa::plant_sim
