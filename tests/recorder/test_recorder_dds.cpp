// record and play over DDS (real processes, loopback, domains 60-69): samples published here
// are recorded by a hexa_recorder child process with exact counts and loss from ticks; a
// recording played back by a child arrives here field for field.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <cstring>
#include <filesystem>
#include <thread>

#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/reader.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/comm/writer.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"

#ifndef HEXA_RECORDER_BIN
#error "HEXA_RECORDER_BIN must name the hexa_recorder executable"
#endif

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;
using namespace std::chrono_literals;

// hexa_recorder child; killed by PID and reaped in the destructor whatever the test's outcome.
class Child {
 public:
  explicit Child(std::vector<std::string> args) {
    args.insert(args.begin(), HEXA_RECORDER_BIN);
    std::vector<char*> argv;
    for (auto& s : args) argv.push_back(s.data());
    argv.push_back(nullptr);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) _exit(111);
      ::execv(argv[0], argv.data());
      _exit(112);
    }
  }
  ~Child() {
    if (pid_ > 0 && !reaped_) {
      ::kill(pid_, SIGKILL);
      int st;
      ::waitpid(pid_, &st, 0);
    }
  }
  void Signal(int sig) { ::kill(pid_, sig); }
  // Exit code, or -1 on timeout / signal death.
  int Wait(std::chrono::seconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      int st = 0;
      const pid_t r = ::waitpid(pid_, &st, WNOHANG);
      if (r == pid_) {
        reaped_ = true;
        return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
      }
      std::this_thread::sleep_for(10ms);
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
};

template <typename W>
bool WaitMatched(const W& w, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (w.Snapshot().publication_matched_current >= 1) return true;
    std::this_thread::sleep_for(10ms);
  }
  return false;
}

class RecorderDds : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { comm::EnsureDdsConfig(); }
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("hexa_rec_dds_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(RecorderDds, RecordsEveryPublishedSampleWithLossFromTicks) {
  constexpr int kDomain = 61;
  const std::string out = dir_ / "rec.mcap";
  Child rec({"record", "--output", out, "--domain", std::to_string(kDomain), "--flush-ms", "50",
             "--quiet"});
  comm::Participant p(kDomain);
  comm::Topic<hexa_msg_LegSensors> sensors_topic(p);
  comm::Topic<hexa_msg_ImuSample> imu_topic(p);
  comm::Topic<hexa_msg_FaultEvent> fault_topic(p);
  comm::QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  params.lockstep = true;  // reliable writers, as the recorder's default (reliable) QoS needs
  comm::Writer<hexa_msg_LegSensors> sensors(p, sensors_topic, params);
  comm::Writer<hexa_msg_ImuSample> imu(p, imu_topic, params);
  comm::Writer<hexa_msg_FaultEvent> fault(p, fault_topic, params);
  ASSERT_TRUE(WaitMatched(sensors, 20s));
  ASSERT_TRUE(WaitMatched(imu, 20s));
  ASSERT_TRUE(WaitMatched(fault, 20s));

  uint64_t sent_sensors = 0, sent_imu = 0;
  for (uint64_t tick = 1; tick <= 300; ++tick) {
    for (uint8_t leg = 1; leg <= 6; ++leg) {
      if (leg == 5 && tick >= 50 && tick < 53) continue;  // 3 samples never sent
      hexa_msg_LegSensors s{};
      s.leg_id = leg;
      s.header.tick = tick;
      s.header.sim_time_s = 1e-3 * static_cast<double>(tick);
      s.header.source_time_ns = 1'000'000'000'000 + static_cast<int64_t>(tick) * 1'000'000 + leg;
      s.length_m = 0.5 + 1e-4 * leg;
      s.cap_pressure_pa = 4e5 + static_cast<double>(tick);
      ASSERT_GE(sensors.Write(s, comm::RealtimeNow_ns()), 0);
      ++sent_sensors;
    }
    if (tick % 5 == 0) {
      hexa_msg_ImuSample m{};
      m.header.tick = tick;
      m.header.source_time_ns = static_cast<int64_t>(tick);
      m.orientation_wxyz[0] = 1.0;
      ASSERT_GE(imu.Write(m, comm::RealtimeNow_ns()), 0);
      ++sent_imu;
    }
    if (tick == 100) {
      hexa_msg_FaultEvent f{};
      std::strcpy(f.source_node, "test");
      f.tick = tick;
      f.reason = hexa_msg_FAULT_SENSOR_INVALID;
      f.source_time_ns = 77;
      ASSERT_GE(fault.Write(f, comm::RealtimeNow_ns()), 0);
    }
    // 1 ms per tick as in the system: the writers' keep-last histories (comm profile) then
    // cover ~100 ms of recorder stall on this loaded 2-core machine without overwriting.
    std::this_thread::sleep_for(1ms);
  }
  std::this_thread::sleep_for(500ms);  // let reliable delivery complete
  rec.Signal(SIGINT);
  ASSERT_EQ(rec.Wait(30s), 0);

  const RecordingInfo info = Inspect(out);
  ASSERT_TRUE(info.complete);
  std::map<std::string, const ChannelInfo*> by_topic;
  for (const auto& c : info.channels) by_topic[c.topic] = &c;
  // Every topic has a channel, even without data (10 topics with the tracker's), and so has
  // the 3-D scene (docs/foxglove.md).
  ASSERT_EQ(by_topic.size(), 10u + 2u);
  ASSERT_EQ(by_topic.count("hexa_Scene") + by_topic.count("hexa_FrameTransforms"), 2u);
  EXPECT_EQ(by_topic["hexa_LegSensors"]->count, sent_sensors);
  EXPECT_EQ(by_topic["hexa_LegSensors"]->missing, 3u);
  EXPECT_EQ(by_topic["hexa_ImuSample"]->count, sent_imu);
  EXPECT_EQ(by_topic["hexa_ImuSample"]->missing, 0u);
  EXPECT_EQ(by_topic["hexa_FaultEvent"]->count, 1u);
  EXPECT_EQ(by_topic["hexa_ValveCommand"]->count, 0u);
  EXPECT_EQ(by_topic["hexa_LegSensors"]->metadata.at("qos.recorder.reliability"), "reliable");
  EXPECT_EQ(by_topic["hexa_LegSensors"]->metadata.at("qos.recorder.history"), "keep_all");
  EXPECT_EQ(by_topic["hexa_ValveCommand"]->metadata.at("qos.writer.ownership"), "shared");  // the plant chooses primary or standby (docs/faults.md)
  EXPECT_EQ(by_topic["hexa_LegSensors"]->metadata.at(kMetaPeriodS), "0.001");
  // publish_time is the sample's source_time_ns; fields survive DDS -> protobuf.
  uint64_t checked = 0;
  ReadRecording(out, [&](const McapChannel& ch, const McapMessageView& m,
                         const google::protobuf::Message& msg) {
    if (ch.topic != "hexa_LegSensors") return;
    rec::LegSensors s;
    ASSERT_TRUE(s.ParseFromString(msg.SerializeAsString()));
    EXPECT_EQ(m.publish_time_ns, static_cast<uint64_t>(s.header().source_time_ns()));
    EXPECT_EQ(s.header().source_time_ns(),
              1'000'000'000'000 + static_cast<int64_t>(s.header().tick()) * 1'000'000 + s.leg_id());
    EXPECT_EQ(s.length_m(), 0.5 + 1e-4 * s.leg_id());
    EXPECT_EQ(s.cap_pressure_pa(), 4e5 + static_cast<double>(s.header().tick()));
    ++checked;
  });
  EXPECT_EQ(checked, sent_sensors);
}

TEST_F(RecorderDds, PlayRepublishesTheSelectedTopicsFieldForField) {
  constexpr int kDomain = 62;
  const std::string file = dir_ / "play.mcap";
  // A recording written directly (no DDS): 100 ticks x 6 legs of sensors and valve commands.
  std::vector<rec::LegSensors> sent;
  {
    RecordingWriter w;
    w.Open(file);
    const uint16_t cs = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(), {});
    const uint16_t cv = w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(), {});
    for (uint64_t tick = 1; tick <= 100; ++tick) {
      for (uint32_t leg = 1; leg <= 6; ++leg) {
        rec::LegSensors s;
        s.set_leg_id(leg);
        s.mutable_header()->set_tick(tick);
        s.mutable_header()->set_sim_time_s(1e-3 * static_cast<double>(tick));
        s.mutable_header()->set_source_time_ns(static_cast<int64_t>(tick * 1000 + leg));
        s.set_length_m(0.45 + 1e-3 * leg + 1e-6 * static_cast<double>(tick));
        s.set_cap_pressure_pa(1.0 * tick);
        s.set_rod_pressure_pa(2.0 * tick);
        s.set_supply_pressure_pa(7e5);
        w.Write(cs, tick * 1'000'000, tick * 1000 + leg, s);
        sent.push_back(s);
        rec::ValveCommand v;
        v.set_leg_id(leg);
        v.mutable_header()->set_tick(tick);
        w.Write(cv, tick * 1'000'000 + 1, tick * 1000, v);
      }
    }
    w.Close();
  }
  comm::Participant p(kDomain);
  comm::Topic<hexa_msg_LegSensors> sensors_topic(p);
  comm::Topic<hexa_msg_ValveCommand> valve_topic(p);
  comm::QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  // Timed playback writes with the real-time writer QoS (periodic topics best effort).
  params.recorder_periodic_best_effort = true;
  comm::Reader<hexa_msg_LegSensors> sensors(p, sensors_topic, comm::EndpointRole::kRecorderReader,
                                            params, 1024);
  comm::Reader<hexa_msg_ValveCommand> valves(p, valve_topic, comm::EndpointRole::kRecorderReader,
                                             params, 1024);
  Child play({"play", file, "--domain", std::to_string(kDomain), "--rate", "1",
              "--topics", "hexa_LegSensors", "--wait-readers-s", "2", "--deadline-s", "inf",
              "--no-progress"});
  ASSERT_EQ(play.Wait(60s), 0);
  std::this_thread::sleep_for(300ms);
  std::vector<hexa_msg_LegSensors> got;
  while (sensors.Take() > 0) {
    for (size_t i = 0; i < sensors.count(); ++i)
      if (sensors.info(i).valid_data) got.push_back(sensors.sample(i));
  }
  ASSERT_EQ(got.size(), sent.size());
  // A keep-all reader hands samples out grouped by instance (leg): order as they were sent.
  std::stable_sort(got.begin(), got.end(), [](const auto& a, const auto& b) {
    return a.header.tick != b.header.tick ? a.header.tick < b.header.tick : a.leg_id < b.leg_id;
  });
  for (size_t i = 0; i < got.size(); ++i) {
    hexa_msg_LegSensors expect{};
    ASSERT_TRUE(FromProto(sent[i], expect));
    EXPECT_EQ(std::memcmp(&got[i], &expect, sizeof expect), 0) << "sample " << i;
  }
  // --topics left ValveCommand out.
  EXPECT_EQ(valves.Take(), 0);
}

}  // namespace
}  // namespace hexa::recorder
