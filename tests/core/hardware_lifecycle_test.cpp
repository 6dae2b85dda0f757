// HardwareLifecycle (core/hardware_lifecycle.hpp): every transition and every refusal, each
// named with its leg and value, and which valves a tick applies. No process, no DDS, no clock.
#include "hexa/core/hardware_lifecycle.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace {

using namespace hexa;

HardwareLifecycleConfig Config(int expected_legs = 6) {
  HardwareLifecycleConfig c;  // the reference rig's leg-controller ranges
  c.expected_legs = expected_legs;
  return c;
}

// A healthy rig: configured, loop closed, every controller live, sensors at mid-stroke, 7 bar.
HardwareLifecycleInput Healthy() {
  HardwareLifecycleInput in;
  in.device_configured = true;
  in.leg_controller_live.fill(true);
  for (LegSensorReading& s : in.sensors) {
    s.length_m = 0.5034;
    s.chamber1_pressure_pa = 3.0e5;
    s.chamber2_pressure_pa = 3.0e5;
    s.supply_pressure_pa = 7.0e5;
  }
  return in;
}

HardwareLifecycleInput Activate(HardwareLifecycleInput in) {
  in.activate = true;
  return in;
}

std::string Detail(const HardwareLifecycleOutput& out) { return out.detail.data(); }

TEST(HardwareLifecycle, StartsUnconfiguredAndAConfiguredDeviceMakesItInactive) {
  HardwareLifecycle life(Config());
  EXPECT_EQ(life.state(), HardwareState::kUnconfigured);
  HardwareLifecycleOutput out;
  HardwareLifecycleInput in = Healthy();
  in.device_configured = false;
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kUnconfigured);
  EXPECT_FALSE(out.apply_commands);
  EXPECT_FALSE(out.changed);
  life.Update(Healthy(), out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
  EXPECT_TRUE(out.changed);
  EXPECT_FALSE(out.apply_commands);  // inactive: the valves stay at their safe value
  EXPECT_EQ(Detail(out), "hardware inactive");
  // Inactive stays inactive without an activation, however healthy the rig.
  for (int k = 0; k < 100; ++k) life.Update(Healthy(), out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
  EXPECT_FALSE(out.changed);
}

TEST(HardwareLifecycle, ActivationOfAHealthyRigMakesItActiveAndTheCommandsApply) {
  HardwareLifecycle life(Config());
  HardwareLifecycleOutput out;
  life.Update(Healthy(), out);
  life.Update(Activate(Healthy()), out);
  EXPECT_EQ(out.state, HardwareState::kActive);
  EXPECT_TRUE(out.apply_commands);
  EXPECT_TRUE(out.changed);
  EXPECT_TRUE(out.activation_asked);
  EXPECT_EQ(out.refusal, ActivationRefusal::kNone);
  EXPECT_EQ(Detail(out), "hardware active");
  life.Update(Healthy(), out);
  EXPECT_TRUE(out.apply_commands);
  EXPECT_FALSE(out.changed);
  // Asked again while active: answered, nothing changes.
  life.Update(Activate(Healthy()), out);
  EXPECT_EQ(out.state, HardwareState::kActive);
  EXPECT_EQ(out.refusal, ActivationRefusal::kNone);
  EXPECT_EQ(Detail(out), "hardware already active");
}

TEST(HardwareLifecycle, ActivationFromUnconfiguredIsRefusedAsNotConfigured) {
  HardwareLifecycle life(Config());
  HardwareLifecycleOutput out;
  HardwareLifecycleInput in = Activate(Healthy());
  in.device_configured = false;
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kUnconfigured);
  EXPECT_EQ(out.refusal, ActivationRefusal::kNotConfigured);
  EXPECT_FALSE(out.apply_commands);
  EXPECT_NE(Detail(out).find("not configured"), std::string::npos) << Detail(out);
}

TEST(HardwareLifecycle, DeactivateReturnsToInactiveAndALostDeviceToUnconfigured) {
  HardwareLifecycle life(Config());
  HardwareLifecycleOutput out;
  life.Update(Activate(Healthy()), out);  // configured and activated in one update
  ASSERT_EQ(out.state, HardwareState::kActive);
  HardwareLifecycleInput in = Healthy();
  in.deactivate = true;
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
  EXPECT_TRUE(out.changed);
  EXPECT_FALSE(out.apply_commands);
  // Deactivate and activate together: deactivate wins (the shutdown path is never undone).
  in.activate = true;
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
  life.Update(Activate(Healthy()), out);
  ASSERT_EQ(out.state, HardwareState::kActive);
  HardwareLifecycleInput lost = Healthy();
  lost.device_configured = false;
  life.Update(lost, out);
  EXPECT_EQ(out.state, HardwareState::kUnconfigured);
  EXPECT_FALSE(out.apply_commands);
  EXPECT_TRUE(out.changed);
  // Back: inactive first, never straight to active.
  life.Update(Healthy(), out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
}

// Each refusal: the state stays inactive, the valves stay safe, the reason and leg are named.
void ExpectRefused(const HardwareLifecycleInput& in, ActivationRefusal refusal, int leg,
                   const std::string& words, int expected_legs = 6) {
  HardwareLifecycle life(Config(expected_legs));
  HardwareLifecycleOutput out;
  life.Update(Healthy(), out);
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kInactive);
  EXPECT_FALSE(out.apply_commands);
  EXPECT_FALSE(out.changed);
  EXPECT_TRUE(out.activation_asked);
  EXPECT_EQ(out.refusal, refusal) << ToString(out.refusal);
  EXPECT_EQ(out.refusal_leg, leg);
  EXPECT_NE(Detail(out).find(words), std::string::npos) << Detail(out);
  // The same check, asked without an update, says the same.
  int check_leg = -1;
  std::array<char, 160> detail{};
  EXPECT_EQ(life.Check(in, check_leg, detail), refusal);
  EXPECT_EQ(check_leg, leg);
  // Once the cause is gone, the next activation is granted.
  life.Update(Activate(Healthy()), out);
  EXPECT_EQ(out.state, HardwareState::kActive);
}

TEST(HardwareLifecycle, RefusedWithTheEstopLoopOpen) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.estop_loop_open = true;
  ExpectRefused(in, ActivationRefusal::kEstopOpen, 0, "e-stop open (the loop input is open)");
}

TEST(HardwareLifecycle, RefusedWithTheEstopLatched) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.estop_latched = true;
  ExpectRefused(in, ActivationRefusal::kEstopOpen, 0, "e-stop open (the latch is set)");
}

TEST(HardwareLifecycle, RefusedWithALegWithoutALiveController) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.leg_controller_live[3] = false;
  ExpectRefused(in, ActivationRefusal::kNoLiveController, 4, "no live controller for leg 4");
}

TEST(HardwareLifecycle, OnlyTheExpectedLegsNeedAController) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.leg_controller_live[5] = false;  // leg 6 not expected
  HardwareLifecycle life(Config(5));
  HardwareLifecycleOutput out;
  life.Update(in, out);
  EXPECT_EQ(out.state, HardwareState::kActive);
  in.leg_controller_live[4] = false;
  ExpectRefused(in, ActivationRefusal::kNoLiveController, 5, "leg 5", 5);
}

TEST(HardwareLifecycle, RefusedWithALengthOutOfRangeNamingLegValueAndRange) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.sensors[1].length_m = 0.70;  // mid 0.5034 + 0.125 + 0.02 = 0.6484 at most
  ExpectRefused(in, ActivationRefusal::kSensorOutOfRange, 2,
                "sensor out of range: leg 2 length_m = 0.7 outside [0.3584, 0.6484]");
}

TEST(HardwareLifecycle, RefusedWithANonFiniteOrImplausiblePressure) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.sensors[4].chamber1_pressure_pa = std::numeric_limits<double>::quiet_NaN();
  ExpectRefused(in, ActivationRefusal::kSensorOutOfRange, 5, "leg 5 cap_pressure_pa = nan");
  in = Activate(Healthy());
  in.sensors[0].chamber2_pressure_pa = 0.0;  // a dead sensor reads 0 Pa absolute
  ExpectRefused(in, ActivationRefusal::kSensorOutOfRange, 1, "leg 1 rod_pressure_pa = 0 outside [20000, 1.2e+06]");
  in = Activate(Healthy());
  in.sensors[2].supply_pressure_pa = 20.0e5;
  ExpectRefused(in, ActivationRefusal::kSensorOutOfRange, 3, "leg 3 supply_pressure_pa = 2e+06");
}

TEST(HardwareLifecycle, RefusedWithTheSupplyPressureLow) {
  HardwareLifecycleInput in = Activate(Healthy());
  for (LegSensorReading& s : in.sensors) s.supply_pressure_pa = 3.5e5;  // plausible, too low
  ExpectRefused(in, ActivationRefusal::kSupplyPressureLow, 1,
                "supply pressure low: 3.500 bar at leg 1, below the 4.000 bar the legs need");
}

TEST(HardwareLifecycle, TheFirstFailingCheckIsNamedInItsOrder) {
  HardwareLifecycleInput in = Activate(Healthy());
  in.estop_loop_open = true;
  in.leg_controller_live[0] = false;
  in.sensors[0].length_m = 1.0;
  in.sensors[0].supply_pressure_pa = 3.0e5;
  ExpectRefused(in, ActivationRefusal::kEstopOpen, 0, "e-stop");
  in.estop_loop_open = false;
  ExpectRefused(in, ActivationRefusal::kNoLiveController, 1, "no live controller");
  in.leg_controller_live[0] = true;
  ExpectRefused(in, ActivationRefusal::kSensorOutOfRange, 1, "length_m");
  in.sensors[0].length_m = 0.5;
  ExpectRefused(in, ActivationRefusal::kSupplyPressureLow, 1, "supply pressure low");
}

TEST(HardwareLifecycle, ConfigFromTheLegControllerAndValidation) {
  LegControllerConfig leg;
  leg.model.cylinder.stroke_m = 0.3;
  leg.model.cylinder.mid_stroke_length_m = 0.6;
  leg.min_supply_pressure_pa = 4.5e5;
  const HardwareLifecycleConfig c = HardwareLifecycleConfig::FromLegController(leg, 4);
  EXPECT_EQ(c.stroke_m, 0.3);
  EXPECT_EQ(c.mid_stroke_length_m, 0.6);
  EXPECT_EQ(c.min_supply_pressure_pa, 4.5e5);
  EXPECT_EQ(c.length_margin_m, leg.length_margin_m);
  EXPECT_EQ(c.expected_legs, 4);
  EXPECT_NO_THROW(c.Validate());
  HardwareLifecycleConfig bad = c;
  bad.expected_legs = 7;
  try {
    bad.Validate();
    ADD_FAILURE() << "expected_legs 7 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("expected_legs = 7: must be in [0, 6]"), std::string::npos) << e.what();
  }
  bad = c;
  bad.min_supply_pressure_pa = 13e5;
  EXPECT_THROW(HardwareLifecycle{bad}, std::invalid_argument);
}

}  // namespace
