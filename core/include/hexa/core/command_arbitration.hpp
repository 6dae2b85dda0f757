// Command arbitration (docs/faults.md): what the plant, or any node in front of the valves,
// does with the leg controllers' commands before a valve moves. Written once for the plant
// service and the in-process simulation (core/lockstep_simulation), so that the two cannot
// drift. It owns, per leg:
//   - the command source: which authenticated writer's samples apply (the live primary, else
//     the live standby: core/command_source.hpp) and the newest answer of the owner;
//   - command hygiene (core/command_hygiene.hpp): missing, stale, not finite or out of range
//     -> the valve's null voltage, one fault event per episode, repeated while it lasts;
//   - the compute budget of each writer (WriterComputeBudgets);
//   - dead legs: lockstep judges facts about the controller processes
//     (JudgeSilentLegLockstep), real time the writers' liveliness with the lapse rule
//     (RealtimeLapseMeansDead: a lapse while the commands are fresh is the host's, counted);
//     a dead leg's valve is held at null, its cause reported once;
//   - the interlock: a leg whose length the supervisor found inconsistent is held at null;
//   - the host-overload rule: every awaited leg late in the same real-time tick is one
//     FAULT_HOST_OVERLOAD of the host, not six leg faults.
//
// Shape (Ruckig-style): a const model (ArbitrationParams) and the mutable state in
// CommandArbitration; once per tick Update(ArbitrationInput) -> ArbitrationOutput (six safe
// voltages, the fault events, the command ages); between ticks the calls that feed what the
// node learns (Offer a command sample, Interlock, JudgeSilentLegs, ReportGoneWriters), each
// returning its events. Pure: no clock (ticks and durations are arguments), no DDS, no
// allocation, no exceptions. Events carry the figures a node needs to word the report; the
// node publishes those with a reason and logs the others.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "hexa/core/command_hygiene.hpp"
#include "hexa/core/command_source.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/supervisor.hpp"

namespace hexa {

// The wire reason of a command check (kNone for kOk and kAwaitingFirst).
FaultReason FaultOf(CommandCheck check);
// The wire reason of a silent leg's verdict (a process that ended is a writer gone).
FaultReason FaultOf(SilentLegVerdict verdict);

enum class ArbitrationEventKind : std::uint8_t {
  kCommandFault,      // an episode of invalid commands began (reason from the check)
  kNoLiveWriter,      // real time: an episode began on a leg without a live writer
  kStillFaulty,       // the episode goes on: repeated every repeat period
  kEpisodeEnded,      // valid commands again (log only)
  kHostOverload,      // leg 0: every awaited leg late in the same real-time tick
  kComputeOverrun,    // a writer's compute time over budget for overrun_limit cycles
  kComputeRecovered,  // within budget again (log only)
  kLegDead,           // lockstep: a silent leg judged dead, no longer awaited
  kLapseWaited,       // lockstep: the leg's lease lapsed, waited for (log once per leg)
  kWriterGone,        // a leg dead by its lease has no writer left: a crash, not a hang
  kInterlock,         // the supervisor found the leg's length inconsistent (log only)
  kLinkReleased,      // real time: a writer alive for release_after_alive_ticks (log only)
};
const char* ToString(ArbitrationEventKind kind);

struct ArbitrationEvent {
  ArbitrationEventKind kind = ArbitrationEventKind::kCommandFault;
  int leg = 0;                              // 1..6; 0: the host
  FaultReason reason = FaultReason::kNone;  // kNone: for the log only, not a FaultEvent
  std::uint64_t tick = 0;                   // the tick to report it at
  CommandCheck check = CommandCheck::kOk;   // kCommandFault, kStillFaulty
  bool forced = false;                      // kStillFaulty: the valve is forced (dead, interlock)
  double valve_v = 0.0;                     // the newest command's voltage
  std::uint64_t answered_tick = 0;          // the newest command's tick (host: the newest of all)
  std::uint64_t count = 0;                  // fault ticks; gone writers; legs (host overload)
  double compute_s = 0.0;                   // kComputeOverrun: largest in the run
  SilentLegVerdict verdict = SilentLegVerdict::kWait;  // kLegDead
  SilentLegFacts facts;                     // kLegDead
  std::int64_t silent_ns = 0;               // kLegDead: time since the tick began
  bool publish() const { return reason != FaultReason::kNone; }
};

// Fixed capacity: a tick's events (six legs, each at most a start or an end, a release, a
// writer gone; one host event) fit; more are counted in dropped(), never allocated.
class ArbitrationEvents {
 public:
  static constexpr std::size_t kCapacity = 32;
  void Add(const ArbitrationEvent& e) {
    if (count_ < kCapacity) items_[count_++] = e; else ++dropped_;
  }
  void Clear() { count_ = 0; dropped_ = 0; }
  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }
  const ArbitrationEvent& operator[](std::size_t k) const { return items_[k]; }
  const ArbitrationEvent* begin() const { return items_.data(); }
  const ArbitrationEvent* end() const { return items_.data() + count_; }
  std::size_t dropped() const { return dropped_; }

 private:
  std::array<ArbitrationEvent, kCapacity> items_{};
  std::size_t count_ = 0;
  std::size_t dropped_ = 0;
};

struct ArbitrationParams {
  // The valve's range and null; stale_tolerance_ticks: lockstep 0 (every tick is answered),
  // real time a few ticks; startup_grace_ticks: real time, the first command's grace.
  CommandHygieneParams hygiene;
  ComputeBudgetParams compute_budget;
  bool realtime = false;
  int expected_legs = 6;                // the legs that must answer (1..6)
  std::int64_t lapse_confirm_ticks = 10;  // real time: the liveliness lease in ticks
  std::uint32_t release_after_alive_ticks = 100;  // real time: a dead leg's writer alive this long
  std::uint64_t repeat_every_ticks = 100;         // an episode in effect is reported again
};

// One command sample as it arrived from an authenticated writer of its leg.
struct CommandSample {
  int leg = 0;                  // 1..6
  std::uint64_t writer = 0;     // nonzero id (DDS: the publication handle)
  bool standby = false;         // the writer says it is the leg's hot standby
  std::uint64_t answered_tick = 0;
  double valve_v = 0.0;
  double compute_s = 0.0;       // the controller's compute time for it
};

struct ArbitrationInput {
  std::uint64_t tick = 0;  // the tick the valves are for
  // Real time: each leg's writers as the transport sees them now (their liveliness).
  LegArray<LegWriterCounts> writers{};
  bool writers_valid = false;  // real time: judge the links from `writers`
  // Real time: the plant's schedule slipped lately: the controllers catch up over a few ticks,
  // so a lapse waits for the stale tolerance, not only the lease.
  bool after_slip = false;
  // Real time: report legs dead by their lease whose writers are gone now (every 100 ticks).
  bool report_gone_writers = false;
};

struct ArbitrationOutput {
  LegArray<double> valve_v{};        // what the valves get this tick
  LegArray<CommandCheck> checks{};   // per leg, after forcing (a forced leg is at least kMissing)
  LegArray<std::int64_t> command_age_ticks{};  // tick - newest answered tick; -1: none yet
  LegArray<bool> forced{};           // dead or interlocked: null whatever the command says
  bool host_overload = false;        // every awaited leg late this tick (real time)
  ArbitrationEvents events;
};

class CommandArbitration {
 public:
  explicit CommandArbitration(const ArbitrationParams& params);

  // A sample of `s.leg`'s commands from an authenticated writer of that leg. The owner's
  // (CommandSourceSelector, with `liveliness(writer) -> SourceLiveliness`) sample counts for
  // the writer's compute budget (older answers too: they show a slow primary) and, when not
  // older than the newest, becomes the leg's command. True when it did (the leg answered
  // s.answered_tick). `tick`: the clock's tick now, for the events.
  template <typename LivelinessOf>
  bool Offer(const CommandSample& s, std::uint64_t tick, LivelinessOf&& liveliness,
             ArbitrationEvents& events) {
    const std::size_t i = static_cast<std::size_t>(s.leg - 1);
    if (sources_[i].Offer(s.writer, s.standby, {s.answered_tick, s.valve_v}, liveliness) !=
        CommandSourceSelector::Verdict::kApply)
      return false;
    return Accept(s, tick, events);
  }

  // Once per tick: hygiene, forcing, dead links (real time), episodes, the host-overload rule.
  void Update(const ArbitrationInput& in, ArbitrationOutput& out);
  // After the step, with the next tick's number: the repeat of every episode in effect (one
  // event per leg per repeat period).
  void EndTick(std::uint64_t next_tick, ArbitrationEvents& events) const;

  // The supervisor reports leg `leg`'s length inconsistent: its valve at null for good.
  void Interlock(int leg, std::uint64_t tick, ArbitrationEvents& events);
  // Lockstep: the legs in `missing` have not answered `tick` for `silent_ns`; `facts` their
  // controllers' state. Returns the legs judged dead (no longer awaited, valves at null).
  LegMask JudgeSilentLegs(std::uint64_t tick, LegMask missing, const LegArray<SilentLegFacts>& facts,
                          std::int64_t silent_ns, ArbitrationEvents& events);
  // A leg dead by its lease whose writers are gone now is reported again, once.
  void ReportGoneWriters(std::uint64_t tick, const LegArray<LegWriterCounts>& writers,
                         ArbitrationEvents& events);

  const ArbitrationParams& params() const { return params_; }
  const LatestCommand& latest(int leg) const { return latest_[static_cast<std::size_t>(leg - 1)]; }
  std::int64_t CommandAge(int leg, std::uint64_t tick) const;
  LegMask dropped() const { return dropped_; }   // lockstep: legs no longer awaited
  bool dead(int leg) const { return link_dead_[static_cast<std::size_t>(leg - 1)]; }
  bool interlocked(int leg) const { return interlock_[static_cast<std::size_t>(leg - 1)]; }
  FaultReason forced_reason(int leg) const { return forced_reason_[static_cast<std::size_t>(leg - 1)]; }
  std::uint32_t episodes(int leg) const { return faults_per_leg_[static_cast<std::size_t>(leg - 1)]; }
  const WriterComputeBudgets& compute(int leg) const { return compute_[static_cast<std::size_t>(leg - 1)]; }
  std::uint64_t lapses_waited() const { return lapses_waited_; }       // lockstep
  std::uint64_t lapses_while_fresh() const { return lapses_while_fresh_; }  // real time

 private:
  bool Accept(const CommandSample& s, std::uint64_t tick, ArbitrationEvents& events);
  void CheckLinks(const ArbitrationInput& in, ArbitrationEvents& events);
  void ReportEpisodes(const ArbitrationInput& in, ArbitrationOutput& out);

  ArbitrationParams params_;
  LegArray<CommandSourceSelector> sources_{};
  LegArray<LatestCommand> latest_{};
  LegArray<WriterComputeBudgets> compute_{};
  LegArray<CommandEpisode> episodes_{};
  LegArray<std::uint32_t> faults_per_leg_{};
  LegMask dropped_ = 0;
  LegArray<bool> link_dead_{};      // no live writer now (real time) / dropped (lockstep)
  LegArray<bool> interlock_{};
  LegArray<FaultReason> forced_reason_{};
  LegArray<bool> gone_reported_{};
  LegArray<std::uint32_t> link_alive_run_{};  // real time: ticks alive since the leg was dead
  LegArray<bool> link_armed_{};               // real time: a writer of the leg seen alive
  LegArray<bool> lapse_while_fresh_{};
  std::uint64_t lapses_while_fresh_ = 0;
  LegArray<std::uint64_t> lapse_waited_tick_{};  // lockstep: tick + 1 of the last lapse waited
  std::uint64_t lapses_waited_ = 0;
  bool host_overload_reported_ = false;
};

}  // namespace hexa
