// Host side of the board protocol (docs/board_protocol.md): sensor frames -> calibrated SI
// samples, valve voltages -> command frames, and a count of every refused frame by its reason.
// The layout, the CRC and the envelope checks are the board's own C code (firmware/board);
// this adds what only the host judges: the sequence, the calibrated ranges, the sender.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "hexa/core/board_calibration.hpp"
#include "hexa/device/device.hpp"
#include "hexa_board/protocol.h"

namespace hexa::device {

// Verdict on one received datagram. The first values are the protocol's (hb_frame_reason).
enum class FrameVerdict : std::uint8_t {
  kOk = HB_FRAME_OK,
  kShort = HB_FRAME_SHORT,
  kBadCrc = HB_FRAME_BAD_CRC,
  kBadMagic = HB_FRAME_BAD_MAGIC,
  kBadVersion = HB_FRAME_BAD_VERSION,
  kBadType = HB_FRAME_BAD_TYPE,
  kBadSize = HB_FRAME_BAD_SIZE,
  kOldSequence = HB_FRAME_OLD_SEQUENCE,  // duplicate or out of order
  kOutOfRange = HB_FRAME_OUT_OF_RANGE,   // a value outside its calibrated range
  kUnknownSender,                        // a datagram from another address than the board's
  kCount
};
inline constexpr std::size_t kFrameVerdictCount = static_cast<std::size_t>(FrameVerdict::kCount);
const char* ToString(FrameVerdict verdict);

// Every received datagram, counted under its verdict.
struct BoardLinkCounters {
  std::array<std::uint64_t, kFrameVerdictCount> frames{};
  std::uint64_t operator[](FrameVerdict v) const { return frames[static_cast<std::size_t>(v)]; }
  std::uint64_t refused() const;  // all but kOk
  // "ok 1000, bad_crc 2, old_sequence 1" (zero counts left out).
  std::string Describe() const;
};

// Sensor channels in the order of the range check: the 19 ADC channels (protocol.h), then the
// three gyro axes.
inline constexpr int kBoardCheckedChannels = HB_ADC_CHANNELS + 3;
std::string BoardChannelName(int channel);  // "leg 3 chamber1_pressure_pa", "gyro y", ...

class BoardSensorDecoder {
 public:
  explicit BoardSensorDecoder(const BoardCalibration& calibration);

  // Judges one datagram and counts it. kOk: `out` holds the calibrated sample. A frame refused
  // for its values still advances the sequence (it is the board's, intact).
  FrameVerdict Decode(std::span<const std::uint8_t> datagram, DeviceSensors& out);
  // Counts a datagram refused before decoding (kUnknownSender, an oversize datagram).
  void Count(FrameVerdict verdict) { ++counters_.frames[static_cast<std::size_t>(verdict)]; }

  const BoardLinkCounters& counters() const { return counters_; }
  const hb_sensor_frame& last_frame() const { return frame_; }  // the last intact frame
  // The channel and value of the last kOutOfRange verdict (-1: none yet).
  int last_out_of_range_channel() const { return out_of_range_channel_; }
  double last_out_of_range_value_si() const { return out_of_range_value_si_; }

 private:
  FrameVerdict Judge(std::span<const std::uint8_t> datagram);
  bool InRange(const hb_sensor_frame& f);
  void Calibrate(const hb_sensor_frame& f, DeviceSensors& out);

  BoardCalibration calibration_;
  BoardLinkCounters counters_;
  hb_sensor_frame frame_{};
  bool have_sequence_ = false;
  std::uint32_t last_sequence_ = 0;
  bool have_time_ = false;
  std::uint32_t last_board_time_us_ = 0;
  std::uint64_t board_time_us_ = 0;  // unwrapped
  bool have_imu_count_ = false;
  std::uint8_t last_imu_count_ = 0;
  int out_of_range_channel_ = -1;
  double out_of_range_value_si_ = 0.0;
};

class BoardCommandEncoder {
 public:
  BoardCommandEncoder(const BoardCalibration& calibration, double valve_null_v);

  // Next command frame: each voltage clamped into its channel's range and converted to DAC
  // counts (non-finite: the null voltage); `flags` HB_CMD_*. Returns the frame size.
  std::size_t Encode(const LegArray<double>& valve_v, std::uint16_t flags,
                     std::array<std::uint8_t, HB_COMMAND_FRAME_SIZE>& out);
  std::uint16_t ToDac(std::size_t leg, double valve_v) const;

  std::uint32_t sequence() const { return sequence_; }  // of the last frame encoded
  std::uint64_t clamped_values() const { return clamped_; }
  std::uint64_t non_finite_values() const { return non_finite_; }

 private:
  BoardCalibration calibration_;
  double valve_null_v_;
  std::uint16_t watchdog_ms_;
  std::uint32_t sequence_ = 0;
  std::uint64_t clamped_ = 0;
  std::uint64_t non_finite_ = 0;
};

}  // namespace hexa::device
