// The board's side (firmware/board/board.h): power-up state, command intake and its refusals,
// the watchdog, the e-stop latch and its reset, the sensor frame. Time is an argument: every
// case is exact to the microsecond.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "hexa_board/board.h"

namespace {

constexpr std::uint32_t kTickUs = 1000;

hb_board_config Config() {
  hb_board_config c{};
  for (int i = 0; i < HB_NUM_LEGS; ++i) c.safe_dac[i] = static_cast<std::uint16_t>(2048 + i);
  c.dac_max = 4095;
  c.watchdog_default_ms = 5;
  c.watchdog_min_ms = 2;
  c.watchdog_max_ms = 100;
  return c;
}

hb_board_inputs Inputs(bool loop_closed = true) {
  hb_board_inputs in{};
  for (int i = 0; i < HB_ADC_CHANNELS; ++i) in.adc[i] = static_cast<std::uint16_t>(100 + i);
  in.imu_quat[0] = 16384;
  in.digital_inputs = loop_closed ? HB_DIN_ESTOP_LOOP_CLOSED : 0;
  return in;
}

// The host's side of a test: numbered command frames.
struct Host {
  std::uint32_t sequence = 0;
  std::vector<std::uint8_t> Command(std::uint16_t dac, std::uint16_t flags = 0, std::uint16_t watchdog_ms = 0) {
    hb_command_frame c{};
    c.sequence = ++sequence;
    c.flags = flags;
    c.watchdog_ms = watchdog_ms;
    for (auto& d : c.dac) d = dac;
    std::vector<std::uint8_t> out(HB_COMMAND_FRAME_SIZE);
    hb_encode_command(&c, out.data());
    return out;
  }
};

class BoardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const hb_board_config c = Config();
    hb_board_init(&board_, &c);
  }
  hb_frame_reason Receive(const std::vector<std::uint8_t>& frame) {
    return hb_board_receive(&board_, frame.data(), frame.size(), now_us_);
  }
  // One tick at now_us_, then the clock advances one tick.
  void Tick(bool loop_closed = true) {
    const hb_board_inputs in = Inputs(loop_closed);
    hb_board_tick(&board_, &in, now_us_, dac_);
    now_us_ += kTickUs;
  }
  hb_sensor_frame Frame() {
    std::vector<std::uint8_t> out(HB_SENSOR_FRAME_SIZE);
    EXPECT_EQ(hb_board_frame(&board_, out.data()), static_cast<std::size_t>(HB_SENSOR_FRAME_SIZE));
    hb_sensor_frame f{};
    EXPECT_EQ(hb_decode_sensor(out.data(), out.size(), &f), HB_FRAME_OK);
    return f;
  }
  bool Safe() const {
    for (int i = 0; i < HB_NUM_LEGS; ++i) {
      if (dac_[i] != Config().safe_dac[i]) return false;
    }
    return true;
  }
  // Power-up latch cleared by a reset edge with the loop closed; the valves then follow.
  void Arm() {
    ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
    Tick();
    ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
    Tick();
    ASSERT_FALSE(board_.estop_latched);
    ASSERT_EQ(dac_[0], 1000);
  }

  hb_board board_{};
  Host host_;
  std::uint32_t now_us_ = 0xFFFFF000u;  // the microsecond clock wraps within the first ticks
  std::uint16_t dac_[HB_NUM_LEGS]{};
};

TEST_F(BoardTest, PowerUpIsLatchedSafeAndSaysSo) {
  Tick();
  EXPECT_TRUE(Safe());
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.sequence, 1u);
  EXPECT_EQ(f.ack_sequence, 0u);
  EXPECT_TRUE(f.status & HB_STATUS_VALVES_SAFE);
  EXPECT_TRUE(f.status & HB_STATUS_ESTOP_LATCHED);
  EXPECT_TRUE(f.status & HB_STATUS_ESTOP_AT_POWER_UP);
  EXPECT_TRUE(f.status & HB_STATUS_NO_COMMAND_YET);
  EXPECT_TRUE(f.status & HB_STATUS_WATCHDOG);
  EXPECT_EQ(f.watchdog_count, 0u);  // not a firing: there was never a command
  EXPECT_EQ(f.dac_applied[3], 2051u);
  EXPECT_EQ(f.adc[18], 118u);
  EXPECT_EQ(Frame().sequence, 2u);
}

TEST_F(BoardTest, ACommandWithoutResetLeavesThePowerUpLatch) {
  ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
  Tick();
  EXPECT_TRUE(Safe());
  EXPECT_TRUE(Frame().status & HB_STATUS_ESTOP_LATCHED);
  Arm();
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.status, 0u);
  EXPECT_EQ(f.ack_sequence, host_.sequence);
  EXPECT_EQ(f.dac_applied[5], 1000u);
}

TEST_F(BoardTest, WatchdogFiresAfterItsTimeAndCountsOnce) {
  Arm();  // last command at tick 1; default watchdog 5 ms
  const std::uint32_t last_command_us = now_us_ - kTickUs;
  for (int k = 0; k < 4; ++k) {  // 1..4 ms silent (the tick after the command: 1 ms)
    Tick();
    EXPECT_FALSE(Safe()) << k;
  }
  Tick();  // 5 ms silent: "more than 5 ms" is not yet reached
  EXPECT_EQ(now_us_ - kTickUs - last_command_us, 5000u);
  EXPECT_FALSE(Safe());
  Tick();  // 6 ms
  EXPECT_TRUE(Safe());
  hb_sensor_frame f = Frame();
  EXPECT_TRUE(f.status & HB_STATUS_WATCHDOG);
  EXPECT_TRUE(f.status & HB_STATUS_VALVES_SAFE);
  EXPECT_FALSE(f.status & HB_STATUS_ESTOP_LATCHED);
  EXPECT_EQ(f.watchdog_count, 1u);
  for (int k = 0; k < 10; ++k) Tick();
  EXPECT_EQ(Frame().watchdog_count, 1u);
  // A fresh valid command re-arms it; the valves follow again.
  ASSERT_EQ(Receive(host_.Command(3000)), HB_FRAME_OK);
  Tick();
  EXPECT_EQ(dac_[2], 3000);
  f = Frame();
  EXPECT_FALSE(f.status & HB_STATUS_WATCHDOG);
  EXPECT_EQ(f.watchdog_count, 1u);
}

TEST_F(BoardTest, RefusedFramesDoNotFeedTheWatchdog) {
  Arm();
  hb_board_inputs in = Inputs();
  for (int k = 0; k < 10; ++k) {
    auto bad = host_.Command(1000);
    bad[12] ^= 0x01;  // payload bit: bad CRC
    EXPECT_EQ(Receive(bad), HB_FRAME_BAD_CRC);
    hb_board_tick(&board_, &in, now_us_, dac_);
    now_us_ += kTickUs;
  }
  EXPECT_TRUE(Safe());
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.watchdog_count, 1u);
  EXPECT_EQ(f.rejected_count, 10u);
  EXPECT_EQ(f.last_reject, HB_FRAME_BAD_CRC);
}

TEST_F(BoardTest, WatchdogTimeComesFromTheCommandClamped) {
  ASSERT_EQ(Receive(host_.Command(1000, 0, 40)), HB_FRAME_OK);
  EXPECT_EQ(board_.watchdog_ms, 40u);
  ASSERT_EQ(Receive(host_.Command(1000, 0, 1)), HB_FRAME_OK);
  EXPECT_EQ(board_.watchdog_ms, 2u);
  ASSERT_EQ(Receive(host_.Command(1000, 0, 60000)), HB_FRAME_OK);
  EXPECT_EQ(board_.watchdog_ms, 100u);
  ASSERT_EQ(Receive(host_.Command(1000, 0, 0)), HB_FRAME_OK);
  EXPECT_EQ(board_.watchdog_ms, 5u);
  Tick();
  EXPECT_EQ(Frame().watchdog_ms, 5u);
}

TEST_F(BoardTest, OpenLoopLatchesWithinTheTickAndNeedsAClosedLoopReset) {
  Arm();
  ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
  Tick(false);  // the loop opens: safe in this very tick
  EXPECT_TRUE(Safe());
  hb_sensor_frame f = Frame();
  EXPECT_TRUE(f.status & HB_STATUS_ESTOP_LATCHED);
  EXPECT_TRUE(f.status & HB_STATUS_ESTOP_BY_INPUT);
  EXPECT_FALSE(f.digital_inputs & HB_DIN_ESTOP_LOOP_CLOSED);
  // Closing the loop alone does not release it.
  ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
  Tick(true);
  EXPECT_TRUE(Safe());
  // A reset while the loop is open is refused and said so.
  ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
  Tick(false);
  EXPECT_TRUE(Safe());
  EXPECT_TRUE(Frame().status & HB_STATUS_RESET_REFUSED);
  // Holding the reset bit while the loop closes is no new edge: still latched.
  ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
  Tick(true);
  EXPECT_TRUE(Safe());
  // Release, press again with the loop closed: reset.
  ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
  Tick(true);
  ASSERT_EQ(Receive(host_.Command(1500, HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
  Tick(true);
  EXPECT_EQ(dac_[0], 1500);
  f = Frame();
  EXPECT_EQ(f.status & (HB_STATUS_ESTOP_LATCHED | HB_STATUS_RESET_REFUSED | HB_STATUS_ESTOP_BY_INPUT), 0u);
}

TEST_F(BoardTest, HostEstopLatchesAndIsNotResetWhileAsked) {
  Arm();
  ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_ESTOP)), HB_FRAME_OK);
  Tick();
  EXPECT_TRUE(Safe());
  const hb_sensor_frame f = Frame();
  EXPECT_TRUE(f.status & HB_STATUS_ESTOP_BY_HOST);
  EXPECT_FALSE(f.status & HB_STATUS_ESTOP_BY_INPUT);
  ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_ESTOP | HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
  Tick();
  EXPECT_TRUE(Safe());
  EXPECT_TRUE(Frame().status & HB_STATUS_RESET_REFUSED);
  ASSERT_EQ(Receive(host_.Command(1000)), HB_FRAME_OK);
  Tick();
  ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_RESET_ESTOP)), HB_FRAME_OK);
  Tick();
  EXPECT_FALSE(Safe());
}

TEST_F(BoardTest, HostSafeRequestHoldsTheValvesWithTheLinkAlive) {
  Arm();
  for (int k = 0; k < 20; ++k) {
    ASSERT_EQ(Receive(host_.Command(1000, HB_CMD_SAFE)), HB_FRAME_OK);
    Tick();
    EXPECT_TRUE(Safe());
  }
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.status, HB_STATUS_VALVES_SAFE | HB_STATUS_HOST_SAFE);
  EXPECT_EQ(f.watchdog_count, 0u);
}

TEST_F(BoardTest, DuplicateAndOlderSequencesAreRefusedAndCounted) {
  Arm();
  const auto newer = host_.Command(2000);
  const auto older = host_.Command(3000);  // sequence + 1, but delivered late
  const auto newest = host_.Command(2500);
  ASSERT_EQ(Receive(newest), HB_FRAME_OK);
  EXPECT_EQ(Receive(newest), HB_FRAME_OLD_SEQUENCE);  // duplicate
  EXPECT_EQ(Receive(older), HB_FRAME_OLD_SEQUENCE);
  EXPECT_EQ(Receive(newer), HB_FRAME_OLD_SEQUENCE);
  Tick();
  EXPECT_EQ(dac_[0], 2500);
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.rejected_count, 3u);
  EXPECT_EQ(f.last_reject, HB_FRAME_OLD_SEQUENCE);
  EXPECT_EQ(f.ack_sequence, host_.sequence);
  // A gap (lost frames) is fine.
  host_.sequence += 100;
  EXPECT_EQ(Receive(host_.Command(100)), HB_FRAME_OK);
}

TEST_F(BoardTest, AnotherVersionIsRefusedAndNamed) {
  Arm();
  auto frame = host_.Command(4000);
  frame[2] = 2;
  const std::uint32_t crc = hb_crc32c(frame.data(), frame.size() - 4);
  for (int k = 0; k < 4; ++k) frame[frame.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
  EXPECT_EQ(Receive(frame), HB_FRAME_BAD_VERSION);
  Tick();
  EXPECT_EQ(dac_[0], 1000);
  const hb_sensor_frame f = Frame();
  EXPECT_EQ(f.last_reject, HB_FRAME_BAD_VERSION);
  EXPECT_EQ(f.rejected_count, 1u);
}

TEST_F(BoardTest, DacAboveFullScaleIsRefused) {
  Arm();
  EXPECT_EQ(Receive(host_.Command(4096)), HB_FRAME_OUT_OF_RANGE);
  EXPECT_EQ(Receive(host_.Command(4095)), HB_FRAME_OK);
  Tick();
  EXPECT_EQ(dac_[1], 4095);
  EXPECT_EQ(Frame().rejected_count, 1u);
}

}  // namespace
