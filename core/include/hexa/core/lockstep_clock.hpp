// The lockstep clock's decisions (docs/architecture.md, "Lockstep"), without the transport:
// the tick's barrier with its re-ask and last-resort timeout (LockstepBarrier), and the flow
// control that keeps a fast loop within a window of a slow recorder. Two clocks drive it: the
// plant service (simulated ticks) and the recorder's deterministic replay (`hexa_recorder play
// --lockstep`: the recording's ticks), so that when a tick is complete, when a silent leg is
// asked again and when it is given up are decided by the same code for both.
//
// Recorder flow control: every sync_every_ticks the loop asks for an acknowledgement wait
// (the node's main thread waits, beside the loop, until every reliable reader has
// acknowledged what was written so far). The loop goes on, and stops only when such a wait,
// begun window_ticks ago, has not ended; it resumes when the wait ends or is given up (a
// reader that never acknowledges must not stop the control loop: after a give-up the clock
// does not block again until a wait succeeds).
//
// Who calls what: the thread that advances the loop calls ReadyToStep, AfterTick, Begin and
// Answer; the thread that waits for acknowledgements calls TakeAckWaitRequest and
// AckWaitEnded. Both under the node's loop lock. Pure: times are arguments, no I/O, no
// allocation.
#pragma once

#include <cstdint>

#include "hexa/core/lockstep_protocol.hpp"

namespace hexa {

struct LockstepClockParams {
  LockstepBarrierParams barrier;
  // Re-asks of the supervisor back off within a tick (the re-ask period, then doubling up to
  // this): a supervisor that is only slow is not buried under repeated inputs
  // (docs/liveliness.md, "Re-asks back off").
  std::int64_t supervisor_reask_max_ns = 1'000'000'000;
  std::uint64_t sync_every_ticks = 0;  // 0: no recorder flow control
  std::uint64_t sync_window_ticks = 1200;
};

class LockstepClock {
 public:
  explicit LockstepClock(const LockstepClockParams& params = {})
      : params_(params),
        barrier_(params.barrier),
        supervisor_reask_(params.barrier.reask_after_ns, params.supervisor_reask_max_ns) {}

  // What the loop does after a completed tick `tick` (the tick now to be published).
  enum class Flow : std::uint8_t {
    kStart,          // publish it now
    kStartAndWake,   // publish it now; an acknowledgement wait was asked for: wake the waiter
    kBlocked,        // do not publish: the wait begun a window ago has not ended; wake the waiter
  };

  void Run(std::uint64_t last_tick) { running_ = true; last_tick_ = last_tick; }
  void Stop() { running_ = false; }
  bool running() const { return running_; }
  std::uint64_t last_tick() const { return last_tick_; }

  // Tick `tick` published at `now_ns` to the legs in `awaited`.
  void Begin(std::uint64_t tick, LegMask awaited, std::int64_t now_ns) {
    supervisor_reask_.Begin(now_ns);
    barrier_.Begin(tick, awaited, now_ns);
  }
  // At a re-ask of the legs (LockstepBarrier::Check): is the supervisor to be asked again too?
  bool SupervisorReaskDue(std::int64_t now_ns) { return supervisor_reask_.Due(now_ns); }

  // What the silence of the legs the tick still awaits calls for at `now_ns`.
  struct Silence {
    LockstepBarrier::Action action = LockstepBarrier::Action::kWait;
    LegMask legs = 0;                // kReask: the legs to ask again; kTimeout: the legs missing
    bool reask_supervisor = false;   // kReask: the supervisor's inputs are due again as well
    std::int64_t next_check_ns = 0;  // kWait: when to look again at the latest
  };
  Silence CheckSilence(std::int64_t now_ns);
  bool Answer(int leg, std::uint64_t tick) { return barrier_.Answer(leg, tick); }
  bool Release(LegMask legs) { return barrier_.Release(legs); }
  // Every awaited leg answered, the loop runs and no recorder sync holds it.
  bool ReadyToStep() const { return running_ && !sync_pending_ && barrier_.complete(); }
  Flow AfterTick(std::uint64_t tick, std::int64_t now_ns);

  // The waiter: true when a wait was asked for (it is active from now on).
  bool TakeAckWaitRequest();
  bool ack_wait_active() const { return ack_wait_active_; }
  bool sync_pending() const { return sync_pending_; }
  bool sync_suspended() const { return sync_suspended_; }
  // How long the loop has stood still for the pending sync.
  std::int64_t blocked_ns(std::int64_t now_ns) const { return now_ns - sync_blocked_since_ns_; }

  struct AckOutcome {
    bool acknowledged = false;      // the wait ended with every acknowledgement
    bool acknowledged_again = false;  // ... after a give-up (log it)
    bool given_up = false;          // the pending sync was given up now
    bool resume = false;            // the loop may go on: publish the current tick
  };
  // The waiter's wait ended (`acked`) or not; `give_up`: the pending sync has stood still
  // long enough to be given up (the node judges the readers' processes). `tick`: the current.
  AckOutcome AckWaitEnded(bool acked, bool give_up, std::uint64_t tick, std::int64_t now_ns);

  LockstepBarrier& barrier() { return barrier_; }
  const LockstepBarrier& barrier() const { return barrier_; }
  std::uint64_t syncs() const { return syncs_; }              // acknowledgement waits ended
  std::uint64_t sync_blocks() const { return sync_blocks_; }  // of them, the loop stopped for
  std::uint64_t syncs_given_up() const { return syncs_given_up_; }
  double sync_wait_s() const { return sync_wait_s_; }         // time the loop stood still

 private:
  LockstepClockParams params_;
  LockstepBarrier barrier_;
  ReaskBackoff supervisor_reask_;
  bool running_ = false;
  std::uint64_t last_tick_ = UINT64_MAX;
  bool sync_pending_ = false;       // the current tick is not published until the wait ends
  bool ack_wait_requested_ = false;
  bool ack_wait_active_ = false;
  std::uint64_t ack_wait_tick_ = 0;  // the tick at which it was asked for
  std::int64_t sync_blocked_since_ns_ = 0;
  bool sync_suspended_ = false;      // a sync was given up: no blocking until a wait succeeds
  std::uint64_t syncs_ = 0, sync_blocks_ = 0, syncs_given_up_ = 0;
  double sync_wait_s_ = 0.0;
};

}  // namespace hexa
