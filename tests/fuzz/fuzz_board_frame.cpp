// libFuzzer target: the board link's parsers on arbitrary bytes, both sides. The first byte
// picks how the rest reaches them: 0 as received; 1 with a correct CRC-32C put in its last
// four bytes (so that the checks behind the CRC are reached); 2 through the serial line's
// COBS decoder first. Invariants: nothing crashes; the host's decoder counts every datagram
// exactly once, under a named verdict; an accepted frame has every calibrated value within
// its range and finite; the board counts every refused command and changes nothing else.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "hexa/core/board_calibration.hpp"
#include "hexa/device/board_codec.hpp"
#include "hexa_board/board.h"

namespace {

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

std::vector<std::uint8_t> Prepare(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return {};
  const std::uint8_t mode = data[0] % 3;
  std::vector<std::uint8_t> bytes(data + 1, data + size);
  if (mode == 1 && bytes.size() >= 4) {
    const std::uint32_t crc = hb_crc32c(bytes.data(), bytes.size() - 4);
    for (int k = 0; k < 4; ++k) bytes[bytes.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
  } else if (mode == 2) {
    std::vector<std::uint8_t> decoded(bytes.size());
    decoded.resize(hb_cobs_decode(bytes.data(), bytes.size(), decoded.data(), decoded.size()));
    bytes = std::move(decoded);
  }
  return bytes;
}

void HostSide(const std::vector<std::uint8_t>& bytes) {
  static const hexa::BoardCalibration calibration = hexa::MakeReferenceBoardCalibration(hexa::MakeReferenceRig());
  static hexa::device::BoardSensorDecoder decoder(calibration);  // keeps its sequence across inputs
  const std::uint64_t before = decoder.counters().refused() + decoder.counters()[hexa::device::FrameVerdict::kOk];
  hexa::device::DeviceSensors s;
  const hexa::device::FrameVerdict v = decoder.Decode(bytes, s);
  const std::uint64_t after = decoder.counters().refused() + decoder.counters()[hexa::device::FrameVerdict::kOk];
  Check(after == before + 1);
  Check(std::strcmp(hexa::device::ToString(v), "unknown") != 0);
  if (v == hexa::device::FrameVerdict::kOutOfRange) {
    Check(decoder.last_out_of_range_channel() >= 0 &&
          decoder.last_out_of_range_channel() < hexa::device::kBoardCheckedChannels);
  }
  if (v != hexa::device::FrameVerdict::kOk) return;
  for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
    const hexa::BoardLegCalibration& c = calibration.legs[i];
    Check(c.potentiometer_m.InRange(s.legs[i].length_m));
    Check(c.chamber1_pressure_pa.InRange(s.legs[i].chamber1_pressure_pa));
    Check(c.chamber2_pressure_pa.InRange(s.legs[i].chamber2_pressure_pa));
    Check(calibration.supply_pressure_pa.InRange(s.legs[i].supply_pressure_pa));
    Check(std::isfinite(s.applied_valve_v[i]));
  }
  Check(s.imu.q_BP_measured.coeffs().allFinite());
  Check(std::abs(s.imu.q_BP_measured.norm() - 1.0) < 1e-9);
  for (int k = 0; k < 3; ++k) Check(calibration.imu_rate_rad_s.InRange(s.imu.angular_rate_B_rad_s(k)));
}

void BoardSide(const std::vector<std::uint8_t>& bytes) {
  hb_board_config config{};
  for (auto& d : config.safe_dac) d = 32765;
  config.dac_max = 65535;
  config.watchdog_default_ms = 5;
  config.watchdog_min_ms = 2;
  config.watchdog_max_ms = 100;
  static hb_board board;
  static bool initialised = false;
  if (!initialised) {
    hb_board_init(&board, &config);
    initialised = true;
  }
  static std::uint32_t now_us = 0;
  now_us += 1000;
  const hb_board before = board;
  const hb_frame_reason r = hb_board_receive(&board, bytes.data(), bytes.size(), now_us);
  Check(r >= HB_FRAME_OK && r < HB_FRAME_REASON_COUNT);
  if (r != HB_FRAME_OK) {
    Check(static_cast<std::uint16_t>(board.rejected_count - before.rejected_count) == 1u);
    Check(board.last_reject == r);
    Check(std::memcmp(&board.command, &before.command, sizeof board.command) == 0);
    Check(board.last_command_us == before.last_command_us);
  }
  hb_board_inputs in{};
  in.digital_inputs = HB_DIN_ESTOP_LOOP_CLOSED;
  std::uint16_t dac[HB_NUM_LEGS];
  hb_board_tick(&board, &in, now_us, dac);
  for (int i = 0; i < HB_NUM_LEGS; ++i) Check(dac[i] <= config.dac_max);
  std::uint8_t frame[HB_SENSOR_FRAME_SIZE];
  hb_sensor_frame decoded{};
  Check(hb_board_frame(&board, frame) == HB_SENSOR_FRAME_SIZE);
  Check(hb_decode_sensor(frame, sizeof frame, &decoded) == HB_FRAME_OK);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<std::uint8_t> bytes = Prepare(data, size);
  HostSide(bytes);
  BoardSide(bytes);
  return 0;
}
