// The plant node's hardware lifecycle (core/hardware_lifecycle.hpp, docs/faults.md "Hardware
// lifecycle"): each tick reads what the device and the legs' controllers report and the
// activation asked for, lets the core decide, and answers the operator on NodeStatus. Not
// active, the device holds every valve at its safe value (ExchangeWithDevice).
#include <cstdio>

#include "hexa/services/command_answer.hpp"
#include "hexa/services/format_cut.hpp"
#include "plant_node.hpp"

namespace hexa::plant_sim {
namespace {

const char* KindName(hexa_msg_OperatorCommandKind kind) {
  switch (kind) {
    case hexa_msg_OPERATOR_START: return "start";
    case hexa_msg_OPERATOR_HOME: return "home";
    case hexa_msg_OPERATOR_RESET: return "reset";
    default: return "command";
  }
}

// The FaultEvent of a refused automatic activation: the supervisor holds with the cause.
hexa_msg_FaultReason ReasonOf(ActivationRefusal refusal) {
  switch (refusal) {
    case ActivationRefusal::kEstopOpen: return hexa_msg_FAULT_ESTOP;
    case ActivationRefusal::kNoLiveController: return hexa_msg_FAULT_LIVELINESS_LOST;
    case ActivationRefusal::kSensorOutOfRange: return hexa_msg_FAULT_SENSOR_INVALID;
    case ActivationRefusal::kSupplyPressureLow: return hexa_msg_FAULT_SUPPLY_PRESSURE_LOW;
    case ActivationRefusal::kNotConfigured: return hexa_msg_FAULT_BOARD_LINK;
    case ActivationRefusal::kNone: break;
  }
  return hexa_msg_FAULT_NONE;
}

}  // namespace

void PlantNode::AskActivation(const hexa_msg_OperatorCommand& c) {
  const bool operator_activation = options_.activation == HardwareActivation::kOperator;
  const bool asks = c.kind == hexa_msg_OPERATOR_RESET ? !operator_activation : operator_activation;
  if (!asks) return;
  activation_asked_ = true;
  activation_sequence_ = c.sequence;
  activation_kind_ = KindName(c.kind);
}

void PlantNode::UpdateHardware() {
  HardwareLifecycleInput in;
  const device::DeviceSensors& s = link_.sensors();
  in.device_configured = !link_.lost();
  in.estop_loop_open = s.safety.estop_loop_open;
  in.estop_latched = s.safety.estop_latched;
  in.sensors = s.legs;
  const bool automatic = !auto_activation_done_ && options_.activation == HardwareActivation::kAuto;
  auto_activation_done_ = true;
  in.activate = activation_asked_ || automatic;
  // The legs' controllers are looked at only when asked (the process table and the peers'
  // status are read). Live: not judged dead, its process not ended, and a writer of its
  // commands known or its status RUNNING (in real time a best-effort reader knows a writer's
  // liveliness only from its data: none before the first command).
  if (in.activate) peers_.Poll();
  for (int leg = 1; in.activate && leg <= static_cast<int>(kNumLegs); ++leg) {
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    const SilentLegFacts f = LegFacts(leg);  // its writers, its processes (primary, standby)
    const bool ended = f.processes > 0 && f.processes_ended == f.processes;
    const bool running = peers_.StateOf(leg_name_[i]) == hexa_msg_NODE_RUNNING;
    in.leg_controller_live[i] = !(arbitration_.dropped() & LegBit(leg)) && !ended &&
                                (f.writers.alive + f.writers.not_alive > 0 || running);
  }
  if (in.activate && !activation_asked_) activation_kind_ = "automatic activation";
  const std::uint32_t sequence = activation_asked_ ? activation_sequence_ : 0;
  activation_asked_ = false;
  lifecycle_.Update(in, hardware_);
  if (hardware_.changed) {
    log_->warn("tick {}: hardware {}: {}", tick_, ToString(hardware_.state),
               hardware_.apply_commands ? "the valves follow the commands"
                                        : "every valve held at its safe value, sensors published");
  }
  if (!hardware_.activation_asked) return;
  const bool refused = hardware_.refusal != ActivationRefusal::kNone;
  // Cut to the DDS detail field it is sent in (the log line below has the whole detail).
  char why[160];
  text::FormatCut(why, sizeof why, "%s%s", refused ? "hardware inactive: " : "", hardware_.detail.data());
  if (sequence != 0) {
    services::FormatCommandAnswer(hardware_answer_, sequence, activation_kind_,
                                  refused ? services::CommandAnswer::kRefused : services::CommandAnswer::kAccepted,
                                  why);
  } else {
    text::FormatCut(hardware_answer_, sizeof hardware_answer_, "%s %s: %s", activation_kind_,
                    refused ? "refused" : "granted", why);
  }
  hardware_answer_tick_ = tick_;
  if (refused) {
    log_->error("tick {}: activation REFUSED ({}): {}", tick_, activation_kind_, hardware_.detail.data());
    // Automatic: no one waits for an answer; the supervisor holds with the cause.
    if (sequence == 0)
      faults_.Publish(static_cast<uint8_t>(hardware_.refusal_leg), tick_, ReasonOf(hardware_.refusal), why);
  } else {
    log_->info("tick {}: activation granted ({}): {}", tick_, activation_kind_, hardware_.detail.data());
  }
  runtime_.Publish(hexa_msg_NODE_RUNNING, Figures(), StatusDetail());
}

const char* PlantNode::StatusDetail() {
  // The answer is repeated for 1000 ticks: the status topic keeps one sample per node, and a
  // periodic one must not replace it before the supervisor and the operator have read it.
  if (hardware_answer_[0] != '\0' && tick_ - hardware_answer_tick_ <= 1000) return hardware_answer_;
  std::snprintf(status_detail_, sizeof status_detail_, "%s; hardware %s",
                arbitration_params_.realtime ? "real time" : "lockstep", ToString(hardware_.state));
  return status_detail_;
}

}  // namespace hexa::plant_sim
