#include "hexa/device/sim_device.hpp"

#include <cmath>

namespace hexa::device {

SimDevice::SimDevice(const PlatformPlantConfig& config, double tick_s)
    : plant_(config), tick_s_(tick_s), null_v_(config.rig.valve.null_voltage_v) {}

bool SimDevice::Configure(std::string& /*error*/) {
  configured_ = true;
  return true;
}

DeviceStatus SimDevice::ReadSensors(DeviceSensors& out) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  if (!fresh_) return DeviceStatus::kNoNewData;
  fresh_ = false;
  const PlatformPlantOutput& o = plant_.output();
  out.legs = o.legs;
  out.imu = o.imu;
  out.applied_valve_v = o.truth.applied_valve_v;
  out.device_time_s = o.truth.time_s;
  out.safety = DeviceSafety{};
  out.safety.estop_latched = estop_latched_;
  out.safety.valves_safe = estop_latched_;
  out.safety.estop_by_host = estop_latched_;  // its only source: LatchEstop
  return DeviceStatus::kOk;
}

DeviceStatus SimDevice::WriteValves(const LegArray<double>& valve_v) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  LegArray<double> applied = valve_v;
  for (double& v : applied)
    if (estop_latched_ || !std::isfinite(v)) v = null_v_;  // latched, or not finite: null
  plant_.Step(applied, tick_s_);
  fresh_ = true;
  return plant_.output().status == PlantStatus::kNonFiniteState ? DeviceStatus::kFault : DeviceStatus::kOk;
}

DeviceStatus SimDevice::WriteSafeState() {
  LegArray<double> null_v{};
  null_v.fill(null_v_);
  return WriteValves(null_v);
}

}  // namespace hexa::device
