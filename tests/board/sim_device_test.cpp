// SimDevice (device/sim_device.hpp): the simulated rig behind the device seam steps exactly as
// PlatformPlant does (the plant service's numbers are unchanged by the seam), one sample per
// step, and refuses to run unconfigured.
#include "hexa/device/sim_device.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace {

using hexa::LegArray;
using hexa::PlatformPlant;
using hexa::PlatformPlantConfig;
using hexa::device::DeviceSensors;
using hexa::device::DeviceStatus;
using hexa::device::SimDevice;

PlatformPlantConfig Config() {
  PlatformPlantConfig c;
  c.rig = hexa::MakeReferenceRig();
  c.disturbance = hexa::MakeRealisticDisturbanceProfile();
  c.seed = 7;
  return c;
}

TEST(SimDevice, StepsBitForBitAsThePlantItWraps) {
  PlatformPlant plant(Config());
  SimDevice device(Config(), 0.001);
  std::string error;
  ASSERT_TRUE(device.Configure(error));
  DeviceSensors s;
  for (int tick = 0; tick < 300; ++tick) {
    ASSERT_EQ(device.ReadSensors(s), DeviceStatus::kOk);
    EXPECT_EQ(device.ReadSensors(s), DeviceStatus::kNoNewData);  // one sample per step
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
      ASSERT_EQ(s.legs[i].length_m, plant.output().legs[i].length_m) << tick;
      ASSERT_EQ(s.legs[i].chamber1_pressure_pa, plant.output().legs[i].chamber1_pressure_pa);
    }
    LegArray<double> v{};
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) v[i] = 5.0 + 0.3 * static_cast<double>(i % 3) - 0.2;
    plant.Step(v, 0.001);
    ASSERT_EQ(device.WriteValves(v), DeviceStatus::kOk);
  }
  EXPECT_EQ(device.plant().truth().pose.p_BP_B_m, plant.truth().pose.p_BP_B_m);
  ASSERT_NE(device.simulation(), nullptr);
}

TEST(SimDevice, ANonFiniteCommandIsTheNullAndALatchedEstopHoldsEveryValveAtNull) {
  SimDevice device(Config(), 0.001);
  std::string error;
  ASSERT_TRUE(device.Configure(error));
  LegArray<double> v{};
  v.fill(7.0);
  v[2] = std::numeric_limits<double>::quiet_NaN();
  ASSERT_EQ(device.WriteValves(v), DeviceStatus::kOk);
  DeviceSensors s;
  ASSERT_EQ(device.ReadSensors(s), DeviceStatus::kOk);
  EXPECT_EQ(s.applied_valve_v[2], Config().rig.valve.null_voltage_v);
  EXPECT_EQ(s.applied_valve_v[0], 7.0);
  device.LatchEstop();
  ASSERT_EQ(device.WriteValves(v), DeviceStatus::kOk);
  ASSERT_EQ(device.ReadSensors(s), DeviceStatus::kOk);
  for (double a : s.applied_valve_v) EXPECT_EQ(a, Config().rig.valve.null_voltage_v);
  EXPECT_TRUE(s.safety.estop_latched);
}

TEST(SimDevice, RefusesToRunUnconfigured) {
  SimDevice device(Config(), 0.001);
  DeviceSensors s;
  LegArray<double> v{};
  v.fill(5.0);
  EXPECT_EQ(device.ReadSensors(s), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.WriteValves(v), DeviceStatus::kNotConfigured);
}

}  // namespace
