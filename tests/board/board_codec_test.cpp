// Host side of the board protocol (device/board_codec.hpp): calibration of every channel,
// every refusal counted under its name (the out-of-range one with its channel), the clock's
// unwrapping, the IMU's freshness, and the command encoder's conversion and clamping.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "hexa/core/board_calibration.hpp"
#include "hexa/device/board_codec.hpp"

namespace {

using hexa::device::BoardCommandEncoder;
using hexa::device::BoardSensorDecoder;
using hexa::device::DeviceSensors;
using hexa::device::FrameVerdict;

hexa::BoardCalibration Calibration() { return hexa::MakeReferenceBoardCalibration(hexa::MakeReferenceRig()); }

// A plausible frame: legs at mid-stroke, 3 bar, 6 bar supply, level.
hb_sensor_frame Plausible(std::uint32_t sequence) {
  const hexa::BoardCalibration cal = Calibration();
  hb_sensor_frame f{};
  f.sequence = sequence;
  f.board_time_us = sequence * 1000u;
  for (int i = 0; i < HB_NUM_LEGS; ++i) {
    f.adc[HB_ADC_POT(i)] = static_cast<std::uint16_t>(std::lround(cal.legs[0].potentiometer_m.ToCounts(0.5034)));
    f.adc[HB_ADC_CHAMBER1(i)] = 20000;  // 3 bar
    f.adc[HB_ADC_CHAMBER2(i)] = static_cast<std::uint16_t>(20000 + i);
  }
  f.adc[HB_ADC_SUPPLY] = 40000;  // 6 bar
  f.imu_quat[0] = 16384;
  f.digital_inputs = HB_DIN_ESTOP_LOOP_CLOSED;
  return f;
}

std::vector<std::uint8_t> Bytes(const hb_sensor_frame& f) {
  std::vector<std::uint8_t> out(HB_SENSOR_FRAME_SIZE);
  hb_encode_sensor(&f, out.data());
  return out;
}

void PutCrc(std::vector<std::uint8_t>& frame) {
  const std::uint32_t crc = hb_crc32c(frame.data(), frame.size() - 4);
  for (int k = 0; k < 4; ++k) frame[frame.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
}

TEST(BoardCodec, CalibratesEveryChannel) {
  BoardSensorDecoder decoder(Calibration());
  hb_sensor_frame f = Plausible(1);
  f.imu_rate[1] = -250;
  f.dac_applied[2] = 32765;
  f.digital_inputs |= HB_DIN_EXTENDED(2) | HB_DIN_RETRACTED(4);
  f.status = HB_STATUS_VALVES_SAFE | HB_STATUS_WATCHDOG;
  f.watchdog_count = 4;
  DeviceSensors s;
  ASSERT_EQ(decoder.Decode(Bytes(f), s), FrameVerdict::kOk);
  EXPECT_NEAR(s.legs[3].length_m, 0.5034, 2e-6);  // within half a count (4 um)
  EXPECT_DOUBLE_EQ(s.legs[0].chamber1_pressure_pa, 300000.0);
  EXPECT_DOUBLE_EQ(s.legs[5].chamber2_pressure_pa, 15.0 * 20005);
  EXPECT_DOUBLE_EQ(s.legs[4].supply_pressure_pa, 600000.0);
  EXPECT_DOUBLE_EQ(s.imu.angular_rate_B_rad_s.y(), -0.25);
  EXPECT_NEAR(s.applied_valve_v[2], 5.0, 1e-3);
  EXPECT_TRUE(s.at_extended_end[2]);
  EXPECT_TRUE(s.at_retracted_end[4]);
  EXPECT_FALSE(s.at_extended_end[4]);
  EXPECT_TRUE(s.safety.valves_safe);
  EXPECT_TRUE(s.safety.watchdog_expired);
  EXPECT_FALSE(s.safety.estop_loop_open);
  EXPECT_EQ(s.safety.watchdog_count, 4u);
  EXPECT_DOUBLE_EQ(s.device_time_s, 0.001);
  EXPECT_TRUE(s.imu.fresh);
  EXPECT_NEAR(s.imu.q_BP_measured.w(), 1.0, 1e-12);
}

TEST(BoardCodec, EveryRefusalIsCountedUnderItsName) {
  BoardSensorDecoder decoder(Calibration());
  DeviceSensors s;
  ASSERT_EQ(decoder.Decode(Bytes(Plausible(10)), s), FrameVerdict::kOk);

  auto crc = Bytes(Plausible(11));
  crc[30] ^= 0x40;
  EXPECT_EQ(decoder.Decode(crc, s), FrameVerdict::kBadCrc);
  auto version = Bytes(Plausible(12));
  version[2] = 0;
  PutCrc(version);
  EXPECT_EQ(decoder.Decode(version, s), FrameVerdict::kBadVersion);
  EXPECT_EQ(decoder.Decode(Bytes(Plausible(10)), s), FrameVerdict::kOldSequence);  // duplicate
  EXPECT_EQ(decoder.Decode(Bytes(Plausible(9)), s), FrameVerdict::kOldSequence);   // out of order
  auto truncated = Bytes(Plausible(13));
  truncated.resize(60);
  PutCrc(truncated);
  EXPECT_EQ(decoder.Decode(truncated, s), FrameVerdict::kBadSize);
  EXPECT_EQ(decoder.Decode(std::vector<std::uint8_t>(5, 0), s), FrameVerdict::kShort);
  hb_command_frame c{};
  std::vector<std::uint8_t> command(HB_COMMAND_FRAME_SIZE);
  hb_encode_command(&c, command.data());
  EXPECT_EQ(decoder.Decode(command, s), FrameVerdict::kBadType);
  auto magic = Bytes(Plausible(14));
  magic[0] = 'X';
  PutCrc(magic);
  EXPECT_EQ(decoder.Decode(magic, s), FrameVerdict::kBadMagic);
  hb_sensor_frame broken = Plausible(15);
  broken.adc[HB_ADC_CHAMBER2(3)] = 0;  // 0 Pa: a cut wire
  EXPECT_EQ(decoder.Decode(Bytes(broken), s), FrameVerdict::kOutOfRange);
  EXPECT_EQ(hexa::device::BoardChannelName(decoder.last_out_of_range_channel()), "leg 4 chamber2_pressure_pa");
  EXPECT_EQ(decoder.last_out_of_range_value_si(), 0.0);
  decoder.Count(FrameVerdict::kUnknownSender);
  // The sequence of a frame refused for its values is the board's: 15 is consumed.
  EXPECT_EQ(decoder.Decode(Bytes(Plausible(15)), s), FrameVerdict::kOldSequence);
  ASSERT_EQ(decoder.Decode(Bytes(Plausible(16)), s), FrameVerdict::kOk);

  const auto& n = decoder.counters();
  EXPECT_EQ(n[FrameVerdict::kOk], 2u);
  EXPECT_EQ(n[FrameVerdict::kBadCrc], 1u);
  EXPECT_EQ(n[FrameVerdict::kBadVersion], 1u);
  EXPECT_EQ(n[FrameVerdict::kOldSequence], 3u);
  EXPECT_EQ(n[FrameVerdict::kBadSize], 1u);
  EXPECT_EQ(n[FrameVerdict::kShort], 1u);
  EXPECT_EQ(n[FrameVerdict::kBadType], 1u);
  EXPECT_EQ(n[FrameVerdict::kBadMagic], 1u);
  EXPECT_EQ(n[FrameVerdict::kOutOfRange], 1u);
  EXPECT_EQ(n[FrameVerdict::kUnknownSender], 1u);
  EXPECT_EQ(n.refused(), 11u);
  EXPECT_EQ(n.Describe(),
            "ok 2, short 1, bad_crc 1, bad_magic 1, bad_version 1, bad_type 1, bad_size 1, old_sequence 3, "
            "out_of_range 1, unknown_sender 1");
}

TEST(BoardCodec, EveryCheckedChannelHasItsOwnName) {
  std::vector<std::string> names;
  for (int ch = 0; ch < hexa::device::kBoardCheckedChannels; ++ch) {
    names.push_back(hexa::device::BoardChannelName(ch));
    for (std::size_t k = 0; k + 1 < names.size(); ++k) EXPECT_NE(names[k], names.back());
  }
  EXPECT_EQ(names[0], "leg 1 potentiometer_m");
  EXPECT_EQ(names[6], "leg 1 chamber1_pressure_pa");
  EXPECT_EQ(names[17], "leg 6 chamber2_pressure_pa");
  EXPECT_EQ(names[18], "supply_pressure_pa");
  EXPECT_EQ(names[21], "imu_rate_rad_s z");
}

TEST(BoardCodec, BoardClockIsUnwrappedAndImuFreshnessFollowsItsCounter) {
  BoardSensorDecoder decoder(Calibration());
  DeviceSensors s;
  hb_sensor_frame f = Plausible(1);
  f.board_time_us = 0xFFFFFC18u;  // 1 ms before the wrap
  f.imu_count = 7;
  ASSERT_EQ(decoder.Decode(Bytes(f), s), FrameVerdict::kOk);
  const double t0 = s.device_time_s;
  f.sequence = 2;
  f.board_time_us = 1000;  // wrapped
  ASSERT_EQ(decoder.Decode(Bytes(f), s), FrameVerdict::kOk);
  EXPECT_NEAR(s.device_time_s - t0, 0.002, 1e-9);
  EXPECT_FALSE(s.imu.fresh);  // same counter: the IMU has not renewed
  f.sequence = 3;
  f.imu_count = 8;
  ASSERT_EQ(decoder.Decode(Bytes(f), s), FrameVerdict::kOk);
  EXPECT_TRUE(s.imu.fresh);
}

TEST(BoardCodec, EncoderConvertsClampsAndNumbersCommands) {
  BoardCommandEncoder encoder(Calibration(), 5.0);
  std::array<std::uint8_t, HB_COMMAND_FRAME_SIZE> out{};
  hexa::LegArray<double> v = {0.0, 10.0, 5.0, -3.0, 12.0, std::nan("")};
  ASSERT_EQ(encoder.Encode(v, HB_CMD_SAFE, out), static_cast<std::size_t>(HB_COMMAND_FRAME_SIZE));
  hb_command_frame c{};
  ASSERT_EQ(hb_decode_command(out.data(), out.size(), &c), HB_FRAME_OK);
  EXPECT_EQ(c.sequence, 1u);
  EXPECT_EQ(c.flags, HB_CMD_SAFE);
  EXPECT_EQ(c.watchdog_ms, 5u);
  EXPECT_EQ(c.dac[0], 0u);
  EXPECT_EQ(c.dac[1], 65531u);  // 10 V / 1.526e-4 V per count
  EXPECT_EQ(c.dac[2], 32765u);
  EXPECT_EQ(c.dac[3], 0u);       // clamped to 0 V
  EXPECT_EQ(c.dac[4], 65531u);   // clamped to 10 V
  EXPECT_EQ(c.dac[5], 32765u);   // non-finite: the null voltage
  EXPECT_EQ(encoder.clamped_values(), 2u);
  EXPECT_EQ(encoder.non_finite_values(), 1u);
  encoder.Encode(v, 0, out);
  EXPECT_EQ(encoder.sequence(), 2u);
}

}  // namespace
