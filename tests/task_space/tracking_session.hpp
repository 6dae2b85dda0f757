// Runs one paper trajectory in the lockstep simulation as the system does (start at the first
// supervisor tick, until the supervisor is back to idle or holds) and calls `on_tracking_tick`
// after every 1 ms tick of the TRACKING window. Returns true if the run completed (left idle,
// came back to idle, no hold, plant ok). Shared by the closed-loop task-space tests.
#pragma once

#include "hexa/core/lockstep_simulation.hpp"

namespace hexa {

template <typename OnTick>
bool RunTrackingWindow(const LockstepConfig& config, PaperMotion motion, OnTick&& on_tracking_tick) {
  LockstepSimulation sim(config);
  if (sim.Tick() != PlantStatus::kOk) return false;
  const StartRequest start = sim.supervisor().PreparePaperStart(motion);
  bool started = false, left_idle = false;
  SupervisorState state = SupervisorState::kIdle;
  while (sim.time_s() < 60.0) {
    const bool due = sim.supervisor_due();
    const auto cmd = (due && !started) ? OperatorCommandKind::kStart : OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == OperatorCommandKind::kStart ? &start : nullptr) != PlantStatus::kOk) return false;
    if (due) {
      started = true;
      state = sim.supervisor_output().state;
      if (state != SupervisorState::kIdle) left_idle = true;
      if (state == SupervisorState::kHold || (left_idle && state == SupervisorState::kIdle)) break;
    }
    if (state == SupervisorState::kTracking) on_tracking_tick(sim);
  }
  return left_idle && state == SupervisorState::kIdle;
}

}  // namespace hexa
