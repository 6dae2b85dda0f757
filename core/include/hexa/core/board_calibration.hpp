// Per-channel calibration of the remote I/O board (docs/board_protocol.md, "Calibration"):
// raw ADC counts -> SI values with a plausible range, and valve volts -> DAC counts. Pure
// data and arithmetic: the host's codec (device/) and the board emulator share it. The rig
// file's `board` block (proto/rig.proto) fills it; CheckBoardCalibration holds its rules.
#pragma once

#include <cstdint>
#include <string>

#include "hexa/core/param_checks.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// value_si = offset_si + gain_si_per_count * counts; plausible in [min_si, max_si].
struct ChannelCalibration {
  double offset_si = 0.0;
  double gain_si_per_count = 1.0;
  double min_si = 0.0;
  double max_si = 0.0;

  double ToSi(double counts) const { return offset_si + gain_si_per_count * counts; }
  double ToCounts(double value_si) const { return (value_si - offset_si) / gain_si_per_count; }
  bool InRange(double value_si) const { return value_si >= min_si && value_si <= max_si; }
};

struct BoardLegCalibration {
  ChannelCalibration potentiometer_m;       // leg length
  ChannelCalibration chamber1_pressure_pa;  // cap side, absolute
  ChannelCalibration chamber2_pressure_pa;  // rod side, absolute
  ChannelCalibration valve_v;               // volts <-> DAC counts
};

struct BoardCalibration {
  LegArray<BoardLegCalibration> legs{};
  ChannelCalibration supply_pressure_pa;
  ChannelCalibration imu_rate_rad_s;  // each gyro axis
  int adc_bits = 16;
  int dac_bits = 16;
  double watchdog_timeout_s = 0.005;

  std::uint32_t adc_max_counts() const { return (1u << adc_bits) - 1u; }
  std::uint32_t dac_max_counts() const { return (1u << dac_bits) - 1u; }
};

// Quaternion scale of the sensor frame (Q14: 16384 = 1), fixed by the protocol.
inline constexpr double kBoardQuaternionScale = 16384.0;
// Watchdog times a board accepts (protocol: whole milliseconds, clamped by the board).
inline constexpr double kBoardWatchdogMin_s = 0.002;
inline constexpr double kBoardWatchdogMax_s = 0.1;

// A 16-bit board in front of `rig` (the shipped rig file's `board` block): potentiometers over
// the stroke with 5 mm to spare at the short end, 0-9.8 bar absolute pressure sensors, a
// +-32.8 rad/s gyro, 0-10 V valve outputs.
BoardCalibration MakeReferenceBoardCalibration(const RigParams& rig);

// The rules of the rig file's `board` block against the rig it serves: gains finite and
// non-zero; ranges ordered and representable in the ADC/DAC counts; potentiometer ranges
// covering the stroke, pressure ranges covering atmosphere to supply, valve ranges covering
// the valve's voltage range; bits in [8, 16]; the watchdog in [2, 100] ms and at least two
// plant ticks. `path` is the block's path ("board").
void CheckBoardCalibration(ParamChecker& c, const BoardCalibration& b, const RigParams& rig,
                           const std::string& path = "board");

}  // namespace hexa
