// The rig's hardware lifecycle (docs/faults.md, "Hardware lifecycle"), modelled on
// ros2_control's hardware interface: a pure decision unit the rig I/O node (the plant service)
// runs once per tick, reading what the device and the peers report and writing which valves
// to apply. No clock, no DDS.
//
//                 configured               activate (every check passed)
//   UNCONFIGURED ------------> INACTIVE ------------------------------> ACTIVE
//        ^                        ^  |  activate refused: stays INACTIVE, says why |
//        |                        |  +---------------------------------------------+
//        |                        +-------------- deactivate -------------------+
//        +------- the device not configured or its link lost (from any state) --+
//
//   INACTIVE: sensors published, every valve held at its safe value, controllers computing
//             (their commands are not applied).
//   ACTIVE:   the valves follow the arbitrated commands (the e-stop latch still overrides
//             them in the hardware: DeviceSafety).
//
// Activation is asked for (an operator command, or the node's automatic activation) and
// granted only when every check passes, in this order, the first failing one named:
//   1. the device is configured and its link is alive;
//   2. the e-stop loop is closed and no latch is set;
//   3. every expected leg has a live controller;
//   4. every sensor is inside its plausible range (the leg controllers' own input checks);
//   5. the supply pressure is at least the lowest the legs can work with.
#pragma once

#include <array>
#include <cstdint>

#include "hexa/core/leg_controller.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/sensor_model.hpp"

namespace hexa {

enum class HardwareState : std::uint8_t { kUnconfigured, kInactive, kActive };
const char* ToString(HardwareState state);  // "unconfigured", "inactive", "active"

// Why an activation was refused (kNone: granted, or nothing asked).
enum class ActivationRefusal : std::uint8_t {
  kNone,
  kNotConfigured,      // the device is not configured, or its link is lost
  kEstopOpen,          // the e-stop loop is open, or its latch is set
  kNoLiveController,   // an expected leg has no live controller
  kSensorOutOfRange,   // a sensor reading is not finite or outside its plausible range
  kSupplyPressureLow,  // the supply pressure is below what the legs need
};
const char* ToString(ActivationRefusal refusal);  // "e-stop open", ...

struct HardwareLifecycleConfig {
  // The plausible sensor ranges: those the leg controllers check their inputs against
  // (LegControllerConfig), so that a rig the controllers would refuse is never activated.
  double mid_stroke_length_m = 0.5034;
  double stroke_m = 0.25;
  double length_margin_m = 0.02;
  double min_pressure_pa = 0.2e5;
  double max_pressure_pa = 12.0e5;
  double min_supply_pressure_pa = 4.0e5;
  int expected_legs = 6;  // legs 1..expected_legs must have a live controller (0: none)

  // The ranges of this leg controller configuration (every leg shares the nominal cylinder).
  static HardwareLifecycleConfig FromLegController(const LegControllerConfig& leg, int expected_legs);
  // Throws std::invalid_argument naming the field, its value and the limit.
  void Validate() const;
};

struct HardwareLifecycleInput {
  bool device_configured = false;  // Configure succeeded and the link is alive
  bool estop_loop_open = false;    // the normally-closed input, now
  bool estop_latched = false;      // the hardware's (or the operator's) latch
  LegArray<bool> leg_controller_live{};  // a live primary or standby writes the leg's commands
  LegArray<LegSensorReading> sensors{};  // the newest sample
  bool activate = false;    // activation asked for this tick
  bool deactivate = false;  // back to INACTIVE (shutdown, parking done)
};

struct HardwareLifecycleOutput {
  HardwareState state = HardwareState::kUnconfigured;
  bool apply_commands = false;  // ACTIVE: write the arbitrated valves; else the safe state
  bool changed = false;         // the state changed at this update
  // The answer to `activate` at this update: asked, and refused (with the reason) or not.
  bool activation_asked = false;
  ActivationRefusal refusal = ActivationRefusal::kNone;
  int refusal_leg = 0;  // 1-based leg concerned, 0: none
  std::array<char, 160> detail{};  // NUL-terminated: the state, or why the activation was refused
};

class HardwareLifecycle {
 public:
  explicit HardwareLifecycle(const HardwareLifecycleConfig& config);  // validates (throws)

  // One tick: read what the device and the peers report, decide. Neither throws nor allocates.
  void Update(const HardwareLifecycleInput& in, HardwareLifecycleOutput& out) noexcept;
  // The checks alone (what an activation asked now would be refused for); `leg` and `detail`
  // say which and why.
  ActivationRefusal Check(const HardwareLifecycleInput& in, int& leg,
                          std::array<char, 160>& detail) const noexcept;

  HardwareState state() const { return state_; }
  const HardwareLifecycleConfig& config() const { return config_; }

 private:
  HardwareLifecycleConfig config_;
  HardwareState state_ = HardwareState::kUnconfigured;
};

}  // namespace hexa
