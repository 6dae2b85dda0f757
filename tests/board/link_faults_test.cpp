// The emulated board's link faults (device/emulator/link_faults.hpp), without a socket: every
// Nth frame altered into exactly the refusal it stands for, the seeded loss at its rate and
// the same run to run, a held frame only one at a time, and the command line parsed with
// errors that name the text.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "link_faults.hpp"
#include "hexa_board/protocol.h"

namespace {

using hexa::device::FrameFate;
using hexa::device::LinkFault;
using hexa::device::LinkFaultInjector;
using hexa::device::ParseLinkFault;

std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE> Frame(std::uint32_t sequence) {
  hb_sensor_frame f{};
  f.sequence = sequence;
  f.board_time_us = sequence * 1000u;
  for (int c = 0; c < HB_ADC_CHANNELS; ++c) f.adc[c] = 30000;
  std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE> bytes{};
  hb_encode_sensor(&f, bytes.data());
  return bytes;
}

LinkFault Parse(const std::string& text) {
  LinkFault f;
  std::string error;
  EXPECT_TRUE(ParseLinkFault(text, f, error)) << error;
  return f;
}

TEST(LinkFaults, EveryNthFrameBecomesTheRefusalItStandsFor) {
  LinkFaultInjector faults({Parse("bad-crc:7"), Parse("old-version:11:100"), Parse("out-of-range:13:0:200")}, 1);
  int bad_crc = 0, bad_version = 0, out_of_range = 0, intact = 0;
  for (std::uint64_t tick = 0; tick < 400; ++tick) {
    auto bytes = Frame(static_cast<std::uint32_t>(tick + 1));
    const auto original = bytes;
    const FrameFate fate = faults.Apply(tick, bytes, false);
    hb_sensor_frame decoded{};
    const hb_frame_reason r = hb_decode_sensor(bytes.data(), bytes.size(), &decoded);
    if (fate == FrameFate::kSend) {
      ASSERT_EQ(bytes, original) << tick;
      ++intact;
      continue;
    }
    ASSERT_EQ(fate, FrameFate::kSendAltered) << tick;
    // The first fault due on a tick wins (the order given).
    if (tick % 7 == 6) {
      EXPECT_EQ(r, HB_FRAME_BAD_CRC) << tick;
      ++bad_crc;
    } else if (tick >= 100 && (tick - 100) % 11 == 10) {
      EXPECT_EQ(r, HB_FRAME_BAD_VERSION) << tick;
      ++bad_version;
    } else {
      ASSERT_TRUE(tick < 200 && tick % 13 == 12) << tick;
      EXPECT_EQ(r, HB_FRAME_OK) << tick;  // intact: only the host's range check refuses it
      EXPECT_EQ(decoded.adc[HB_ADC_POT(0)], 0);
      EXPECT_EQ(decoded.adc[HB_ADC_POT(1)], 30000);
      EXPECT_EQ(decoded.sequence, tick + 1);
      ++out_of_range;
    }
  }
  EXPECT_EQ(bad_crc, 57);  // ticks 6, 13, ..., 398
  EXPECT_EQ(faults.counts().bad_crc, 57u);
  EXPECT_EQ(static_cast<std::uint64_t>(bad_version), faults.counts().old_version);
  EXPECT_EQ(static_cast<std::uint64_t>(out_of_range), faults.counts().out_of_range);
  EXPECT_GT(bad_version, 20);
  EXPECT_GT(out_of_range, 10);
  EXPECT_EQ(intact + bad_crc + bad_version + out_of_range, 400);
}

TEST(LinkFaults, LossIsSeededAtItsRateEitherWay) {
  auto run = [](std::uint64_t seed) {
    LinkFaultInjector faults({Parse("drop:5")}, seed);
    std::vector<int> lost;
    for (std::uint64_t tick = 0; tick < 20000; ++tick) {
      auto bytes = Frame(static_cast<std::uint32_t>(tick + 1));
      const bool command_lost = faults.DropCommand(tick);
      const bool frame_lost = faults.Apply(tick, bytes, false) == FrameFate::kDrop;
      lost.push_back((command_lost ? 1 : 0) + (frame_lost ? 2 : 0));
    }
    return std::pair{lost, faults.counts()};
  };
  const auto [a, counts] = run(4);
  const auto [b, counts_b] = run(4);
  const auto [c, counts_c] = run(5);
  EXPECT_EQ(a, b) << "the same seed loses the same datagrams";
  EXPECT_NE(a, c);
  // 20000 datagrams each way at 5 %: 1000 expected, sigma 31.
  EXPECT_NEAR(static_cast<double>(counts.commands_dropped), 1000.0, 150.0);
  EXPECT_NEAR(static_cast<double>(counts.frames_dropped), 1000.0, 150.0);
  LinkFaultInjector none({Parse("drop:0")}, 4);
  auto bytes = Frame(1);
  for (std::uint64_t tick = 0; tick < 1000; ++tick) {
    EXPECT_FALSE(none.DropCommand(tick));
    EXPECT_EQ(none.Apply(tick, bytes, false), FrameFate::kSend);
  }
}

TEST(LinkFaults, ReorderHoldsOneFrameAtATime) {
  LinkFaultInjector faults({Parse("reorder:1")}, 1);
  auto bytes = Frame(1);
  EXPECT_EQ(faults.Apply(0, bytes, false), FrameFate::kHold);
  EXPECT_EQ(faults.Apply(1, bytes, true), FrameFate::kSend);  // sent, then the held one
  EXPECT_EQ(faults.counts().reordered, 1u);
}

TEST(LinkFaults, CommandLineErrorsNameTheText) {
  LinkFault f;
  std::string error;
  for (const std::string& bad : {"drop:101", "drop:x", "bad-crc:0", "bad-crc", "reorder:5:10:10", "noise:3",
                                 "old-version:2:x"}) {
    EXPECT_FALSE(ParseLinkFault(bad, f, error)) << bad;
    EXPECT_NE(error.find("'" + bad + "'"), std::string::npos) << error;
  }
  ASSERT_TRUE(ParseLinkFault("old-version:1:3000", f, error)) << error;
  EXPECT_EQ(f.every, 1u);
  EXPECT_EQ(f.from_tick, 3000u);
  ASSERT_TRUE(ParseLinkFault("drop:1.5", f, error)) << error;
  EXPECT_DOUBLE_EQ(f.drop_fraction, 0.015);
}

}  // namespace
