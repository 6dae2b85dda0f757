// The board link protocol's C code (firmware/board/protocol.h): CRC-32C test vectors, frame
// layout and round trips, the envelope's verdicts in their order, sequence arithmetic, COBS.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "hexa_board/protocol.h"

namespace {

std::uint32_t Crc(const std::vector<std::uint8_t>& bytes) { return hb_crc32c(bytes.data(), bytes.size()); }

void PutCrc(std::vector<std::uint8_t>& frame) {
  const std::uint32_t crc = hb_crc32c(frame.data(), frame.size() - HB_CRC_SIZE);
  for (int k = 0; k < 4; ++k) frame[frame.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
}

hb_sensor_frame SampleSensorFrame() {
  hb_sensor_frame f{};
  f.sequence = 0x01020304u;
  f.board_time_us = 0xA0B0C0D0u;
  f.ack_sequence = 77;
  f.status = HB_STATUS_WATCHDOG | HB_STATUS_VALVES_SAFE;
  f.digital_inputs = HB_DIN_ESTOP_LOOP_CLOSED | HB_DIN_EXTENDED(5);
  for (int i = 0; i < HB_ADC_CHANNELS; ++i) f.adc[i] = static_cast<std::uint16_t>(1000 * i + 7);
  f.imu_quat[0] = 16384;
  f.imu_quat[1] = -1;
  f.imu_quat[2] = -32768;
  f.imu_quat[3] = 32767;
  f.imu_rate[0] = -300;
  f.imu_rate[1] = 0;
  f.imu_rate[2] = 12;
  f.imu_count = 255;
  f.last_reject = HB_FRAME_BAD_CRC;
  for (int i = 0; i < HB_NUM_LEGS; ++i) f.dac_applied[i] = static_cast<std::uint16_t>(2048 + i);
  f.watchdog_count = 3;
  f.rejected_count = 65535;
  f.watchdog_ms = 5;
  return f;
}

std::vector<std::uint8_t> Encode(const hb_command_frame& c) {
  std::vector<std::uint8_t> out(HB_COMMAND_FRAME_SIZE);
  EXPECT_EQ(hb_encode_command(&c, out.data()), static_cast<std::size_t>(HB_COMMAND_FRAME_SIZE));
  return out;
}

TEST(BoardProtocol, Crc32cMatchesPublishedVectors) {
  const char* check = "123456789";
  EXPECT_EQ(hb_crc32c(reinterpret_cast<const std::uint8_t*>(check), 9), 0xE3069283u);
  // RFC 3720 (iSCSI) appendix B.4.
  EXPECT_EQ(Crc(std::vector<std::uint8_t>(32, 0x00)), 0x8A9136AAu);
  EXPECT_EQ(Crc(std::vector<std::uint8_t>(32, 0xFF)), 0x62A8AB43u);
  std::vector<std::uint8_t> up(32), down(32);
  for (int i = 0; i < 32; ++i) {
    up[i] = static_cast<std::uint8_t>(i);
    down[i] = static_cast<std::uint8_t>(31 - i);
  }
  EXPECT_EQ(Crc(up), 0x46DD794Eu);
  EXPECT_EQ(Crc(down), 0x113FDB5Cu);
  EXPECT_EQ(hb_crc32c(nullptr, 0), 0x00000000u);
}

TEST(BoardProtocol, Crc32cUpdateContinuesAcrossPieces) {
  const std::uint8_t data[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  const std::uint32_t first = hb_crc32c_update(0, data, 4);
  EXPECT_EQ(hb_crc32c_update(first, data + 4, 5), 0xE3069283u);
}

TEST(BoardProtocol, SensorFrameLayoutIsLittleEndianWithTheCrcLast) {
  const hb_sensor_frame f = SampleSensorFrame();
  std::vector<std::uint8_t> out(HB_SENSOR_FRAME_SIZE);
  ASSERT_EQ(hb_encode_sensor(&f, out.data()), 96u);
  EXPECT_EQ(out[0], 'H');
  EXPECT_EQ(out[1], 'B');
  EXPECT_EQ(out[2], 1);
  EXPECT_EQ(out[3], HB_TYPE_SENSOR);
  EXPECT_EQ(out[4], 0x04);  // sequence, least significant byte first
  EXPECT_EQ(out[7], 0x01);
  EXPECT_EQ(out[20], 7);    // adc[0] = 7
  EXPECT_EQ(out[20 + 2 * 18], (18007) & 0xFF);  // adc[18], the supply
  EXPECT_EQ(out[58], 0x00);  // quaternion w = 16384 = 0x4000
  EXPECT_EQ(out[59], 0x40);
  EXPECT_EQ(out[60], 0xFF);  // x = -1
  EXPECT_EQ(out[61], 0xFF);
  const std::uint32_t crc = hb_crc32c(out.data(), 92);
  EXPECT_EQ(out[92], crc & 0xFF);
  EXPECT_EQ(out[95], crc >> 24);
}

TEST(BoardProtocol, FramesRoundTrip) {
  const hb_sensor_frame f = SampleSensorFrame();
  std::vector<std::uint8_t> out(HB_SENSOR_FRAME_SIZE);
  hb_encode_sensor(&f, out.data());
  hb_sensor_frame back{};
  ASSERT_EQ(hb_decode_sensor(out.data(), out.size(), &back), HB_FRAME_OK);
  EXPECT_EQ(std::memcmp(&f, &back, sizeof f), 0);

  hb_command_frame c{};
  c.sequence = 0xFFFFFFFFu;
  c.flags = HB_CMD_RESET_ESTOP | HB_CMD_SAFE;
  c.watchdog_ms = 7;
  for (int i = 0; i < HB_NUM_LEGS; ++i) c.dac[i] = static_cast<std::uint16_t>(65535 - i);
  const auto bytes = Encode(c);
  hb_command_frame c2{};
  ASSERT_EQ(hb_decode_command(bytes.data(), bytes.size(), &c2), HB_FRAME_OK);
  EXPECT_EQ(std::memcmp(&c, &c2, sizeof c), 0);
}

TEST(BoardProtocol, EveryFlippedBitIsABadCrc) {
  hb_command_frame c{};
  c.sequence = 5;
  const auto good = Encode(c);
  hb_command_frame out{};
  for (std::size_t byte = 0; byte < good.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      auto bad = good;
      bad[byte] ^= static_cast<std::uint8_t>(1u << bit);
      EXPECT_EQ(hb_decode_command(bad.data(), bad.size(), &out), HB_FRAME_BAD_CRC) << byte << ":" << bit;
    }
  }
}

TEST(BoardProtocol, EnvelopeVerdictsNameTheirCause) {
  hb_command_frame c{};
  c.sequence = 9;
  hb_command_frame out{};
  const auto good = Encode(c);
  EXPECT_EQ(hb_decode_command(good.data(), 11, &out), HB_FRAME_SHORT);

  auto magic = good;
  magic[1] = 'X';
  PutCrc(magic);
  EXPECT_EQ(hb_decode_command(magic.data(), magic.size(), &out), HB_FRAME_BAD_MAGIC);

  auto old_version = good;
  old_version[2] = 0;
  PutCrc(old_version);
  EXPECT_EQ(hb_decode_command(old_version.data(), old_version.size(), &out), HB_FRAME_BAD_VERSION);
  // A future version's frame of another size is refused for its version, not its size.
  std::vector<std::uint8_t> longer(good.begin(), good.end() - 4);
  longer.insert(longer.end(), {1, 2, 3, 4, 0, 0, 0, 0});
  longer[2] = 2;
  PutCrc(longer);
  EXPECT_EQ(hb_decode_command(longer.data(), longer.size(), &out), HB_FRAME_BAD_VERSION);
  longer[2] = HB_VERSION;
  PutCrc(longer);
  EXPECT_EQ(hb_decode_command(longer.data(), longer.size(), &out), HB_FRAME_BAD_SIZE);

  hb_sensor_frame sensor{};
  EXPECT_EQ(hb_decode_sensor(good.data(), good.size(), &sensor), HB_FRAME_BAD_TYPE);
}

TEST(BoardProtocol, SequenceNewerIsModular) {
  EXPECT_TRUE(hb_sequence_newer(2, 1));
  EXPECT_FALSE(hb_sequence_newer(1, 1));
  EXPECT_FALSE(hb_sequence_newer(1, 2));
  EXPECT_TRUE(hb_sequence_newer(0, 0xFFFFFFFFu));  // wrap
  EXPECT_TRUE(hb_sequence_newer(5, 0xFFFFFFF0u));
  EXPECT_FALSE(hb_sequence_newer(0xFFFFFFF0u, 5));
  EXPECT_TRUE(hb_sequence_newer(0x7FFFFFFFu, 0));
  EXPECT_FALSE(hb_sequence_newer(0x80000000u, 0));  // half the range away: not newer
}

TEST(BoardProtocol, CobsRoundTripsAndHidesEveryZero) {
  std::mt19937 rng(7);
  for (std::size_t size : {1u, 2u, 28u, 96u, 253u, 254u, 255u, 256u, 600u}) {
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<std::uint8_t> data(size);
      for (auto& b : data) b = static_cast<std::uint8_t>(rng() % 4 == 0 ? 0 : rng() % 256);
      if (trial == 0) std::fill(data.begin(), data.end(), 0);
      if (trial == 1) std::fill(data.begin(), data.end(), 0xAB);
      std::vector<std::uint8_t> enc(HB_COBS_MAX_SIZE(size));
      const std::size_t n = hb_cobs_encode(data.data(), size, enc.data(), enc.size());
      ASSERT_GT(n, size);
      EXPECT_EQ(enc[n - 1], 0);
      for (std::size_t k = 0; k + 1 < n; ++k) ASSERT_NE(enc[k], 0) << size << " " << trial << " " << k;
      std::vector<std::uint8_t> dec(size);
      ASSERT_EQ(hb_cobs_decode(enc.data(), n - 1, dec.data(), dec.size()), size);
      EXPECT_EQ(dec, data);
    }
  }
}

TEST(BoardProtocol, CobsRefusesBrokenBlocks) {
  std::uint8_t out[16];
  const std::uint8_t zero_inside[] = {0x03, 0x11, 0x00};
  EXPECT_EQ(hb_cobs_decode(zero_inside, sizeof zero_inside, out, sizeof out), 0u);
  const std::uint8_t truncated[] = {0x05, 0x11, 0x22};
  EXPECT_EQ(hb_cobs_decode(truncated, sizeof truncated, out, sizeof out), 0u);
  const std::uint8_t fits[] = {0x03, 0x11, 0x22, 0x02, 0x33};
  EXPECT_EQ(hb_cobs_decode(fits, sizeof fits, out, 3), 0u);  // needs 4 bytes
  EXPECT_EQ(hb_cobs_decode(fits, sizeof fits, out, 4), 4u);
  std::uint8_t small[3];
  const std::uint8_t data[] = {1, 2, 3};
  EXPECT_EQ(hb_cobs_encode(data, 3, small, sizeof small), 0u);
}

TEST(BoardProtocol, ReasonsHaveDistinctNames) {
  for (int a = 0; a < HB_FRAME_REASON_COUNT; ++a) {
    for (int b = a + 1; b < HB_FRAME_REASON_COUNT; ++b) {
      EXPECT_STRNE(hb_frame_reason_name(static_cast<hb_frame_reason>(a)),
                   hb_frame_reason_name(static_cast<hb_frame_reason>(b)));
    }
  }
}

}  // namespace
