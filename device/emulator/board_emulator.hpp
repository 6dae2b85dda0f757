// The remote I/O board emulated (hexa_board_emulator, docs/board_protocol.md "Emulator"): the
// board's own C code (firmware/board) with the simulated rig behind its channels. The rig is
// core's PlatformPlant, stepped one 1 ms tick per board tick as the plant service does; its
// sensors (noise, potentiometer offsets and gain errors, quantisation of the rig file's
// disturbance profile) are turned into ADC counts through the rig file's board calibration
// (rounded and saturated like an ADC), and the DAC counts into valve volts the same way.
//
// A board tick: sample the inputs, hb_board_tick (latch, watchdog, outputs), the sensor frame,
// then the plant advances one tick with the outputs. A command answering frame k therefore
// acts from tick k + 1, as on a real board. No clock, no socket: main.cpp drives it.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "hexa/core/board_calibration.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa_board/board.h"

namespace hexa::device {

// Ticks [open_tick, close_tick) during which the e-stop loop is open (a pressed button).
struct EstopOpenWindow {
  std::uint64_t open_tick = 0;
  std::uint64_t close_tick = 0;
};

struct BoardEmulatorConfig {
  PlatformPlantConfig plant;   // rig, disturbance profile, seed
  BoardCalibration calibration;
  double valve_null_v = 5.0;   // the board's safe value of every valve (MPYE: spool centred)
  std::vector<EstopOpenWindow> estop_open;
  // End switches close this close to each end of the stroke.
  double end_switch_margin_m = 0.001;
};

class BoardEmulator {
 public:
  explicit BoardEmulator(const BoardEmulatorConfig& config);

  // A received datagram, at the board time of the coming tick.
  hb_frame_reason Receive(std::span<const std::uint8_t> datagram);
  // One board tick; the sensor frame into `frame`. Returns its size.
  std::size_t Tick(std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE>& frame);

  std::uint64_t tick() const { return tick_; }
  std::uint32_t board_time_us() const { return static_cast<std::uint32_t>(tick_ * 1000u); }
  const hb_board& board() const { return board_; }
  const PlatformPlant& plant() const { return plant_; }
  // Board inputs from the plant's present output (exposed for tests).
  hb_board_inputs SampleInputs() const;
  std::uint16_t safe_dac(std::size_t leg) const { return board_.config.safe_dac[leg]; }

 private:
  bool LoopClosed(std::uint64_t tick) const;

  BoardEmulatorConfig config_;
  PlatformPlant plant_;
  hb_board board_{};
  std::uint64_t tick_ = 0;
  std::uint8_t imu_count_ = 0;
};

}  // namespace hexa::device
