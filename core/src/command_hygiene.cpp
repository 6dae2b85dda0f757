#include "hexa/core/command_hygiene.hpp"

#include <cmath>

namespace hexa {

const char* ToString(CommandCheck check) {
  switch (check) {
    case CommandCheck::kOk: return "ok";
    case CommandCheck::kAwaitingFirst: return "awaiting first command";
    case CommandCheck::kMissing: return "missing";
    case CommandCheck::kStale: return "stale";
    case CommandCheck::kNotFinite: return "not finite";
    case CommandCheck::kOutOfRange: return "out of range";
  }
  return "unknown";
}

CommandHygieneParams CommandHygieneParams::FromValve(const ValveParams& valve,
                                                     std::uint64_t stale_tolerance_ticks) {
  CommandHygieneParams p;
  p.min_voltage_v = valve.min_voltage_v;
  p.max_voltage_v = valve.max_voltage_v;
  p.null_voltage_v = valve.null_voltage_v;
  p.stale_tolerance_ticks = stale_tolerance_ticks;
  return p;
}

CommandCheck CheckCommand(const LatestCommand& command, std::uint64_t current_tick,
                          const CommandHygieneParams& params) {
  if (!command.received) {
    const std::uint64_t grace = params.startup_grace_ticks > params.stale_tolerance_ticks
                                    ? params.startup_grace_ticks
                                    : params.stale_tolerance_ticks;
    return current_tick <= grace ? CommandCheck::kAwaitingFirst : CommandCheck::kMissing;
  }
  // A command from the future (tick beyond the plant's) is as wrong as an old one.
  if (command.answered_tick > current_tick ||
      current_tick - command.answered_tick > params.stale_tolerance_ticks) {
    return CommandCheck::kStale;
  }
  if (!std::isfinite(command.valve_v)) return CommandCheck::kNotFinite;
  if (command.valve_v < params.min_voltage_v || command.valve_v > params.max_voltage_v) {
    return CommandCheck::kOutOfRange;
  }
  return CommandCheck::kOk;
}

double SafeValveVoltage(const LatestCommand& command, CommandCheck check,
                        const CommandHygieneParams& params) {
  return check == CommandCheck::kOk ? command.valve_v : params.null_voltage_v;
}

bool IsCommandFault(CommandCheck check) {
  return check != CommandCheck::kOk && check != CommandCheck::kAwaitingFirst;
}

CommandEpisode::Event CommandEpisode::Update(CommandCheck check) {
  if (IsCommandFault(check)) {
    ok_run_ = 0;
    latest_ = check;
    ++fault_ticks_;
    if (active_) return Event::kNone;
    active_ = true;
    first_ = check;
    fault_ticks_ = 1;
    ++episodes_;
    return Event::kStarted;
  }
  if (!active_ || check != CommandCheck::kOk) return Event::kNone;
  if (++ok_run_ < clear_after_ok_ticks_) return Event::kNone;
  active_ = false;
  return Event::kEnded;
}

ComputeBudgetMonitor::Event ComputeBudgetMonitor::Update(double compute_s,
                                                         const ComputeBudgetParams& params) {
  ++cycles_;
  if (compute_s > max_s_) max_s_ = compute_s;
  // Not finite counts as over budget: a controller reporting nonsense is not within it.
  if (!(compute_s <= params.budget_s)) {
    ++over_budget_;
    ok_run_ = 0;
    run_max_s_ = over_run_ == 0 ? compute_s : (compute_s > run_max_s_ ? compute_s : run_max_s_);
    ++over_run_;
    if (!active_ && over_run_ >= params.overrun_limit) {
      active_ = true;
      return Event::kStarted;
    }
    return Event::kNone;
  }
  over_run_ = 0;
  if (active_ && ++ok_run_ >= params.clear_after_ok) {
    active_ = false;
    return Event::kEnded;
  }
  return Event::kNone;
}

ComputeBudgetMonitor::Event WriterComputeBudgets::Update(std::uint64_t writer,
                                                         std::uint64_t tick, double compute_s,
                                                         const ComputeBudgetParams& params) {
  ++updates_;
  std::size_t slot = kSlots;
  for (std::size_t k = 0; k < kSlots; ++k) {
    if (slots_[k].used && slots_[k].writer == writer) {
      slot = k;
      break;
    }
  }
  if (slot == kSlots) {  // a new writer: a free slot, else the one heard from least recently
    slot = 0;
    for (std::size_t k = 0; k < kSlots; ++k) {
      if (!slots_[k].used) {
        slot = k;
        break;
      }
      if (slots_[k].heard < slots_[slot].heard) slot = k;
    }
    slots_[slot] = Slot{};
    slots_[slot].used = true;
    slots_[slot].writer = writer;
  } else if (tick <= slots_[slot].last_tick) {
    slots_[slot].heard = updates_;
    return ComputeBudgetMonitor::Event::kNone;  // this writer's tick again, or an older one
  }
  Slot& s = slots_[slot];
  s.heard = updates_;
  s.last_tick = tick;
  last_ = slot;
  const ComputeBudgetMonitor::Event event = s.monitor.Update(compute_s, params);
  ++cycles_;
  if (!(compute_s <= params.budget_s)) ++over_budget_;
  if (compute_s > max_s_) max_s_ = compute_s;
  return event;
}

}  // namespace hexa
