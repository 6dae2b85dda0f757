// The plant node's device side on top of DeviceLink (device_link.hpp, the part without DDS):
// the bring-up, one exchange per tick, the e-stop as the device reports it, the operator's
// e-stop and reset, and the device's events as FaultEvents and log lines.
#include <string>

#include "plant_node.hpp"

namespace hexa::plant_sim {

void PlantNode::BringUpDevice() {
  const std::string answered = link_.BringUp();  // throws naming the cause
  if (!answered.empty()) log_->info("{}", answered);
}

device::DeviceStatus PlantNode::ExchangeWithDevice(const LegArray<double>& valve_v) {
  device_events_.Clear();
  // Not active (hardware lifecycle): the device holds every valve at its safe value.
  const device::DeviceStatus status =
      link_.Exchange(valve_v, tick_, device_events_, /*safe_state=*/!hardware_.apply_commands);
  Report(device_events_);
  return status;
}

void PlantNode::JudgeDeviceSafety() {
  device_events_.Clear();
  link_.JudgeSafety(tick_, device_events_);
  Report(device_events_);
}

void PlantNode::Report(const DeviceEvents& events) {
  for (std::size_t i = 0; i < events.size(); ++i) {
    const DeviceEvent& e = events[i];
    if (e.fault()) faults_.Publish(0, e.tick, e.reason(), e.detail);
    const LegArray<double>& v = link_.sensors().applied_valve_v;
    switch (e.kind) {
      case DeviceEvent::Kind::kEstopLatched:
        log_->error("tick {}: FAULT_ESTOP: {} (applied [{:.3f} {:.3f} {:.3f} {:.3f} {:.3f} {:.3f}] V); "
                    "re-arm: close the loop, then an operator reset", e.tick, e.detail, v[0], v[1],
                    v[2], v[3], v[4], v[5]);
        break;
      case DeviceEvent::Kind::kEstopResetRefused:
      case DeviceEvent::Kind::kOperatorEstop:
        log_->error("tick {}: FAULT_ESTOP: {}", e.tick, e.detail);
        break;
      case DeviceEvent::Kind::kLinkLost:
        log_->error("tick {}: FAULT_BOARD_LINK: {}: the last sample is published on, the supervisor "
                    "holds, the board's watchdog holds the valves safe", e.tick, e.detail);
        break;
      case DeviceEvent::Kind::kEstopReleased:
        log_->warn("tick {}: e-stop latch reset: the valves follow the commands again", e.tick);
        break;
      case DeviceEvent::Kind::kLinkBack:
        log_->warn("tick {}: {}", e.tick, e.detail);
        break;
      case DeviceEvent::Kind::kFrameRefused:
        log_->warn("tick {}: {} (the first; the tick republishes the last sample, every refusal is "
                   "counted)", e.tick, e.detail);
        break;
    }
  }
}

void PlantNode::LatchOperatorEstop(std::uint32_t sequence) {
  device_events_.Clear();
  link_.LatchOperatorEstop(sequence, tick_, device_events_);
  Report(device_events_);
}

void PlantNode::TakeOperatorCommands() {
  // The supervisor's word on an operator e-stop (a FaultEvent) when this reader missed it;
  // real time: every 10 ticks with the interlock (RunRealtime), lockstep: every tick.
  if (options_.common.mode == node::TimeMode::kLockstep) TakeFaultEvents();
  while (operator_reader_.Take() > 0) {
    for (std::size_t k = 0; k < operator_reader_.count(); ++k) {
      if (!operator_reader_.info(k).valid_data) continue;
      const hexa_msg_OperatorCommand& c = operator_reader_.sample(k);
      if (c.kind != hexa_msg_OPERATOR_ESTOP && c.kind != hexa_msg_OPERATOR_RESET &&
          c.kind != hexa_msg_OPERATOR_START && c.kind != hexa_msg_OPERATOR_HOME)
        continue;
      // Only the session's operator tools (docs/faults.md, "Foreign commands").
      const comm::CommandTrust trust = operator_reader_.Authenticate(k);
      if (!comm::Trusted(trust)) {
        refusals_.Refuse(operator_reader_.get(), operator_reader_.info(k), trust, "OperatorCommand", 0,
                         tick_, faults_, *log_);
        continue;
      }
      if (c.kind == hexa_msg_OPERATOR_ESTOP) {
        LatchOperatorEstop(c.sequence);
        continue;
      }
      AskActivation(c);  // start / home; a reset only when the activation is automatic
      if (c.kind == hexa_msg_OPERATOR_RESET && link_.RequestEstopReset()) {
        log_->warn("tick {}: operator reset #{}: e-stop reset asked of the rig", tick_,
                   static_cast<unsigned>(c.sequence));
      }
    }
  }
}

void PlantNode::LogDeviceEnd() const {
  log_->info("{}", link_.DescribeEnd());
  if (link_.estop_unsafe_ticks() > 0)
    log_->error("e-stop: {} ticks latched with a valve not at its safe value (the device's report)",
                link_.estop_unsafe_ticks());
}

}  // namespace hexa::plant_sim
