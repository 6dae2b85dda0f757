#include "hexa/core/lockstep_clock.hpp"

namespace hexa {

LockstepClock::Silence LockstepClock::CheckSilence(std::int64_t now_ns) {
  Silence s;
  s.action = barrier_.Check(now_ns);
  switch (s.action) {
    case LockstepBarrier::Action::kWait:
      s.next_check_ns = barrier_.next_check_ns();
      break;
    case LockstepBarrier::Action::kReask:
      s.legs = barrier_.missing();
      s.reask_supervisor = supervisor_reask_.Due(now_ns);
      break;
    case LockstepBarrier::Action::kTimeout:
      s.legs = barrier_.missing();
      break;
  }
  return s;
}

LockstepClock::Flow LockstepClock::AfterTick(std::uint64_t tick, std::int64_t now_ns) {
  if (params_.sync_every_ticks == 0 || tick % params_.sync_every_ticks != 0) return Flow::kStart;
  if (!ack_wait_requested_ && !ack_wait_active_) {
    // The waiter waits for the acknowledgements while the loop goes on.
    ack_wait_requested_ = true;
    ack_wait_tick_ = tick;
    return Flow::kStartAndWake;
  }
  if (!sync_suspended_ && tick - ack_wait_tick_ >= params_.sync_window_ticks) {
    // The wait begun at ack_wait_tick_ has not ended: the recorder is that far behind. The
    // waiter publishes `tick` when it ends.
    sync_pending_ = true;
    sync_blocked_since_ns_ = now_ns;
    ++sync_blocks_;
    return Flow::kBlocked;
  }
  return Flow::kStart;
}

bool LockstepClock::TakeAckWaitRequest() {
  if (!ack_wait_requested_) return false;
  ack_wait_requested_ = false;
  ack_wait_active_ = true;
  return true;
}

LockstepClock::AckOutcome LockstepClock::AckWaitEnded(bool acked, bool give_up, std::uint64_t tick,
                                                      std::int64_t now_ns) {
  AckOutcome o;
  if (!ack_wait_active_) return o;
  if (acked) {
    ack_wait_active_ = false;
    ++syncs_;
    o.acknowledged = true;
    o.acknowledged_again = sync_suspended_;
    sync_suspended_ = false;
    o.resume = sync_pending_;
  } else if (sync_pending_ && give_up) {
    sync_suspended_ = true;
    ++syncs_given_up_;
    o.given_up = true;
    o.resume = true;
  }
  if (o.resume) {
    sync_pending_ = false;
    sync_wait_s_ += static_cast<double>(now_ns - sync_blocked_since_ns_) * 1e-9;
    if (running_ && !sync_suspended_) {
      ack_wait_requested_ = true;  // the next wait starts at once
      ack_wait_tick_ = tick;
    }
  }
  return o;
}

}  // namespace hexa
