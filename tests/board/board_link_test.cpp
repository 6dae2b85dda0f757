// The RemoteBoardDevice against hexa_board_emulator over loopback UDP (docs/board_protocol.md):
// in step mode (one board tick per command, deterministic) the sensors follow the plant's
// physics and equal an in-process emulator's byte for byte; the board's watchdog fires when
// valid commands stop; the e-stop loop latches within its tick and needs a reset with the loop
// closed; every bad frame, in either direction, is counted under its reason. On the wall clock,
// the watchdog fires when the host falls silent. Configuration errors name their cause.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "board_emulator.hpp"
#include "board_link_support.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/device/remote_board_device.hpp"
#include "scratch_dir.hpp"

namespace {

using hexa::device::DeviceSensors;
using hexa::device::DeviceStatus;
using hexa::device::FrameVerdict;
using hexa::device::RemoteBoardDevice;
using hexa::device::RemoteBoardDeviceConfig;
using hexa::testing::EmulatorProcess;
using hexa::testing::LinkProxy;
using hexa::testing::Mangle;

const hexa::config::SystemConfig& Rig() {
  static const hexa::config::SystemConfig rig = hexa::config::LoadSystemConfigOrThrow(hexa::config::DefaultRigFile());
  return rig;
}

RemoteBoardDeviceConfig DeviceConfig(std::uint16_t board_port) {
  RemoteBoardDeviceConfig c;
  c.board_host = "127.0.0.1";
  c.board_port = board_port;
  c.local_host = "127.0.0.1";
  c.calibration = *Rig().board;
  c.valve_null_v = Rig().rig.valve.null_voltage_v;
  return c;
}

void PutCrc(std::vector<std::uint8_t>& frame) {
  const std::uint32_t crc = hb_crc32c(frame.data(), frame.size() - 4);
  for (int k = 0; k < 4; ++k) frame[frame.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
}

hexa::LegArray<double> Volts(double v) {
  hexa::LegArray<double> a;
  a.fill(v);
  return a;
}

// A device and an emulator in step mode with the proxy between them.
class StepLink : public ::testing::Test {
 protected:
  void Start(std::vector<std::string> emulator_args) {
    dir_ = hexa::testing::ScratchDir("board_link");
    emulator_args.insert(emulator_args.end(), {"--clock", "step", "--seed", "3"});
    emulator_ = std::make_unique<EmulatorProcess>(dir_, emulator_args);
    ASSERT_GT(emulator_->port(), 0) << emulator_->Log();
    proxy_ = std::make_unique<LinkProxy>(emulator_->port());
    device_ = std::make_unique<RemoteBoardDevice>(DeviceConfig(proxy_->board_port()));
    std::string error;
    ASSERT_TRUE(device_->Configure(error)) << error;
  }
  void TearDown() override {
    if (device_) device_->Close();
    if (emulator_) emulator_->Stop();
  }
  // One tick: the command through the proxy, the board's frame back. Returns ReadSensors'.
  DeviceStatus Step(const hexa::LegArray<double>& valve_v, const Mangle& command = hexa::testing::Pass,
                    const Mangle& frame = hexa::testing::Pass, bool safe = false) {
    EXPECT_EQ(safe ? device_->WriteSafeState() : device_->WriteValves(valve_v), DeviceStatus::kOk);
    EXPECT_TRUE(proxy_->ForwardCommand(command));
    EXPECT_TRUE(proxy_->ForwardFrame(frame));
    device_->WaitForData(0.5);
    ++ticks_;
    return device_->ReadSensors(sensors_);
  }
  // Power-up latch cleared (the loop closed), as an operator would before activation.
  void Arm() {
    device_->RequestEstopReset();
    for (int k = 0; k < 4; ++k) ASSERT_EQ(Step(Volts(5.0)), DeviceStatus::kOk);
    ASSERT_FALSE(sensors_.safety.estop_latched);
  }
  std::uint64_t BoardTick() const { return static_cast<std::uint64_t>(std::lround(sensors_.device_time_s * 1000.0)); }

  std::string dir_;
  std::unique_ptr<EmulatorProcess> emulator_;
  std::unique_ptr<LinkProxy> proxy_;
  std::unique_ptr<RemoteBoardDevice> device_;
  DeviceSensors sensors_;
  int ticks_ = 0;
};

hexa::device::BoardEmulatorConfig ReferenceBoard(const std::string& profile, std::uint64_t seed) {
  hexa::device::BoardEmulatorConfig ec;
  ec.plant.rig = Rig().rig;
  ec.plant.disturbance = Rig().profiles.at(profile);
  ec.plant.seed = seed;
  ec.calibration = *Rig().board;
  ec.valve_null_v = Rig().rig.valve.null_voltage_v;
  return ec;
}

TEST_F(StepLink, SensorsFollowThePhysicsAndEqualTheInProcessBoard) {
  Start({"--profile", "realistic"});
  // The same board in process, fed the datagrams the proxy forwards: what its plant outputs
  // before each tick is what that tick's frame samples.
  hexa::device::BoardEmulator reference(ReferenceBoard("realistic", 3));
  std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE> expected{};
  hexa::PlatformPlantOutput sampled;
  int identical = 0;
  auto feed = [&](std::vector<std::uint8_t> d) {
    reference.Receive(d);
    sampled = reference.plant().output();
    reference.Tick(expected);
    return std::vector<std::vector<std::uint8_t>>{std::move(d)};
  };
  auto compare = [&](std::vector<std::uint8_t> d) {
    identical += std::equal(d.begin(), d.end(), expected.begin(), expected.end()) ? 1 : 0;
    return std::vector<std::vector<std::uint8_t>>{std::move(d)};
  };
  device_->RequestEstopReset();
  hexa::LegArray<double> v = Volts(5.0);
  double worst_quantisation_m = 0.0, worst_truth_m = 0.0, worst_quantisation_pa = 0.0, worst_truth_pa = 0.0;
  double length_at_100_m = 0.0, truth_at_100_m = 0.0;
  for (int k = 0; k < 400; ++k) {
    v[0] = k >= 100 && k < 300 ? 6.5 : 5.0;  // leg 1's valve off null for 0.2 s
    ASSERT_EQ(Step(v, feed, compare), DeviceStatus::kOk) << k;
    ASSERT_EQ(BoardTick(), static_cast<std::uint64_t>(k));
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
      const hexa::LegSensorReading& r = sampled.legs[i];
      worst_quantisation_m = std::max(worst_quantisation_m, std::abs(sensors_.legs[i].length_m - r.length_m));
      worst_truth_m = std::max(worst_truth_m, std::abs(sensors_.legs[i].length_m - sampled.truth.length_m[i]));
      for (const auto& [measured, plant, truth] :
           {std::tuple{sensors_.legs[i].chamber1_pressure_pa, r.chamber1_pressure_pa,
                       sampled.truth.legs[i].chamber1_pressure_pa},
            std::tuple{sensors_.legs[i].chamber2_pressure_pa, r.chamber2_pressure_pa,
                       sampled.truth.legs[i].chamber2_pressure_pa}}) {
        worst_quantisation_pa = std::max(worst_quantisation_pa, std::abs(measured - plant));
        worst_truth_pa = std::max(worst_truth_pa, std::abs(measured - truth));
      }
    }
    if (k == 100) {
      length_at_100_m = sensors_.legs[0].length_m;
      truth_at_100_m = sampled.truth.length_m[0];
    }
  }
  EXPECT_EQ(identical, 400) << "the frames over the socket differ from the in-process board's";
  // The ADC adds no more than half a count to the plant's readings (4 um, 15 Pa per count).
  EXPECT_LE(worst_quantisation_m, 2.0e-6 + 1e-12);
  EXPECT_LE(worst_quantisation_pa, 7.5 + 1e-9);
  // Against the truth: the realistic profile's potentiometer offset (<= 1 mm), gain error
  // (<= 0.5 % of the piston position) and noise; pressure noise sigma 2 kPa.
  EXPECT_LT(worst_truth_m, 2.0e-3);
  EXPECT_LT(worst_truth_pa, 10.0e3);
  // The valve moved the leg, and the measurement moved with the truth.
  const double moved_m = sensors_.legs[0].length_m - length_at_100_m;
  const double truth_moved_m = sampled.truth.length_m[0] - truth_at_100_m;
  EXPECT_GT(std::abs(truth_moved_m), 0.005);
  EXPECT_LT(std::abs(truth_moved_m), 0.1);  // not at an end stop
  // Potentiometer gain error (<= 0.5 %) of the motion, plus noise and quantisation.
  EXPECT_NEAR(moved_m, truth_moved_m, 0.005 * std::abs(truth_moved_m) + 0.5e-3);
  EXPECT_EQ(device_->counters().refused(), 0u) << device_->counters().Describe();
}

TEST_F(StepLink, WatchdogFiresWhenValidCommandsStop) {
  Start({"--profile", "ideal"});
  Arm();
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);  // the last valid command, at board tick T
  const std::uint64_t t = BoardTick();
  ASSERT_NEAR(sensors_.applied_valve_v[0], 6.0, 1e-3);
  auto corrupt = [](std::vector<std::uint8_t> d) {
    d[13] ^= 0x01;  // a DAC bit: the CRC no longer matches
    return std::vector<std::vector<std::uint8_t>>{std::move(d)};
  };
  // Each corrupted command still ticks the board (step mode), but does not feed the watchdog
  // (5 ms): the valves hold for 5 ticks and are safe from the 6th, by the board itself.
  for (std::uint64_t k = 1; k <= 10; ++k) {
    ASSERT_EQ(Step(Volts(6.0), corrupt), DeviceStatus::kOk);
    ASSERT_EQ(BoardTick(), t + k);
    const bool expired = k >= 6;
    EXPECT_EQ(sensors_.safety.watchdog_expired, expired) << k;
    EXPECT_EQ(sensors_.safety.valves_safe, expired) << k;
    EXPECT_NEAR(sensors_.applied_valve_v[3], expired ? 5.0 : 6.0, 1e-3) << k;
  }
  EXPECT_EQ(sensors_.safety.watchdog_count, 1u);
  EXPECT_FALSE(sensors_.safety.estop_latched);
  EXPECT_EQ(device_->decoder().last_frame().rejected_count, 10u);
  EXPECT_EQ(device_->decoder().last_frame().last_reject, HB_FRAME_BAD_CRC);
  // A valid command again: the valves follow from that tick.
  ASSERT_EQ(Step(Volts(4.0)), DeviceStatus::kOk);
  EXPECT_FALSE(sensors_.safety.watchdog_expired);
  EXPECT_NEAR(sensors_.applied_valve_v[3], 4.0, 1e-3);
}

TEST_F(StepLink, BoardRefusesOldVersionsAndReplayedCommands) {
  Start({"--profile", "ideal"});
  Arm();
  std::vector<std::uint8_t> kept;
  auto keep = [&](std::vector<std::uint8_t> d) {
    kept = d;
    return std::vector<std::vector<std::uint8_t>>{std::move(d)};
  };
  ASSERT_EQ(Step(Volts(5.5), keep), DeviceStatus::kOk);
  auto replay = [&](std::vector<std::uint8_t>) { return std::vector<std::vector<std::uint8_t>>{kept}; };
  ASSERT_EQ(Step(Volts(7.0), replay), DeviceStatus::kOk);
  EXPECT_EQ(device_->decoder().last_frame().last_reject, HB_FRAME_OLD_SEQUENCE);
  EXPECT_NEAR(sensors_.applied_valve_v[0], 5.5, 1e-3);
  auto old_version = [](std::vector<std::uint8_t> d) {
    d[2] = 0;
    PutCrc(d);
    return std::vector<std::vector<std::uint8_t>>{std::move(d)};
  };
  ASSERT_EQ(Step(Volts(7.0), old_version), DeviceStatus::kOk);
  EXPECT_EQ(device_->decoder().last_frame().last_reject, HB_FRAME_BAD_VERSION);
  EXPECT_EQ(device_->decoder().last_frame().rejected_count, 2u);
  EXPECT_NEAR(sensors_.applied_valve_v[0], 5.5, 1e-3);
}

TEST_F(StepLink, BadFramesFromTheBoardAreCountedAndNamed) {
  Start({"--profile", "ideal"});
  Arm();
  auto one = [](std::vector<std::uint8_t> d) { return std::vector<std::vector<std::uint8_t>>{std::move(d)}; };
  auto bad_crc = [&](std::vector<std::uint8_t> d) {
    d[40] ^= 0x80;
    return one(std::move(d));
  };
  auto old_version = [&](std::vector<std::uint8_t> d) {
    d[2] = 0;
    PutCrc(d);
    return one(std::move(d));
  };
  auto twice = [](std::vector<std::uint8_t> d) { return std::vector<std::vector<std::uint8_t>>{d, d}; };
  auto wrong_size = [&](std::vector<std::uint8_t> d) {
    d.resize(64);
    PutCrc(d);
    return one(std::move(d));
  };
  auto pot_cut = [&](std::vector<std::uint8_t> d) {
    d[20] = 0;  // adc[0], leg 1's potentiometer: 0 counts = 0.3734 m, below its range
    d[21] = 0;
    PutCrc(d);
    return one(std::move(d));
  };
  std::vector<std::uint8_t> held;
  auto hold = [&](std::vector<std::uint8_t> d) {
    held = std::move(d);
    return std::vector<std::vector<std::uint8_t>>{};
  };
  auto after_held = [&](std::vector<std::uint8_t> d) { return std::vector<std::vector<std::uint8_t>>{d, held}; };
  const auto ok_before = device_->counters()[FrameVerdict::kOk];

  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, bad_crc), DeviceStatus::kNoNewData);
  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, old_version), DeviceStatus::kNoNewData);
  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, twice), DeviceStatus::kOk);  // the copy is refused
  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, wrong_size), DeviceStatus::kNoNewData);
  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, pot_cut), DeviceStatus::kNoNewData);
  device_->WriteValves(Volts(5.0));  // a frame held back and delivered after the next one
  ASSERT_TRUE(proxy_->ForwardCommand());
  ASSERT_TRUE(proxy_->ForwardFrame(hold));
  EXPECT_EQ(Step(Volts(5.0), hexa::testing::Pass, after_held), DeviceStatus::kOk);
  proxy_->SendFromStranger(std::vector<std::uint8_t>(HB_SENSOR_FRAME_SIZE, 0x55));
  device_->WaitForData(0.5);
  EXPECT_EQ(device_->ReadSensors(sensors_), DeviceStatus::kNoNewData);

  const auto& n = device_->counters();
  EXPECT_EQ(n[FrameVerdict::kOk] - ok_before, 2u);
  EXPECT_EQ(n[FrameVerdict::kBadCrc], 1u);
  EXPECT_EQ(n[FrameVerdict::kBadVersion], 1u);
  EXPECT_EQ(n[FrameVerdict::kOldSequence], 2u);  // the duplicate and the late one
  EXPECT_EQ(n[FrameVerdict::kBadSize], 1u);
  EXPECT_EQ(n[FrameVerdict::kOutOfRange], 1u);
  EXPECT_EQ(n[FrameVerdict::kUnknownSender], 1u);
  EXPECT_EQ(n.refused(), 7u) << n.Describe();
  EXPECT_EQ(hexa::device::BoardChannelName(device_->decoder().last_out_of_range_channel()), "leg 1 potentiometer_m");
  EXPECT_NEAR(device_->decoder().last_out_of_range_value_si(), 0.3734, 1e-9);
}

TEST_F(StepLink, EstopLoopLatchesWithinItsTickAndNeedsAResetWithTheLoopClosed) {
  Start({"--profile", "ideal", "--estop-open", "200:260"});
  Arm();
  while (ticks_ < 200) ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  ASSERT_EQ(BoardTick(), 199u);
  EXPECT_FALSE(sensors_.safety.estop_latched);
  EXPECT_NEAR(sensors_.applied_valve_v[2], 6.0, 1e-3);
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);  // tick 200: the loop opens
  EXPECT_TRUE(sensors_.safety.estop_loop_open);
  EXPECT_TRUE(sensors_.safety.estop_latched);
  EXPECT_TRUE(sensors_.safety.estop_by_input);
  EXPECT_TRUE(sensors_.safety.valves_safe);
  EXPECT_NEAR(sensors_.applied_valve_v[2], 5.0, 1e-3);  // in the same tick
  while (ticks_ < 230) ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  device_->RequestEstopReset();  // refused: the loop is open
  for (int k = 0; k < 5; ++k) ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  EXPECT_TRUE(sensors_.safety.reset_refused);
  EXPECT_TRUE(sensors_.safety.estop_latched);
  while (ticks_ < 300) {
    ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
    ASSERT_TRUE(sensors_.safety.estop_latched) << BoardTick();  // closing the loop alone: still latched
    ASSERT_NEAR(sensors_.applied_valve_v[2], 5.0, 1e-3);
  }
  EXPECT_FALSE(sensors_.safety.estop_loop_open);
  device_->RequestEstopReset();
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);  // the board clears the latch at this tick
  EXPECT_FALSE(sensors_.safety.estop_latched);
  EXPECT_FALSE(sensors_.safety.reset_refused);
  EXPECT_NEAR(sensors_.applied_valve_v[2], 6.0, 1e-3);
  // The operator's e-stop through the device latches the same way.
  device_->LatchEstop();
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  EXPECT_TRUE(sensors_.safety.estop_latched);
  EXPECT_TRUE(sensors_.safety.estop_by_host);
  EXPECT_NEAR(sensors_.applied_valve_v[2], 5.0, 1e-3);
  device_->RequestEstopReset();  // during the previous request's run: one frame without the bit
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  EXPECT_TRUE(sensors_.safety.estop_latched);
  ASSERT_EQ(Step(Volts(6.0)), DeviceStatus::kOk);
  EXPECT_FALSE(sensors_.safety.estop_latched);
}

TEST_F(StepLink, SafeStateHoldsTheValvesWhileTheLinkStaysAlive) {
  Start({"--profile", "ideal"});
  Arm();
  for (int k = 0; k < 20; ++k) ASSERT_EQ(Step(Volts(7.0), hexa::testing::Pass, hexa::testing::Pass, true), DeviceStatus::kOk);
  EXPECT_TRUE(sensors_.safety.host_safe);
  EXPECT_TRUE(sensors_.safety.valves_safe);
  EXPECT_FALSE(sensors_.safety.watchdog_expired);
  EXPECT_NEAR(sensors_.applied_valve_v[5], 5.0, 1e-3);
}

TEST(BoardLinkWallClock, WatchdogFiresWhenTheHostFallsSilent) {
  const std::string dir = hexa::testing::ScratchDir("board_wall");
  EmulatorProcess emulator(dir, {"--clock", "wall", "--profile", "ideal"});
  ASSERT_GT(emulator.port(), 0) << emulator.Log();
  RemoteBoardDevice device(DeviceConfig(emulator.port()));
  std::string error;
  ASSERT_TRUE(device.Configure(error)) << error;
  device.RequestEstopReset();
  DeviceSensors s;
  // Commands at the board's pace (one per frame received) for 300 frames, then silence.
  std::uint32_t last_sent = 0;
  for (int frames = 0; frames < 300;) {
    ASSERT_EQ(device.WriteValves(Volts(5.5)), DeviceStatus::kOk);
    last_sent = device.encoder().sequence();
    if (device.WaitForData(2.0) && device.ReadSensors(s) == DeviceStatus::kOk) ++frames;
  }
  // The first frame acknowledging the last command is the tick the board took it.
  double acked_s = -1.0, fired_s = -1.0;
  for (int k = 0; k < 5000 && fired_s < 0.0; ++k) {
    if (!device.WaitForData(2.0)) break;
    if (device.ReadSensors(s) != DeviceStatus::kOk) continue;
    if (acked_s < 0.0 && device.decoder().last_frame().ack_sequence == last_sent) acked_s = s.device_time_s;
    if (acked_s >= 0.0 && s.safety.watchdog_expired) fired_s = s.device_time_s;
  }
  ASSERT_GE(acked_s, 0.0) << emulator.Log();
  ASSERT_GE(fired_s, 0.0) << emulator.Log();
  // The board fires 6 ticks ("more than 5 ms") after the tick it took the last command; the
  // host sees only the newest of the frames waiting when it reads, so the first acknowledging
  // frame it sees may be a later one: the firing is at most 6 ms of board time after it.
  EXPECT_GT(fired_s - acked_s, 0.0);
  EXPECT_LE(fired_s - acked_s, 0.006 + 1e-9);
  EXPECT_TRUE(s.safety.valves_safe);
  EXPECT_NEAR(s.applied_valve_v[0], 5.0, 1e-3);
  EXPECT_GE(s.safety.watchdog_count, 1u);
}

TEST(BoardLinkRead, NewestOfSeveralFramesKeepsAnImuSampleRenewedBeforeIt) {
  hexa::device::UdpSocket board;  // a board of the test's own
  std::string error;
  ASSERT_TRUE(board.Open(*hexa::device::ParseIpv4("127.0.0.1", 0), error)) << error;
  RemoteBoardDevice device(DeviceConfig(ntohs(board.local_address().sin_port)));
  ASSERT_TRUE(device.Configure(error)) << error;
  const hexa::BoardCalibration& cal = *Rig().board;
  auto send = [&](std::uint32_t sequence, std::uint8_t imu_count) {
    hb_sensor_frame f{};
    f.sequence = sequence;
    f.board_time_us = sequence * 1000;
    for (int i = 0; i < HB_NUM_LEGS; ++i) {
      f.adc[HB_ADC_POT(i)] = static_cast<std::uint16_t>(cal.legs[0].potentiometer_m.ToCounts(0.5));
      f.adc[HB_ADC_CHAMBER1(i)] = f.adc[HB_ADC_CHAMBER2(i)] = 20000;
    }
    f.adc[HB_ADC_SUPPLY] = 40000;
    f.imu_quat[0] = 16384;
    f.imu_count = imu_count;
    std::vector<std::uint8_t> bytes(HB_SENSOR_FRAME_SIZE);
    hb_encode_sensor(&f, bytes.data());
    int err = 0;
    ASSERT_TRUE(board.Send(bytes, device.local_address(), err));
  };
  DeviceSensors s;
  send(1, 4);
  ASSERT_TRUE(device.WaitForData(2.0));
  ASSERT_EQ(device.ReadSensors(s), DeviceStatus::kOk);
  send(2, 5);  // the IMU renewed here ...
  send(3, 5);  // ... and not here; on loopback both are queued when send returns
  ASSERT_TRUE(device.WaitForData(2.0));
  ASSERT_EQ(device.ReadSensors(s), DeviceStatus::kOk);
  EXPECT_EQ(device.decoder().last_frame().sequence, 3u);
  EXPECT_TRUE(s.imu.fresh);
  EXPECT_NEAR(s.imu.sample_time_s, 0.002, 1e-9);
}

TEST(BoardLinkConfig, ErrorsNameTheirCause) {
  RemoteBoardDeviceConfig c = DeviceConfig(5005);
  c.board_host = "192.168.1.300";
  try {
    RemoteBoardDevice device(c);
    ADD_FAILURE() << "an invalid board address was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("board_host"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("192.168.1.300"), std::string::npos) << e.what();
  }
  // A local port in use: the device and the emulator both say which address.
  hexa::device::UdpSocket taken;
  std::string error;
  ASSERT_TRUE(taken.Open(*hexa::device::ParseIpv4("127.0.0.1", 0), error)) << error;
  const std::uint16_t port = ntohs(taken.local_address().sin_port);
  c = DeviceConfig(5005);
  c.local_port = port;
  RemoteBoardDevice device(c);
  EXPECT_FALSE(device.Configure(error));
  EXPECT_NE(error.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << error;
  EXPECT_NE(error.find("in use"), std::string::npos) << error;
  EXPECT_EQ(device.ReadSensors(*std::make_unique<DeviceSensors>()), DeviceStatus::kNotConfigured);

  const std::string dir = hexa::testing::ScratchDir("board_config");
  const pid_t busy = EmulatorProcess::Spawn({HEXA_BOARD_EMULATOR_BIN, "--port", std::to_string(port)}, dir + "/busy.log");
  EXPECT_EQ(EmulatorProcess::WaitExit(busy, 30.0), 3);
  std::ifstream busy_log(dir + "/busy.log");
  const std::string busy_text((std::istreambuf_iterator<char>(busy_log)), {});
  EXPECT_NE(busy_text.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << busy_text;

  // A rig file without a `board` block.
  std::ifstream in(hexa::config::DefaultRigFile());
  std::string text((std::istreambuf_iterator<char>(in)), {});
  text = text.substr(0, text.find("\nboard {"));
  const std::string no_board = dir + "/no_board.textproto";
  std::ofstream(no_board) << text << "\n";
  const pid_t rigless = EmulatorProcess::Spawn({HEXA_BOARD_EMULATOR_BIN, "--rig", no_board}, dir + "/no_board.log");
  EXPECT_EQ(EmulatorProcess::WaitExit(rigless, 30.0), 1);
  std::ifstream log(dir + "/no_board.log");
  const std::string log_text((std::istreambuf_iterator<char>(log)), {});
  EXPECT_NE(log_text.find("no `board` block"), std::string::npos) << log_text;
}

}  // namespace
