// The plant's device seam (docs/board_protocol.md, "Host side"): what a rig I/O node needs from
// the hardware under it, modelled on ros2_control's SystemInterface (on_configure -> read ->
// write, a safe state, release). Implemented by the remote I/O board (remote_board_device.hpp)
// and by the simulated rig (sim_device.hpp: core's PlatformPlant, one tick per write).
//
// Calls come from one thread, the node's control loop: ReadSensors and WriteValves neither
// block nor allocate once configured; errors inside the loop are status codes, never
// exceptions.
#pragma once

#include <cstdint>
#include <string>

#include "hexa/core/platform_plant.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/sensor_model.hpp"

namespace hexa::device {

// The safety chain as the hardware reports it.
struct DeviceSafety {
  bool valves_safe = true;        // every valve at its safe value, for any reason below
  bool watchdog_expired = false;  // the hardware's own watchdog holds the valves (no command)
  bool estop_latched = false;     // until a reset with the loop closed
  bool estop_loop_open = false;   // the normally-closed e-stop input, now
  bool estop_by_input = false;    // what set the latch
  bool estop_by_host = false;
  bool estop_at_power_up = false;
  bool reset_refused = false;     // the last reset came while the loop was open
  bool host_safe = false;         // held safe because the host asked (WriteSafeState)
  std::uint32_t watchdog_count = 0;  // times the watchdog fired
};

// One sample of everything the rig measures, in SI units.
struct DeviceSensors {
  LegArray<LegSensorReading> legs{};
  ImuReading imu;                     // fresh only on the samples the IMU renewed
  LegArray<bool> at_retracted_end{};  // end switches
  LegArray<bool> at_extended_end{};
  LegArray<double> applied_valve_v{};  // what the valve outputs are driven with
  DeviceSafety safety;
  double device_time_s = 0.0;  // the device's clock at sampling (monotonic, unwrapped)
};

enum class DeviceStatus {
  kOk,
  kNoNewData,      // ReadSensors: nothing since the last call; `out` untouched
  kNotConfigured,  // Configure has not succeeded (or Close was called)
  kIoError,        // the transport failed (counted; the device stays configured)
  kFault,          // the device cannot go on (the simulated state became non-finite)
};

class Device {
 public:
  virtual ~Device() = default;

  // Opens the link / builds the model. False with `error` naming the cause (field, address,
  // port) on failure; nothing is left open then.
  virtual bool Configure(std::string& error) = 0;
  // The newest sample, if one came since the last call. Never blocks.
  virtual DeviceStatus ReadSensors(DeviceSensors& out) = 0;
  // Valve voltages for this tick (non-finite: the valve's null). Never blocks.
  virtual DeviceStatus WriteValves(const LegArray<double>& valve_v) = 0;
  // Every valve to its safe value while the link stays alive (lifecycle inactive, parking).
  virtual DeviceStatus WriteSafeState() = 0;
  // Operator e-stop: latched in the hardware from the next write on, until a reset.
  virtual void LatchEstop() = 0;
  // Asks the hardware to clear its e-stop latch; it refuses while the loop is open
  // (DeviceSafety::reset_refused).
  virtual void RequestEstopReset() = 0;
  // Valves to their safe state where the device can, then releases everything.
  virtual void Close() = 0;
  // A simulated rig also knows the truth (ground truth, the external pose instrument, the
  // true parameters): for the recording and evaluation only, never for control. nullptr for
  // real hardware.
  virtual const PlatformPlant* simulation() const { return nullptr; }
};

const char* ToString(DeviceStatus status);

}  // namespace hexa::device
