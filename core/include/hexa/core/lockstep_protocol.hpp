// The lockstep protocol (docs/architecture.md, "Lockstep"), written once. Three users follow
// it: the plant service over DDS, the recorder's deterministic replay over DDS, and the
// in-process simulation (core/lockstep_simulation), so that what makes a tick complete and
// which setpoint a leg uses at a tick cannot drift apart between them.
//
//   tick n: the clock (plant, or replay) publishes leg sensors(n) (and IMU(n) when n % 5 == 0);
//           the supervisor, when n % 5 == 0, answers with setpoints issued at n;
//           leg i answers sensors(n) with its valve command for n, computed with the setpoint
//           issued at s(n) = 5 * floor((n - 1) / 5) (none at n = 0);
//           the clock advances when every awaited leg has answered n.
// The clock does not wait for the supervisor: the legs do (each needs setpoint s(n) before it
// answers n), so the supervisor is inside every tick's barrier without a round trip of its
// own. Pure: no clock (times are arguments), no I/O, no allocation.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "hexa/core/leg_controller.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/supervisor.hpp"

namespace hexa {

// Legs as a bit set: bit (leg_id - 1).
using LegMask = std::uint8_t;
inline constexpr LegMask kAllLegs = 0x3F;
constexpr LegMask LegBit(int leg_id) { return static_cast<LegMask>(1u << (leg_id - 1)); }
constexpr LegMask FirstLegs(int count) {
  return static_cast<LegMask>(count <= 0 ? 0u : (count >= 6 ? 0x3Fu : (1u << count) - 1u));
}

struct LockstepSchedule {
  int supervisor_every_ticks = 5;
  bool SupervisorDue(std::uint64_t tick) const {
    return tick % static_cast<std::uint64_t>(supervisor_every_ticks) == 0;
  }
};

// Index of the setpoint a leg controller uses at tick n: the newest issued strictly before
// n, i.e. at 5 * floor((n - 1) / 5); none at tick 0 (returns false).
bool RequiredSetpointTick(std::uint64_t tick, int supervisor_every_ticks,
                          std::uint64_t& setpoint_tick);

// The clock's side: which awaited legs have answered the current tick, and what to do about
// those that stay silent (ask again, then give up).
struct LockstepBarrierParams {
  // A leg silent this long after the tick began (and again after each re-ask) is asked again:
  // its sensor sample is re-published and it answers from its cache (its state does not
  // advance twice). Recovers a sample lost to a reader that had just matched and the
  // hand-over to a hot standby.
  std::int64_t reask_after_ns = 50'000'000;
  // A tick not complete this long after it began is a fault of the missing legs.
  std::int64_t timeout_ns = 10'000'000'000;
};

class LockstepBarrier {
 public:
  enum class Action : std::uint8_t { kWait, kReask, kTimeout };

  explicit LockstepBarrier(const LockstepBarrierParams& params = {}) : params_(params) {}

  // Tick `tick` was published at `now_ns` to the legs in `awaited`.
  void Begin(std::uint64_t tick, LegMask awaited, std::int64_t now_ns);
  // Leg `leg_id` (1..6) answered tick `answered_tick`. Answers for other ticks (a repeated
  // answer, a late answer of an earlier tick) change nothing. Returns complete().
  bool Answer(int leg_id, std::uint64_t answered_tick);
  // Stops awaiting `legs` for this tick (a leg judged dead: JudgeSilentLeg). Returns complete().
  bool Release(LegMask legs);
  bool complete() const { return missing_ == 0; }
  std::uint64_t tick() const { return tick_; }
  LegMask missing() const { return missing_; }
  LegMask awaited() const { return awaited_; }
  // What the silence of missing() calls for at `now_ns`: kReask at most once per re-ask
  // period, kTimeout once the timeout since Begin() has passed (and on every call after).
  Action Check(std::int64_t now_ns);
  // When the next Check() can return something other than kWait.
  std::int64_t next_check_ns() const;
  std::uint64_t reasks_total() const { return reasks_total_; }
  std::int64_t began_ns() const { return began_ns_; }

 private:
  LockstepBarrierParams params_;
  std::uint64_t tick_ = 0;
  LegMask awaited_ = 0;
  LegMask missing_ = 0;
  std::int64_t began_ns_ = 0;
  std::int64_t next_reask_ns_ = 0;
  std::uint64_t reasks_total_ = 0;
};

// Re-asks of one tick that back off: the first `first_ns` after the tick began, then after
// twice the previous wait, up to `max_ns` between two. For a process that is only slow (its
// CPU starved): every re-ask adds samples it must take, and under DDS Security decrypt, in
// order, before the one it waits for; re-asked at a fixed 50 ms it fell further behind with
// every re-ask (docs/liveliness.md, "Re-asks back off"). A sample lost on the way is still asked
// for again after `first_ns`.
class ReaskBackoff {
 public:
  ReaskBackoff(std::int64_t first_ns, std::int64_t max_ns) : first_ns_(first_ns), max_ns_(max_ns) {}
  // A new tick began at `now_ns`.
  void Begin(std::int64_t now_ns) {
    wait_ns_ = first_ns_;
    next_ns_ = now_ns + wait_ns_;
  }
  // True when a re-ask is due at `now_ns` (then the next one is scheduled).
  bool Due(std::int64_t now_ns) {
    if (now_ns < next_ns_) return false;
    wait_ns_ = std::min(2 * wait_ns_, max_ns_);
    next_ns_ = now_ns + wait_ns_;
    return true;
  }
  std::int64_t next_ns() const { return next_ns_; }

 private:
  std::int64_t first_ns_, max_ns_;
  std::int64_t wait_ns_ = 0, next_ns_ = 0;
};

// What the clock does about an awaited leg that has not answered (docs/faults.md). Its leg
// controller writers as the transport sees them: `alive` writers assert their liveliness (a
// leg controller asserts it only while its control cycle runs and publishes what it computes:
// a crashed, hung or silent controller lets its lease lapse), `not_alive` ones are still
// known but their lease lapsed, `gone` ones disappeared (writer deleted, or its participant's
// lease expired: the process is gone).
struct LegWriterCounts {
  int alive = 0;
  int not_alive = 0;
  int gone = 0;
};

enum class SilentLegVerdict : std::uint8_t {
  kWait,            // a live writer may still answer, or the leg's process is only not running now
  kLivelinessLost,  // no live writer: crashed, hung or silent (lockstep: its process says it is stuck)
  kWriterGone,      // no writer left at all: the process (or its participant) is gone
  kProcessEnded,    // lockstep: every controller process of the leg has ended (same host)
};
const char* ToString(SilentLegVerdict verdict);

// Real time, pure: the cause of a leg without a live writer (kWait while one is alive).
SilentLegVerdict JudgeSilentLeg(const LegWriterCounts& writers);

// Lockstep, pure: what the leg's controllers show while the clock awaits the leg's answer.
// Lockstep has no deadline, so the wall clock alone never makes a leg dead: a lapsed lease
// says only that the process did not run its loop for a lease, which a stopped or starved
// process (a loaded machine, SIGSTOP, a debugger) does as well as a dead one. Dead is a fact
// about the process: it ended (`processes_ended`, from the process ids the launcher gave,
// same host), its writers are gone (DDS: its participant left or its lease of 10 s expired),
// or it runs and says that its control cycle is stuck (`processes_stuck`: its main thread saw
// the same cycle in progress, or an answer computed and not published, at
// kStuckChecks of its own checks in a row: hang or silence).
struct SilentLegFacts {
  LegWriterCounts writers;
  int processes = 0;         // the leg's controller processes with a known process id
  int processes_ended = 0;   // of them, ended
  int processes_stuck = 0;   // the leg's controllers that report their control cycle stuck
};
SilentLegVerdict JudgeSilentLegLockstep(const SilentLegFacts& facts);

// A leg controller's main thread calls its control cycle stuck after this many checks in a row
// (one every quarter lease) that found the same cycle in progress, or the same answer computed
// and not published. Counted in the controller's own checks, not in wall time: a process that
// is not scheduled makes no checks and is never called stuck. The cycle runs on another thread
// (Cyclone's receive thread), which the machine may not run while the main thread runs on
// another CPU: a check after which the cycle's thread spent more of the interval waiting for a
// CPU than running does not count (the thread's scheduler statistics, /proc schedstat).
inline constexpr int kStuckChecks = 4;

// The leg controller's watch of its own control cycle (main thread), pure: fed at each check
// with what the cycle shows, it says when the cycle is stuck.
class ControlCycleWatch {
 public:
  enum class Cause : std::uint8_t { kNone, kHang, kSilence };
  // `cycle_sequence`: odd while a cycle runs (incremented at its start and end); `unpublished`:
  // an answer was computed and not published, for tick `unpublished_tick`;
  // `cycle_thread_starved`: since the previous check the cycle's thread waited for a CPU more
  // than it ran (the machine's doing, not the cycle's: such a check does not count).
  Cause Check(std::uint64_t cycle_sequence, bool unpublished, std::uint64_t unpublished_tick,
              bool cycle_thread_starved = false);
  Cause cause() const { return cause_; }

 private:
  std::uint64_t last_sequence_ = 0;
  bool last_unpublished_ = false;
  std::uint64_t last_tick_ = 0;
  int checks_ = 0;
  Cause cause_ = Cause::kNone;
};

// Real time, pure: is a leg with no live writer dead? Only if its commands have stopped too:
// its newest applied answer is at least `confirm_ticks` old (the plant: the lease in ticks, or
// the stale-command tolerance just after its schedule slipped). A lapse while the leg's
// commands are fresh is the host's timing (a stall of the control CPU delays the lease renewal
// and the plant's own ticks alike), not the leg: a crashed, hung or silent controller stops
// answering, so its command age reaches the lease when the lease lapses. `command_age_ticks` < 0: no command yet (the start-up grace).
bool RealtimeLapseMeansDead(const LegWriterCounts& writers, std::int64_t command_age_ticks,
                            std::int64_t confirm_ticks);

// A setpoint as issued by the supervisor at tick `tick`: what LegSetpoint carries on the wire.
struct IssuedSetpoint {
  std::uint64_t tick = 0;
  double time_s = 0.0;
  SupervisorLegSetpoint value;
};

// Puts `setpoint` (nullptr: none) into a leg controller's input, the same way for every user
// of the protocol.
void SetSetpointInput(const IssuedSetpoint* setpoint, LegControllerInput& input);

// A leg's side: the setpoints it has received (newest few, in tick order) and the rule that
// says whether tick n can be answered yet. `Setpoint` is whatever the caller stores per
// setpoint; it must have `std::uint64_t tick` (the tick it was issued at).
template <typename Setpoint, std::size_t kCapacity = 16>
class SetpointRing {
 public:
  // Stores a setpoint; one not newer than the newest stored is ignored (returns false).
  bool Add(const Setpoint& s) {
    if (count_ > 0 && s.tick <= items_[newest_].tick) return false;
    newest_ = count_ == 0 ? 0 : (newest_ + 1) % kCapacity;
    items_[newest_] = s;
    if (count_ < kCapacity) ++count_;
    return true;
  }
  // The setpoint issued at `tick`, or nullptr.
  const Setpoint* Find(std::uint64_t tick) const {
    for (std::size_t k = 0; k < count_; ++k) {
      const Setpoint& s = items_[(newest_ + kCapacity - k) % kCapacity];
      if (s.tick == tick) return &s;
      if (s.tick < tick) break;  // older ones cannot match
    }
    return nullptr;
  }
  const Setpoint* newest() const { return count_ > 0 ? &items_[newest_] : nullptr; }
  // Lockstep: the setpoint leg controllers use at `tick`, or nullptr (none at tick 0, or not
  // received yet).
  const Setpoint* ForTick(std::uint64_t tick, int supervisor_every_ticks) const {
    std::uint64_t required = 0;
    if (!RequiredSetpointTick(tick, supervisor_every_ticks, required)) return nullptr;
    return Find(required);
  }
  // Lockstep: true when tick `tick` can be answered now: at tick 0 (no setpoint exists), when
  // its setpoint is here, or when a newer one is (setpoints come in tick order: the required
  // one was skipped and will never come; the controller then holds on a stale setpoint).
  bool CanAnswer(std::uint64_t tick, int supervisor_every_ticks) const {
    std::uint64_t required = 0;
    if (!RequiredSetpointTick(tick, supervisor_every_ticks, required)) return true;
    const Setpoint* n = newest();
    return n != nullptr && (n->tick >= required);
  }
  // Real time: the newest setpoint not issued after `tick`, or nullptr.
  const Setpoint* NewestNotAfter(std::uint64_t tick) const {
    for (std::size_t k = 0; k < count_; ++k) {
      const Setpoint& s = items_[(newest_ + kCapacity - k) % kCapacity];
      if (s.tick <= tick) return &s;
    }
    return nullptr;
  }

 private:
  Setpoint items_[kCapacity]{};
  std::size_t newest_ = 0;
  std::size_t count_ = 0;
};

}  // namespace hexa
