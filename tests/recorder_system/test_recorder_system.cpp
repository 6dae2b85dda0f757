// The recorder against a real lockstep session (record, inspect, replay):
//  Session          records one short session through the launcher (ctest fixture setup);
//  Counts           every topic's count is what the tick count says, nothing missing;
//  RoundTrip        DDS -> MCAP -> DDS -> MCAP keeps every field of every message;
//  ReplaySameBuild  the plant's topics played into six fresh leg controllers give the recorded
//                   commands exactly (and an offline run of the core controller agrees);
//  ReplayChangedGain a changed lambda_1 gives a difference, first at the tick where an offline
//                   run of the core controller with that gain first departs.
// Domains 80-83. Every process runs in a hexa::deploy::ProcessGroup (own process group,
// PR_SET_PDEATHSIG, StopAll in the destructor): nothing outlives the test, even on failure.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/recording/recording.hpp"
#include "process_group.hpp"
#include "recording.pb.h"

namespace {

namespace fs = std::filesystem;
namespace rec = hexa::rec;
using hexa::deploy::ChildSpec;
using hexa::deploy::ProcessGroup;
using namespace std::chrono_literals;

constexpr int kLegs = 6;
const std::string kDir = HEXA_RECSYS_DIR;
const std::string kSession = kDir + "/session.mcap";
// The plant's topics: what a controller under test is fed.
const std::string kPlantTopics = "hexa_LegSensors,hexa_ImuSample,hexa_LegSetpoint";
const std::string kPeriodicTopics =
    "hexa_LegSensors,hexa_ValveCommand,hexa_ImuSample,hexa_LegSetpoint,hexa_PoseReport,"
    "hexa_GroundTruth";

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::map<std::string, std::string> DdsEnv() {
  return {{"CYCLONEDDS_URI", std::string("file://") + HEXA_DDS_CONFIG}};
}

// Waits for the child `name` to exit; returns its exit code (128 + signal), -1 on timeout.
int WaitExit(ProcessGroup& group, const std::string& name, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    auto ev = group.WaitEvent(std::max(left, 1ms));
    if (ev.kind == ProcessGroup::Event::kChildExited) {
      if (ev.exit.name == name)
        return ev.exit.signal == 0 ? ev.exit.exit_code : 128 + ev.exit.signal;
      ADD_FAILURE() << ev.exit.Describe() << " while waiting for " << name;
      return -2;
    }
    if (ev.kind == ProcessGroup::Event::kInterrupted) return -3;
  }
  return -1;
}

// Starts `record` and waits until it has created its readers (its first stderr line).
void StartRecorder(ProcessGroup& group, const std::string& name, const std::string& out,
                   int domain, const std::string& topics, const std::string& log) {
  std::string err;
  ChildSpec s{name,
              {HEXA_RECORDER_EXE, "record", "--output", out, "--domain", std::to_string(domain),
               "--topics", topics, "--sync", "none"},
              DdsEnv(),
              log};
  ASSERT_GT(group.Start(s, err), 0) << err;
  const auto end = std::chrono::steady_clock::now() + 30s;
  while (Slurp(log).find("record: domain") == std::string::npos) {
    ASSERT_LT(std::chrono::steady_clock::now(), end) << "recorder did not start:\n" << Slurp(log);
    ASSERT_TRUE(group.Running(name)) << Slurp(log);
    std::this_thread::sleep_for(20ms);
  }
}

// Runs `hexa_recorder play` to completion; returns its exit code.
int Play(ProcessGroup& group, const std::vector<std::string>& args, const std::string& log) {
  std::string err;
  ChildSpec s{"play", {HEXA_RECORDER_EXE, "play"}, DdsEnv(), log};
  s.argv.insert(s.argv.end(), args.begin(), args.end());
  if (group.Start(s, err) < 0) {
    ADD_FAILURE() << err;
    return -1;
  }
  return WaitExit(group, "play", 150s);
}

// ----------------------------------------------------------------- recorded data, by tick

struct Recorded {
  // [leg 1..6][tick]
  std::map<uint32_t, std::map<uint64_t, rec::LegSensors>> sensors;
  std::map<uint32_t, std::map<uint64_t, rec::LegSetpoint>> setpoints;
  std::map<uint32_t, std::map<uint64_t, rec::ValveCommand>> commands;
  std::map<uint64_t, rec::GroundTruth> truth;
  // (topic, key, tick) -> (serialized message, publish_time): for the round trip.
  std::map<std::tuple<std::string, uint32_t, uint64_t>, std::pair<std::string, uint64_t>> all;
  std::map<std::string, uint64_t> duplicates;  // per topic: (key, tick) seen twice
};

template <typename M>
uint32_t LegOf(const M& m) {
  if constexpr (requires { m.leg_id(); }) {
    return m.leg_id();
  } else {
    return 0;
  }
}

template <typename M>
void Keep(Recorded& r, const std::string& topic, const hexa::recorder::McapMessageView& v, M& m) {
  ASSERT_TRUE(m.ParseFromArray(v.data.data(), static_cast<int>(v.data.size()))) << topic;
  const auto key = std::make_tuple(topic, LegOf(m), static_cast<uint64_t>(m.header().tick()));
  // Compared as parsed messages, serialized again: deterministic for equal field values.
  auto [it, inserted] = r.all.emplace(key, std::make_pair(m.SerializeAsString(), v.publish_time_ns));
  if (!inserted) ++r.duplicates[topic];
}

Recorded Load(const std::string& path) {
  Recorded r;
  hexa::recorder::ReadRecording(path, [&](const hexa::recorder::McapChannel& ch,
                                          const hexa::recorder::McapMessageView& v,
                                          const google::protobuf::Message&) {
    const std::string& t = ch.topic;
    if (t == "hexa_LegSensors") {
      rec::LegSensors m;
      Keep(r, t, v, m);
      r.sensors[m.leg_id()][m.header().tick()] = m;
    } else if (t == "hexa_LegSetpoint") {
      rec::LegSetpoint m;
      Keep(r, t, v, m);
      r.setpoints[m.leg_id()][m.header().tick()] = m;
    } else if (t == "hexa_ValveCommand") {
      rec::ValveCommand m;
      Keep(r, t, v, m);
      r.commands[m.leg_id()][m.header().tick()] = m;
    } else if (t == "hexa_GroundTruth") {
      rec::GroundTruth m;
      Keep(r, t, v, m);
      r.truth[m.header().tick()] = m;
    } else if (t == "hexa_ImuSample") {
      rec::ImuSample m;
      Keep(r, t, v, m);
    } else if (t == "hexa_PoseReport") {
      rec::PoseReport m;
      Keep(r, t, v, m);
    }
  });
  return r;
}

const Recorded& Session() {
  static const Recorded r = Load(kSession);
  return r;
}

// The plant's last tick from its own log ("stopped at tick N"): an independent tick count.
uint64_t PlantLastTick() {
  const std::string log = Slurp(kDir + "/plant.log");
  std::smatch m;
  if (!std::regex_search(log, m, std::regex("stopped at tick ([0-9]+)"))) return 0;
  return std::stoull(m[1]);
}

// Sensor samples the plant re-published for a silent leg in lockstep ("lockstep resends N"):
// each is a second copy of a tick's sample, answered again from the leg's cache.
uint64_t PlantResends() {
  const std::string log = Slurp(kDir + "/plant.log");
  std::smatch m;
  if (!std::regex_search(log, m, std::regex("lockstep resends ([0-9]+)"))) return 0;
  return std::stoull(m[1]);
}

// Re-asks that also re-published the supervisor's inputs of a setpoint tick (six LegSensors
// and the IMU in the all-legs partition, which the recorder reads) and made the supervisor
// re-publish that tick's six setpoints ("(in N re-asks, R to the supervisor)").
uint64_t PlantSupervisorReasks() {
  const std::string log = Slurp(kDir + "/plant.log");
  std::smatch m;
  if (!std::regex_search(log, m, std::regex("re-asks, ([0-9]+) to the supervisor"))) return 0;
  return std::stoull(m[1]);
}

// Offline oracle: the core LegController run on the recorded sensors and setpoints with the
// lockstep setpoint rule of leg_ctrl (docs/architecture.md), no DDS. Returns its output per tick.
std::map<uint64_t, hexa::LegControllerOutput> OfflineController(
    const hexa::config::SystemConfig& cfg, uint32_t leg, const Recorded& r) {
  hexa::LegController c(hexa::LegControllerConfig::FromRig(cfg.rig, cfg.leg_controller,
                                                           hexa::LegControllerKind::kBsSmc));
  std::map<uint64_t, hexa::LegControllerOutput> out;
  const auto& setpoints = r.setpoints.count(leg) ? r.setpoints.at(leg) : decltype(r.setpoints.at(leg)){};
  for (const auto& [tick, s] : r.sensors.at(leg)) {
    hexa::LegControllerInput in;
    in.tick = tick;
    in.time_s = s.header().sim_time_s();
    in.length_m = s.length_m();
    in.cap_pressure_pa = s.cap_pressure_pa();
    in.rod_pressure_pa = s.rod_pressure_pa();
    in.supply_pressure_pa = s.supply_pressure_pa();
    uint64_t required = 0;
    if (hexa::RequiredSetpointTick(tick, 5, required)) {
      auto it = setpoints.find(required);
      if (it != setpoints.end()) {
        const auto& p = it->second;
        in.has_setpoint = true;
        in.setpoint_tick = p.header().tick();
        in.setpoint_time_s = p.header().sim_time_s();
        in.setpoint_length_m = p.length_m();
        in.setpoint_velocity_m_s = p.velocity_m_s();
        in.setpoint_acceleration_m_s2 = p.acceleration_m_s2();
        in.correction_m = p.correction_m();
        in.hold = p.hold();
        in.feedforward_valid = p.feedforward_valid();
        in.feedforward_force_n = p.feedforward_force_n();
        in.feedforward_force_rate_n_s = p.feedforward_force_rate_n_s();
      }
    }
    c.Update(in, out[tick]);
  }
  return out;
}

std::string ChangedGainRig(double lambda_1_s, double& original) {
  std::string text = Slurp(HEXA_RIG_FILE);
  std::smatch m;
  const std::regex re("lambda_1_s:\\s*([0-9.eE+-]+)");
  if (!std::regex_search(text, m, re)) return "";
  original = std::stod(m[1]);
  std::ostringstream v;
  v << "lambda_1_s: " << lambda_1_s;
  text = std::regex_replace(text, re, v.str(), std::regex_constants::format_first_only);
  const std::string path = kDir + "/rig_lambda1_changed.textproto";
  std::ofstream(path) << text;
  return path;
}

// Six fresh leg controllers on `domain`, fed by play --lockstep with the plant's topics;
// their ValveCommands land in `answers`. Returns play's exit code.
int ReplayIntoControllers(int domain, const std::string& rig, const std::string& answers,
                          const std::string& tag) {
  ProcessGroup group;
  for (int leg = 1; leg <= kLegs; ++leg) {
    std::string err;
    const std::string name = tag + "_leg" + std::to_string(leg);
    ChildSpec s{name,
                {HEXA_LEG_CTRL_EXE, "--leg", std::to_string(leg), "--mode", "lockstep", "--rig",
                 rig, "--domain", std::to_string(domain), "--log-file",
                 kDir + "/" + name + ".log"},
                DdsEnv(),
                kDir + "/" + name + ".console.log"};
    if (group.Start(s, err) < 0) {
      ADD_FAILURE() << err;
      return -1;
    }
  }
  const int rc = Play(group,
                      {kSession, "--domain", std::to_string(domain), "--lockstep", "--topics",
                       kPlantTopics, "--answers-out", answers, "--no-progress"},
                      kDir + "/" + tag + "_play.log");
  for (const auto& e : group.StopAll(5000ms))
    EXPECT_TRUE(e.signal == 0 && e.exit_code == 0) << e.Describe();
  return rc;
}

// ------------------------------------------------------------------------------ tests

TEST(RecorderSystem, Session) {
  fs::remove_all(kDir);
  fs::create_directories(kDir);
  ProcessGroup group;
  std::string err;
  ChildSpec s{"session",
              {HEXA_SESSION_EXE, "--trajectory", "combined", "--periods", "1", "--seed", "5",
               "--domain", "80", "--out", kDir, "--timeout", "150"},
              {},
              kDir + "/launcher.console.log"};
  ASSERT_GT(group.Start(s, err), 0) << err;
  const int rc = WaitExit(group, "session", 170s);
  ASSERT_EQ(rc, 0) << Slurp(kDir + "/session.log");
  ASSERT_TRUE(fs::exists(kSession));
  ASSERT_GT(PlantLastTick(), 1000u) << Slurp(kDir + "/plant.log");
}

TEST(RecorderSystem, Counts) {
  // The tick count from the plant's own log, and (independently) from the ground truth.
  const uint64_t last = PlantLastTick();
  ASSERT_GT(last, 1000u);
  const auto& s = Session();
  ASSERT_FALSE(s.truth.empty());
  EXPECT_EQ(s.truth.begin()->first, 0u);
  EXPECT_EQ(s.truth.rbegin()->first, last) << "plant log and ground truth disagree";
  const uint64_t ticks = last + 1;  // ticks 0..last were published
  // The supervisor answers ticks 0, 5, ..., L and leaves. Leg controllers answer tick n with
  // the setpoint of 5 floor((n - 1) / 5) (core/lockstep_protocol.hpp), so the plant can run
  // up to L + 5 without it and stops at L + 6 at the latest (no setpoint L + 5 comes); the
  // launcher may stop it a few ticks earlier. The plant never waits for the supervisor.
  ASSERT_FALSE(s.setpoints.at(1).empty());
  const uint64_t last_setpoint = s.setpoints.at(1).rbegin()->first;
  ASSERT_EQ(last_setpoint % 5, 0u);
  EXPECT_GE(last, last_setpoint + 1);
  EXPECT_LE(last, last_setpoint + 6) << "the plant ran past the last answerable tick";
  const uint64_t supervisor_ticks = last_setpoint / 5 + 1;
  // Each leg answered every tick before `last`, and `last` too when it was answerable and the
  // plant was stopped after that leg answered it.
  uint64_t answered_total = 0;
  for (uint32_t leg = 1; leg <= kLegs; ++leg) {
    const uint64_t n = s.commands.at(leg).size();
    EXPECT_TRUE(n == last || (n == ticks && last <= last_setpoint + 5))
        << n << " commands of leg " << leg << ", last tick " << last;
    answered_total += n;
  }

  const auto info = hexa::recorder::Inspect(kSession);
  EXPECT_TRUE(info.complete);
  std::map<std::string, uint64_t> count, missing;
  for (const auto& c : info.channels) {
    count[c.topic] = c.count;
    missing[c.topic] = c.missing;
  }
  // Under load the plant may re-ask a leg for a tick (docs/architecture.md); that second copy
  // of the sensor sample goes to the leg's controllers only (its partition), so the recording
  // has each tick once. A leg answers a re-ask a second time only if it had already answered
  // that tick (its first answer was merely late), so ValveCommand duplicates are at most the
  // re-asks. A re-ask of the first tick after a setpoint tick also re-publishes the
  // supervisor's inputs of that tick (recorded: duplicates), and the supervisor its setpoints.
  const uint64_t resends = PlantResends();
  const uint64_t supervisor_reasks = PlantSupervisorReasks();
  const uint64_t ticks_imu = ticks / 5 + (ticks % 5 != 0 ? 1 : 0);
  EXPECT_GE(count["hexa_LegSensors"], kLegs * ticks);
  EXPECT_LE(count["hexa_LegSensors"], kLegs * (ticks + supervisor_reasks));
  EXPECT_GE(count["hexa_ValveCommand"], answered_total);
  EXPECT_LE(count["hexa_ValveCommand"], answered_total + resends);
  EXPECT_EQ(count["hexa_GroundTruth"], ticks);
  EXPECT_GE(count["hexa_ImuSample"], ticks_imu);
  EXPECT_LE(count["hexa_ImuSample"], ticks_imu + supervisor_reasks);
  EXPECT_GE(count["hexa_LegSetpoint"], kLegs * supervisor_ticks);
  EXPECT_LE(count["hexa_LegSetpoint"], kLegs * (supervisor_ticks + supervisor_reasks));
  EXPECT_EQ(count["hexa_PoseReport"], supervisor_ticks);
  for (const auto& [topic, m] : missing) EXPECT_EQ(m, 0u) << topic;
  for (const auto& [topic, d] : s.duplicates) {
    if (topic == "hexa_ValveCommand") EXPECT_LE(d, resends) << topic;
    else if (topic == "hexa_LegSensors" || topic == "hexa_LegSetpoint")
      EXPECT_LE(d, kLegs * supervisor_reasks) << topic;
    else if (topic == "hexa_ImuSample") EXPECT_LE(d, supervisor_reasks) << topic;
    else EXPECT_EQ(d, 0u) << topic;
  }
  // Per instance: every tick present, first 0.
  for (uint32_t leg = 1; leg <= kLegs; ++leg) {
    ASSERT_EQ(s.sensors.at(leg).size(), ticks) << leg;
    EXPECT_EQ(s.commands.at(leg).rbegin()->first + 1, s.commands.at(leg).size()) << leg;
    ASSERT_EQ(s.setpoints.at(leg).size(), supervisor_ticks) << leg;
    EXPECT_EQ(s.setpoints.at(leg).rbegin()->first, last_setpoint) << leg;
  }

  // The CLI says the same (the numbers it prints are Inspect's).
  ProcessGroup group;
  std::string err;
  const std::string log = kDir + "/info.txt";
  ChildSpec c{"info", {HEXA_RECORDER_EXE, "info", kSession}, {}, log};
  ASSERT_GT(group.Start(c, err), 0) << err;
  ASSERT_EQ(WaitExit(group, "info", 60s), 0) << Slurp(log);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find(std::to_string(count["hexa_LegSensors"])), std::string::npos) << text;
  EXPECT_NE(text.find(std::to_string(count["hexa_ValveCommand"])), std::string::npos) << text;
}

TEST(RecorderSystem, RoundTrip) {
  // DDS -> MCAP (the session) -> DDS (play) -> MCAP (record): every message of the periodic
  // topics comes back with the same field values and the same publish time (the sample's
  // header.source_time_ns, which play keeps). Only the MCAP log time (receipt time) and the
  // per-channel sequence (file order) legitimately change.
  const std::string out = kDir + "/roundtrip.mcap";
  {
    ProcessGroup group;
    StartRecorder(group, "rt_record", out, 81, kPeriodicTopics, kDir + "/rt_record.log");
    ASSERT_EQ(Play(group,
                   {kSession, "--domain", "81", "--lockstep", "--topics", kPeriodicTopics,
                    "--no-progress"},
                   kDir + "/rt_play.log"),
              0)
        << Slurp(kDir + "/rt_play.log");
    auto e = group.Stop("rt_record", 10000ms);
    ASSERT_TRUE(e.has_value());
    ASSERT_EQ(e->exit_code, 0) << e->Describe() << Slurp(kDir + "/rt_record.log");
  }
  const auto& a = Session();
  const Recorded b = Load(out);
  ASSERT_EQ(a.all.size(), b.all.size());
  std::map<std::string, uint64_t> compared;
  for (const auto& [key, va] : a.all) {
    auto it = b.all.find(key);
    ASSERT_NE(it, b.all.end()) << std::get<0>(key) << " key " << std::get<1>(key) << " tick "
                               << std::get<2>(key) << " did not come back";
    ASSERT_EQ(va.first, it->second.first)
        << std::get<0>(key) << " key " << std::get<1>(key) << " tick " << std::get<2>(key)
        << " changed on the way";
    ASSERT_EQ(va.second, it->second.second) << "publish time of " << std::get<0>(key);
    ++compared[std::get<0>(key)];
  }
  for (const char* t : {"hexa_LegSensors", "hexa_ValveCommand", "hexa_GroundTruth",
                        "hexa_ImuSample", "hexa_LegSetpoint", "hexa_PoseReport"})
    EXPECT_GT(compared[t], 0u) << t;
  // Every field carried a value (a round trip of default values proves nothing).
  const auto& g = a.truth.rbegin()->second;
  EXPECT_NE(g.header().source_time_ns(), 0);
  EXPECT_GT(a.sensors.at(3).rbegin()->second.cap_pressure_pa(), 0.0);
}

TEST(RecorderSystem, ReplaySameBuild) {
  const std::string answers = kDir + "/replay_same.mcap";
  ASSERT_EQ(ReplayIntoControllers(82, HEXA_RIG_FILE, answers, "same"), 0)
      << Slurp(kDir + "/same_play.log");
  const auto d = hexa::recorder::DiffValveCommands(kSession, answers, 0.0);
  std::cout << hexa::recorder::FormatDiff(d);
  ASSERT_EQ(d.legs.size(), static_cast<size_t>(kLegs));
  const auto& s = Session();
  for (const auto& l : d.legs) {
    EXPECT_EQ(l.common_ticks, s.commands.at(l.leg_id).size()) << "leg " << l.leg_id;
    EXPECT_EQ(l.only_a, 0u);
    EXPECT_EQ(l.only_b, 0u);
    EXPECT_EQ(l.max_abs_diff_v, 0.0);
    EXPECT_FALSE(l.differs);
  }
  EXPECT_TRUE(d.identical);
  // Beyond valve_v: every field but the compute time and the source time (wall clock).
  const Recorded b = Load(answers);
  for (uint32_t leg = 1; leg <= kLegs; ++leg) {
    for (const auto& [tick, c] : s.commands.at(leg)) {
      const auto& n = b.commands.at(leg).at(tick);
      ASSERT_EQ(c.valve_v(), n.valve_v()) << leg << " " << tick;
      ASSERT_EQ(c.status(), n.status()) << leg << " " << tick;
      ASSERT_EQ(c.setpoint_tick(), n.setpoint_tick()) << leg << " " << tick;
      ASSERT_EQ(c.desired_length_m(), n.desired_length_m()) << leg << " " << tick;
      ASSERT_EQ(c.sliding_surface_m_s(), n.sliding_surface_m_s()) << leg << " " << tick;
      ASSERT_TRUE(c.has_friction_scale() && n.has_friction_scale()) << leg << " " << tick;
      ASSERT_EQ(c.friction_scale(), n.friction_scale()) << leg << " " << tick;
      ASSERT_EQ(c.controller(), n.controller());
      ASSERT_EQ(c.header().sim_time_s(), n.header().sim_time_s());
    }
  }
  // The offline oracle (core controller on the recorded inputs, no DDS) agrees bit for bit:
  // the replay fed each controller exactly what the session did.
  const auto cfg = hexa::config::LoadSystemConfigOrThrow(HEXA_RIG_FILE);
  for (uint32_t leg = 1; leg <= kLegs; ++leg) {
    const auto off = OfflineController(cfg, leg, s);
    bool adapted = false;  // theta left 1 at some tick: the comparison below can fail
    for (const auto& [tick, c] : s.commands.at(leg)) {
      ASSERT_EQ(off.at(tick).valve_v, c.valve_v()) << "leg " << leg << " tick " << tick;
      ASSERT_EQ(off.at(tick).friction_scale, c.friction_scale()) << "leg " << leg << " tick " << tick;
      adapted = adapted || c.friction_scale() != 1.0;
    }
    EXPECT_TRUE(adapted) << "leg " << leg << ": theta stayed 1 all session";
  }
}

TEST(RecorderSystem, ReplayChangedGain) {
  double original = 0;
  const double changed = 60.0;
  const std::string rig = ChangedGainRig(changed, original);
  ASSERT_FALSE(rig.empty()) << "no lambda_1_s in " << HEXA_RIG_FILE;
  ASSERT_NE(original, changed);
  const std::string answers = kDir + "/replay_gain.mcap";
  ASSERT_EQ(ReplayIntoControllers(83, rig, answers, "gain"), 0) << Slurp(kDir + "/gain_play.log");
  const auto d = hexa::recorder::DiffValveCommands(kSession, answers, 0.0);
  std::cout << hexa::recorder::FormatDiff(d);
  ASSERT_EQ(d.legs.size(), static_cast<size_t>(kLegs));
  EXPECT_FALSE(d.identical);

  // Where the difference must start: the first tick at which the core controller with the
  // changed gain, fed the recorded inputs offline, departs from the recorded command.
  const auto cfg = hexa::config::LoadSystemConfigOrThrow(rig);
  ASSERT_EQ(cfg.leg_controller.bssmc.lambda_1_s, changed);
  const auto& s = Session();
  const Recorded b = Load(answers);
  for (const auto& l : d.legs) {
    EXPECT_EQ(l.only_a + l.only_b, 0u) << "leg " << l.leg_id;
    const auto off = OfflineController(cfg, l.leg_id, s);
    uint64_t expected_first = UINT64_MAX;
    double max_diff = 0, sum2 = 0;
    for (const auto& [tick, c] : s.commands.at(l.leg_id)) {
      const double diff = std::abs(off.at(tick).valve_v - c.valve_v());
      if (diff > 0 && expected_first == UINT64_MAX) expected_first = tick;
      max_diff = std::max(max_diff, diff);
      sum2 += diff * diff;
    }
    ASSERT_NE(expected_first, UINT64_MAX) << "gain change has no effect on leg " << l.leg_id;
    // Open loop (recorded inputs), so the new controllers must equal the offline run exactly.
    for (const auto& [tick, c] : b.commands.at(l.leg_id))
      ASSERT_EQ(c.valve_v(), off.at(tick).valve_v) << "leg " << l.leg_id << " tick " << tick;
    EXPECT_TRUE(l.differs) << "leg " << l.leg_id;
    EXPECT_EQ(l.first_diff_tick, expected_first) << "leg " << l.leg_id;
    // The gain acts only once the control law runs (a setpoint exists): never at tick 0.
    EXPECT_GT(l.first_diff_tick, 0u);
    EXPECT_EQ(l.max_abs_diff_v, max_diff) << "leg " << l.leg_id;
    EXPECT_NEAR(l.rms_diff_v, std::sqrt(sum2 / static_cast<double>(l.common_ticks)), 1e-12);
    EXPECT_GT(l.max_abs_diff_v, 1e-3) << "leg " << l.leg_id;
  }
}

}  // namespace
