// The plant's device link without DDS or a process: the e-stop as a device reports it, the
// operator's e-stop and reset, samples that do not come, and the control round trip, against
// a scripted device and a scripted clock.
#include <cstring>
#include <deque>
#include <string>

#include <gtest/gtest.h>

#include "device_link.hpp"

namespace hexa::plant_sim {
namespace {

std::int64_t g_now_ns = 0;
std::int64_t Now() { return g_now_ns; }

// A device whose latch behaves like the board's: latched by the host, reset refused while
// the e-stop loop is open; each ReadSensors answers with the next scripted status (kOk when
// the script is empty).
class ScriptedDevice : public device::Device {
 public:
  bool Configure(std::string&) override { return true; }
  device::DeviceStatus ReadSensors(device::DeviceSensors& out) override {
    device::DeviceStatus status = device::DeviceStatus::kOk;
    if (!reads.empty()) {
      status = reads.front();
      reads.pop_front();
    }
    if (status != device::DeviceStatus::kOk) return status;
    out.safety = safety;
    out.applied_valve_v = written;
    return status;
  }
  device::DeviceStatus WriteValves(const LegArray<double>& valve_v) override {
    written = valve_v;
    ++writes;
    return write_status;
  }
  device::DeviceStatus WriteSafeState() override {
    ++safe_writes;
    return device::DeviceStatus::kOk;
  }
  void LatchEstop() override {
    ++latches;
    safety.estop_latched = true;
    safety.estop_by_host = true;
  }
  void RequestEstopReset() override {
    ++resets;
    safety.reset_refused = safety.estop_loop_open;
    if (!safety.estop_loop_open) safety = device::DeviceSafety{};
  }
  void Close() override {}

  std::deque<device::DeviceStatus> reads;
  device::DeviceStatus write_status = device::DeviceStatus::kOk;
  device::DeviceSafety safety;
  LegArray<double> written{};
  int writes = 0, safe_writes = 0, latches = 0, resets = 0;
};

class DeviceLinkTest : public ::testing::Test {
 protected:
  DeviceLinkTest() : link_(device_, nullptr, DeviceLinkParams{}, &Now) {
    g_now_ns = 0;
    EXPECT_EQ(link_.BringUp(), "");
  }
  // One tick: exchange and judge, the events of both.
  void Tick(std::uint64_t tick) {
    events_.Clear();
    link_.Exchange(LegArray<double>{5, 5, 5, 5, 5, 5}, tick, events_);
    link_.JudgeSafety(tick, events_);
  }

  ScriptedDevice device_;
  DeviceLink link_;
  DeviceEvents events_;
};

TEST_F(DeviceLinkTest, OperatorEstopLatchesTheDeviceOnceAndTheLatchIsReportedOnce) {
  link_.LatchOperatorEstop(7, 10, events_);
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, DeviceEvent::Kind::kOperatorEstop);
  EXPECT_EQ(events_[0].reason(), hexa_msg_FAULT_ESTOP);
  EXPECT_EQ(events_[0].tick, 10u);
  EXPECT_NE(std::strstr(events_[0].detail, "operator command #7"), nullptr) << events_[0].detail;
  // The same command by the other path (the supervisor's FaultEvent): nothing more.
  events_.Clear();
  link_.LatchOperatorEstop(7, 10, events_);
  EXPECT_EQ(events_.size(), 0u);
  EXPECT_EQ(device_.latches, 1);

  Tick(10);  // the sample of tick 11 shows the latch
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, DeviceEvent::Kind::kEstopLatched);
  EXPECT_NE(std::strstr(events_[0].detail, "an e-stop command from the host"), nullptr) << events_[0].detail;
  Tick(11);
  EXPECT_EQ(events_.size(), 0u) << "a latch is reported once, not every tick";
}

TEST_F(DeviceLinkTest, ResetRefusedWhileTheLoopIsOpenThenReleasedOnceClosed) {
  EXPECT_FALSE(link_.RequestEstopReset()) << "nothing latched: nothing to ask";
  EXPECT_EQ(device_.resets, 0);
  device_.safety.estop_latched = true;
  device_.safety.estop_by_input = true;
  device_.safety.estop_loop_open = true;
  Tick(1);
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_NE(std::strstr(events_[0].detail, "the e-stop loop opened"), nullptr) << events_[0].detail;

  EXPECT_TRUE(link_.RequestEstopReset());
  Tick(2);
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, DeviceEvent::Kind::kEstopResetRefused);
  EXPECT_NE(std::strstr(events_[0].detail, "still open"), nullptr) << events_[0].detail;
  Tick(3);
  EXPECT_EQ(events_.size(), 0u) << "a refusal is reported once per reset asked";

  device_.safety.estop_loop_open = false;
  EXPECT_TRUE(link_.RequestEstopReset());
  Tick(4);
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, DeviceEvent::Kind::kEstopReleased);
  EXPECT_FALSE(events_[0].fault());
  // Latched again (an operator e-stop with a new sequence): reported again.
  events_.Clear();
  link_.LatchOperatorEstop(8, 5, events_);
  Tick(5);
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, DeviceEvent::Kind::kEstopLatched);
}

TEST_F(DeviceLinkTest, UnsafeValvesWhileLatchedAreCountedPerTick) {
  device_.safety.estop_latched = true;
  device_.safety.valves_safe = false;
  Tick(1);
  Tick(2);
  EXPECT_EQ(link_.estop_unsafe_ticks(), 2u);
  ASSERT_EQ(events_.size(), 0u);
  EXPECT_EQ(link_.sensors().applied_valve_v[0], 5.0);
}

TEST_F(DeviceLinkTest, RoundTripIsFromTheSampleReadToTheCommandWrittenFromIt) {
  g_now_ns = 1'000'000;
  Tick(0);  // the sample read at 1 ms
  EXPECT_EQ(link_.round_trip().count(), 0u) << "the bring-up's sample is no round trip";
  g_now_ns = 1'300'000;
  Tick(1);  // its command written 0.3 ms later
  EXPECT_EQ(link_.round_trip().count(), 1u);
  EXPECT_DOUBLE_EQ(link_.round_trip().max_s(), 300e-6);
  // A tick without a new sample: counted, no round trip for the next write, no event from a
  // simulated device (its link is not judged).
  device_.reads = {device::DeviceStatus::kNoNewData};
  g_now_ns = 1'500'000;
  Tick(2);
  EXPECT_EQ(link_.samples_missed_total(), 1u);
  EXPECT_EQ(link_.round_trip().count(), 2u);
  g_now_ns = 2'000'000;
  Tick(3);
  EXPECT_EQ(link_.round_trip().count(), 2u) << "no sample read at tick 2: nothing to answer";
  EXPECT_EQ(events_.size(), 0u);
  EXPECT_FALSE(link_.lost());
}

TEST_F(DeviceLinkTest, AFaultOfTheDeviceIsReturnedAndNothingIsRead) {
  device_.write_status = device::DeviceStatus::kFault;
  device_.reads = {device::DeviceStatus::kNoNewData};
  events_.Clear();
  EXPECT_EQ(link_.Exchange(LegArray<double>{}, 3, events_), device::DeviceStatus::kFault);
  EXPECT_EQ(device_.reads.size(), 1u) << "no read after a failed write";
  EXPECT_EQ(link_.samples_missed_total(), 0u);
}

// The hardware lifecycle not active: the device holds its safe state instead of the commands;
// the sample is read as on any tick (sensors are published while inactive).
TEST_F(DeviceLinkTest, SafeStateExchangeWritesTheSafeStateAndStillReadsTheSample) {
  events_.Clear();
  link_.Exchange(LegArray<double>{1, 2, 3, 4, 6, 7}, 0, events_, /*safe_state=*/true);
  EXPECT_EQ(device_.safe_writes, 1);
  EXPECT_EQ(device_.writes, 0);
  EXPECT_EQ(link_.samples_missed_total(), 0u);
  link_.Exchange(LegArray<double>{1, 2, 3, 4, 6, 7}, 1, events_);
  EXPECT_EQ(device_.safe_writes, 1);
  EXPECT_EQ(device_.writes, 1);
  EXPECT_EQ(device_.written[0], 1.0);
}

TEST(DeviceEvents, AFullListDropsAndSaysSo) {
  DeviceEvents events;
  for (std::size_t i = 0; i < DeviceEvents::kCapacity; ++i)
    EXPECT_NE(events.Add(DeviceEvent::Kind::kLinkBack, i), nullptr);
  EXPECT_EQ(events.Add(DeviceEvent::Kind::kLinkBack, 99), nullptr);
  EXPECT_EQ(events.size(), DeviceEvents::kCapacity);
  EXPECT_EQ(events[0].reason(), hexa_msg_FAULT_ESTOP);  // a log-only kind: never published
  EXPECT_FALSE(events[0].fault());
}

}  // namespace
}  // namespace hexa::plant_sim
