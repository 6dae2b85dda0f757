#include "hexa/core/lockstep_protocol.hpp"

#include <algorithm>

namespace hexa {

bool RequiredSetpointTick(std::uint64_t tick, int supervisor_every_ticks,
                          std::uint64_t& setpoint_tick) {
  if (tick == 0) return false;
  const auto every = static_cast<std::uint64_t>(supervisor_every_ticks);
  setpoint_tick = every * ((tick - 1) / every);
  return true;
}

void SetSetpointInput(const IssuedSetpoint* setpoint, LegControllerInput& input) {
  input.has_setpoint = setpoint != nullptr;
  if (setpoint == nullptr) return;
  input.setpoint_tick = setpoint->tick;
  input.setpoint_time_s = setpoint->time_s;
  input.setpoint_length_m = setpoint->value.length_m;
  input.setpoint_velocity_m_s = setpoint->value.velocity_m_s;
  input.setpoint_acceleration_m_s2 = setpoint->value.acceleration_m_s2;
  input.correction_m = setpoint->value.correction_m;
  input.hold = setpoint->value.hold;
  input.feedforward_valid = setpoint->value.feedforward_valid;
  input.feedforward_force_n = setpoint->value.feedforward_force_n;
  input.feedforward_force_rate_n_s = setpoint->value.feedforward_force_rate_n_s;
}

void LockstepBarrier::Begin(std::uint64_t tick, LegMask awaited, std::int64_t now_ns) {
  tick_ = tick;
  awaited_ = awaited;
  missing_ = awaited;
  began_ns_ = now_ns;
  next_reask_ns_ = now_ns + params_.reask_after_ns;
}

bool LockstepBarrier::Answer(int leg_id, std::uint64_t answered_tick) {
  if (leg_id >= 1 && leg_id <= static_cast<int>(kNumLegs) && answered_tick == tick_) {
    missing_ = static_cast<LegMask>(missing_ & ~LegBit(leg_id));
  }
  return complete();
}

bool LockstepBarrier::Release(LegMask legs) {
  missing_ = static_cast<LegMask>(missing_ & ~legs);
  return complete();
}

const char* ToString(SilentLegVerdict verdict) {
  switch (verdict) {
    case SilentLegVerdict::kWait: return "wait";
    case SilentLegVerdict::kLivelinessLost: return "liveliness lost";
    case SilentLegVerdict::kWriterGone: return "writer gone";
    case SilentLegVerdict::kProcessEnded: return "process ended";
  }
  return "?";
}

SilentLegVerdict JudgeSilentLeg(const LegWriterCounts& writers) {
  if (writers.alive > 0) return SilentLegVerdict::kWait;
  return writers.not_alive > 0 ? SilentLegVerdict::kLivelinessLost : SilentLegVerdict::kWriterGone;
}

SilentLegVerdict JudgeSilentLegLockstep(const SilentLegFacts& f) {
  if (f.processes > 0 && f.processes_ended >= f.processes) return SilentLegVerdict::kProcessEnded;
  if (f.writers.alive > 0) return SilentLegVerdict::kWait;  // it (or a standby taking over) answers
  if (f.writers.not_alive == 0) return SilentLegVerdict::kWriterGone;
  // Every writer whose lease lapsed belongs to a controller that says its cycle is stuck (a
  // standby that is only stopped keeps the leg waiting: it takes over when it runs again).
  if (f.processes_stuck > 0 && f.processes_stuck >= f.writers.not_alive)
    return SilentLegVerdict::kLivelinessLost;
  return SilentLegVerdict::kWait;
}

ControlCycleWatch::Cause ControlCycleWatch::Check(std::uint64_t cycle_sequence, bool unpublished,
                                                  std::uint64_t unpublished_tick,
                                                  bool cycle_thread_starved) {
  Cause now = Cause::kNone;
  if ((cycle_sequence & 1u) != 0 && cycle_sequence == last_sequence_) {
    // The same cycle is still running; if its thread was kept waiting for a CPU meanwhile,
    // this check says nothing about the cycle: neither counted nor a reset.
    if (cycle_thread_starved) return cause_;
    now = Cause::kHang;
  } else if (unpublished && last_unpublished_ && unpublished_tick == last_tick_) {
    now = Cause::kSilence;  // the same answer is still unpublished
  }
  last_sequence_ = cycle_sequence;
  last_unpublished_ = unpublished;
  last_tick_ = unpublished_tick;
  checks_ = now == Cause::kNone ? 0 : checks_ + 1;
  // kStuckChecks checks in a row, i.e. kStuckChecks - 1 repeats after the first sighting.
  cause_ = checks_ >= kStuckChecks - 1 ? now : Cause::kNone;
  return cause_;
}

bool RealtimeLapseMeansDead(const LegWriterCounts& writers, std::int64_t command_age_ticks,
                            std::int64_t confirm_ticks) {
  if (writers.alive > 0) return false;
  return command_age_ticks < 0 || command_age_ticks >= confirm_ticks;
}

LockstepBarrier::Action LockstepBarrier::Check(std::int64_t now_ns) {
  if (complete()) return Action::kWait;
  if (now_ns - began_ns_ >= params_.timeout_ns) return Action::kTimeout;
  if (now_ns >= next_reask_ns_) {
    next_reask_ns_ = now_ns + params_.reask_after_ns;
    ++reasks_total_;
    return Action::kReask;
  }
  return Action::kWait;
}

std::int64_t LockstepBarrier::next_check_ns() const {
  return std::min(next_reask_ns_, began_ns_ + params_.timeout_ns);
}

}  // namespace hexa
