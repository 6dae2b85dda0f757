// The simulated rig as a Device (device.hpp): core's PlatformPlant behind the same seam as the
// remote I/O board. WriteValves applies the voltages for one tick and advances the simulation
// by it; ReadSensors returns the sample the newest step produced (the state at the start of
// the next tick). Pure simulation: no clock, no I/O; deterministic from the seed.
#pragma once

#include <string>

#include "hexa/core/platform_plant.hpp"
#include "hexa/device/device.hpp"

namespace hexa::device {

class SimDevice final : public Device {
 public:
  // The plant is built (and its configuration validated: throws) here; tick_s: one step.
  SimDevice(const PlatformPlantConfig& config, double tick_s);

  bool Configure(std::string& error) override;
  // The current sample: kOk once per step (and at the start), kNoNewData until the next one.
  DeviceStatus ReadSensors(DeviceSensors& out) override;
  // One tick with these voltages; kFault when the state became non-finite (the last good
  // state is kept: PlatformPlant), kNotConfigured before Configure.
  DeviceStatus WriteValves(const LegArray<double>& valve_v) override;
  // One tick with every valve at its null.
  DeviceStatus WriteSafeState() override;
  // The simulated rig has no e-stop circuit of its own: a latch holds the valves at null
  // until a reset (its loop is always closed).
  void LatchEstop() override { estop_latched_ = true; }
  void RequestEstopReset() override { estop_latched_ = false; }
  void Close() override { configured_ = false; }
  const PlatformPlant* simulation() const override { return &plant_; }

  const PlatformPlant& plant() const { return plant_; }

 private:
  PlatformPlant plant_;
  double tick_s_;
  double null_v_;
  bool configured_ = false;
  bool fresh_ = true;  // a sample not yet read
  bool estop_latched_ = false;
};

}  // namespace hexa::device
