// The 3-D scene (docs/foxglove.md): display rate, leg geometry against the plant's own truth,
// leg colours by state, transforms; and the bridge's protocol functions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/core/scene.hpp"
#include "hexa/recording/scene.hpp"
#include "protocol.hpp"
#include "ws_server.hpp"
#include "recording.pb.h"
#include "scratch_dir.hpp"

namespace hexa {
namespace {
using recorder::SceneBuilder;
using recorder::SceneOptions;

SceneOptions Options(uint64_t seed) {
  SceneOptions o;
  o.nominal_geometry = MakeReferenceRig().geometry;
  o.truth_geometry = TrueGeometry(o.nominal_geometry, MakeRealisticDisturbanceProfile(), seed);
  return o;
}

rec::GroundTruth Truth(uint64_t tick, const Pose& pose, const GeometryParams& g) {
  rec::GroundTruth t;
  t.mutable_header()->set_tick(tick);
  for (int i = 0; i < 3; ++i) t.add_position_m(pose.p_BP_B_m[i]);
  const Eigen::Quaterniond q(pose.R_BP);
  t.add_orientation_wxyz(q.w());
  t.add_orientation_wxyz(q.x());
  t.add_orientation_wxyz(q.y());
  t.add_orientation_wxyz(q.z());
  for (const LegSegment& s : LegSegments(g, pose)) t.add_leg_length_m(s.length_m);
  return t;
}

Pose SomePose(double k) {
  Vector6d v;
  v << 0.02 * std::sin(k), -0.03 * std::cos(k), 0.45 + 0.05 * std::sin(2 * k), 0.1 * std::sin(k),
      -0.08, 0.2 * std::cos(k);
  return PoseFromVector(v);
}

const foxglove::SceneEntity* Entity(const foxglove::SceneUpdate& u, const std::string& id) {
  for (const auto& e : u.entities())
    if (e.id() == id) return &e;
  return nullptr;
}
std::string Meta(const foxglove::SceneEntity& e, const std::string& key) {
  for (const auto& kv : e.metadata())
    if (kv.key() == key) return kv.value();
  return "";
}

TEST(Scene, TrueGeometryIsThePlantsOwn) {
  PlatformPlantConfig c;
  c.seed = 17;
  const PlatformPlant plant(c);
  const GeometryParams g = TrueGeometry(c.rig.geometry, c.disturbance, 17);
  for (size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_EQ(g.p_BA_B[i], plant.true_geometry().p_BA_B[i]);
    EXPECT_EQ(g.p_PB_P[i], plant.true_geometry().p_PB_P[i]);
    EXPECT_GT((g.p_BA_B[i] - c.rig.geometry.p_BA_B[i]).norm(), 0.0) << "realistic: joints off";
    EXPECT_LE((g.p_BA_B[i] - c.rig.geometry.p_BA_B[i]).norm(), 2e-3 + 1e-12);
  }
}

TEST(Scene, OneFramePerTwentyTicksDrivenByGroundTruth) {
  const SceneOptions o = Options(3);
  SceneBuilder b(o);
  std::vector<uint64_t> due;
  rec::PoseReport r;
  for (int i = 0; i < 6; ++i) r.add_estimated_pose(i == 2 ? 0.45 : 0.0);
  for (int i = 0; i < 6; ++i) r.add_desired_pose(i == 2 ? 0.45 : 0.0);
  for (uint64_t tick = 0; tick <= 100; ++tick) {
    if (b.Add(Truth(tick, SomePose(tick * 1e-3), o.truth_geometry))) due.push_back(tick);
    r.mutable_header()->set_tick(tick);
    if (tick % 5 == 0) {
      EXPECT_FALSE(b.Add(r)) << "the pose report does not drive when there is truth";
    }
  }
  EXPECT_EQ(due, (std::vector<uint64_t>{0, 20, 40, 60, 80, 100}));
  // Without ground truth (hardware), the pose reports drive, at the same rate.
  SceneBuilder hw(o);
  due.clear();
  for (uint64_t tick = 0; tick <= 100; tick += 5) {
    r.mutable_header()->set_tick(tick);
    if (hw.Add(r)) due.push_back(tick);
  }
  EXPECT_EQ(due, (std::vector<uint64_t>{0, 20, 40, 60, 80, 100}));
  // A skipped tick does not stop the display: the next tick after the due one triggers.
  SceneBuilder gap(o);
  EXPECT_TRUE(gap.Add(Truth(3, SomePose(0), o.truth_geometry)));
  EXPECT_FALSE(gap.Add(Truth(19, SomePose(0), o.truth_geometry)));
  EXPECT_TRUE(gap.Add(Truth(23, SomePose(0), o.truth_geometry)));
  EXPECT_FALSE(gap.Add(Truth(39, SomePose(0), o.truth_geometry)));
  EXPECT_TRUE(gap.Add(Truth(40, SomePose(0), o.truth_geometry)));
}

TEST(Scene, LegsMeetTheJointsAndHaveTheTrueLengths) {
  const SceneOptions o = Options(9);
  SceneBuilder b(o);
  for (int k = 0; k < 20; ++k) {
    const Pose pose = SomePose(0.37 * k);
    const rec::GroundTruth t = Truth(20 * k, pose, o.truth_geometry);
    ASSERT_TRUE(b.Add(t));
    b.Build(1'000'000'000ull * k);
    const foxglove::SceneUpdate& u = b.scene();
    const auto* platform = Entity(u, "platform");
    const auto* base = Entity(u, "base");
    ASSERT_TRUE(platform && base);
    ASSERT_EQ(b.transforms().transforms_size(), 1);  // no pose report yet: truth only
    const auto& tf = b.transforms().transforms(0);
    EXPECT_EQ(tf.child_frame_id(), "platform");
    const Eigen::Quaterniond q(tf.rotation().w(), tf.rotation().x(), tf.rotation().y(),
                               tf.rotation().z());
    const Eigen::Vector3d p(tf.translation().x(), tf.translation().y(), tf.translation().z());
    EXPECT_LT((q.toRotationMatrix() - pose.R_BP).norm(), 1e-12);
    EXPECT_LT((p - pose.p_BP_B_m).norm(), 1e-12);
    for (size_t i = 0; i < kNumLegs; ++i) {
      const auto* leg = Entity(u, "leg" + std::to_string(i + 1));
      ASSERT_TRUE(leg);
      ASSERT_EQ(leg->cylinders_size(), 1);
      const auto& c = leg->cylinders(0);
      const Eigen::Quaterniond cq(c.pose().orientation().w(), c.pose().orientation().x(),
                                  c.pose().orientation().y(), c.pose().orientation().z());
      const Eigen::Vector3d center(c.pose().position().x(), c.pose().position().y(),
                                   c.pose().position().z());
      const Eigen::Vector3d half = cq * Eigen::Vector3d(0, 0, 0.5 * c.size().z());
      const auto& bs = base->spheres(static_cast<int>(i)).pose().position();
      const auto& ps = platform->spheres(static_cast<int>(i)).pose().position();
      const Eigen::Vector3d base_joint(bs.x(), bs.y(), bs.z());
      const Eigen::Vector3d platform_joint = p + q * Eigen::Vector3d(ps.x(), ps.y(), ps.z());
      EXPECT_LT((center - half - base_joint).norm(), 1e-9) << "leg " << i + 1;
      EXPECT_LT((center + half - platform_joint).norm(), 1e-9) << "leg " << i + 1;
      EXPECT_NEAR(c.size().z(), t.leg_length_m(static_cast<int>(i)), 1e-12) << "eq 46";
      EXPECT_EQ(Meta(*leg, "tick"), std::to_string(20 * k));
    }
  }
}

// The soft limits' pose box of `rig_path` as the scene draws it: the cube's centre and size, and
// the 12 edges (24 points) of a LINE_LIST on its corners.
struct DrawnBox {
  Eigen::Vector3d center_m, size_m;
  std::optional<foxglove::SceneEntity> entity;  // "soft_limits"
};
DrawnBox DrawSoftLimits(const std::string& rig_path) {
  SceneBuilder b(recorder::SceneOptionsFromRig(rig_path, "", std::nullopt));
  EXPECT_TRUE(b.Add(Truth(0, SomePose(0), MakeReferenceRig().geometry)));
  b.Build(0);
  DrawnBox d;
  if (const auto* e = Entity(b.scene(), "soft_limits")) d.entity = *e;
  if (!d.entity || d.entity->cubes_size() != 1) return d;
  const auto& c = d.entity->cubes(0);
  d.center_m = Eigen::Vector3d(c.pose().position().x(), c.pose().position().y(), c.pose().position().z());
  d.size_m = Eigen::Vector3d(c.size().x(), c.size().y(), c.size().z());
  EXPECT_EQ(d.entity->frame_id(), "base");
  EXPECT_LT(c.color().a(), 0.5) << "translucent";
  EXPECT_EQ(d.entity->lines_size(), 1);
  if (d.entity->lines_size() != 1) return d;
  const auto& l = d.entity->lines(0);
  EXPECT_EQ(l.type(), foxglove::LinePrimitive::LINE_LIST);
  EXPECT_EQ(l.points_size(), 24);
  Eigen::Vector3d edge_total = Eigen::Vector3d::Zero();
  for (int k = 0; k + 1 < l.points_size(); k += 2) {
    const Eigen::Vector3d a(l.points(k).x(), l.points(k).y(), l.points(k).z());
    const Eigen::Vector3d e = Eigen::Vector3d(l.points(k + 1).x(), l.points(k + 1).y(), l.points(k + 1).z()) - a;
    // A corner of the box, and an edge along one axis: its full side.
    EXPECT_LT(((a - d.center_m).cwiseAbs() - 0.5 * d.size_m).norm(), 1e-12);
    EXPECT_EQ((e.array() != 0.0).count(), 1);
    edge_total += e.cwiseAbs();
  }
  EXPECT_LT((edge_total - 4.0 * d.size_m).norm(), 1e-12) << "four edges along each axis";
  return d;
}

TEST(Scene, SoftLimitBoxIsDrawnWithTheRigFilesDimensions) {
  // The default rig file: home (0, 0, 0.45) m, the box home -+ 0.1 m, the angles -+ 0.3 rad.
  const DrawnBox home_box = DrawSoftLimits(config::DefaultRigFile());
  ASSERT_TRUE(home_box.entity) << "entity soft_limits";
  EXPECT_LT((home_box.center_m - Eigen::Vector3d(0, 0, 0.45)).norm(), 1e-12);
  EXPECT_LT((home_box.size_m - Eigen::Vector3d(0.2, 0.2, 0.2)).norm(), 1e-12);
  EXPECT_EQ(Meta(*home_box.entity, "rotation_max_rad"), "0.300000 0.300000 0.300000");
  // A file with another box: the drawing follows it.
  std::ifstream in(config::DefaultRigFile());
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string before = text;
  text = std::regex_replace(text, std::regex("position_min_from_home_m \\{[^}]*\\}"),
                            "position_min_from_home_m { x: -0.02 y: -0.05 z: -0.04 }");
  text = std::regex_replace(text, std::regex("position_max_from_home_m \\{[^}]*\\}"),
                            "position_max_from_home_m { x: 0.03 y: 0.08 z: 0.06 }");
  text = std::regex_replace(text, std::regex("rotation_max_rad \\{[^}]*\\}"),
                            "rotation_max_rad { roll: 0.2 pitch: 0.25 yaw: 0.3 }");
  ASSERT_NE(text, before);
  const std::string path = hexa::testing::ScratchDir("scene_soft_limits") + "/tight.textproto";
  std::ofstream(path) << text;
  const DrawnBox tight = DrawSoftLimits(path);
  ASSERT_TRUE(tight.entity) << "entity soft_limits";
  EXPECT_LT((tight.size_m - Eigen::Vector3d(0.05, 0.13, 0.10)).norm(), 1e-12);
  EXPECT_LT((tight.center_m - Eigen::Vector3d(0.005, 0.015, 0.46)).norm(), 1e-12);
  EXPECT_EQ(Meta(*tight.entity, "position_min_m"), "-0.020000 -0.050000 0.410000");
  EXPECT_EQ(Meta(*tight.entity, "rotation_max_rad"), "0.200000 0.250000 0.300000");
  // Options built in code without limits draw none.
  SceneBuilder none(Options(1));
  ASSERT_TRUE(none.Add(Truth(0, SomePose(0), MakeReferenceRig().geometry)));
  none.Build(0);
  EXPECT_EQ(Entity(none.scene(), "soft_limits"), nullptr);
}

TEST(Scene, LegColoursFollowTheLegState) {
  const SceneOptions o = Options(1);
  SceneBuilder b(o);
  auto valve = [&](uint32_t leg, rec::LegCtrlStatus s, bool standby) {
    rec::ValveCommand v;
    v.set_leg_id(leg);
    v.set_status(s);
    v.set_standby(standby);
    b.Add(v);
  };
  auto pose_report = [&](rec::SupervisorState s) {
    rec::PoseReport r;
    r.set_state(s);
    b.Add(r);
  };
  auto states = [&]() {
    EXPECT_TRUE(b.Add(Truth(20 * (b.frames() + 1), SomePose(0), o.truth_geometry)) ||
                b.frames() == 0);
    b.Build(0);
    std::string s;
    for (int i = 1; i <= 6; ++i) s += Meta(*Entity(b.scene(), "leg" + std::to_string(i)), "state") + ",";
    return s;
  };
  EXPECT_EQ(states(), "unknown,unknown,unknown,unknown,unknown,unknown,");
  for (uint32_t l = 1; l <= 6; ++l) valve(l, rec::LEGCTRL_OK, false);
  valve(2, rec::LEGCTRL_HOLD_STALE_SETPOINT, false);
  valve(4, rec::LEGCTRL_OK, true);
  EXPECT_EQ(states(), "ok,hold,ok,standby active,ok,ok,");
  rec::FaultEvent f;
  f.set_leg_id(5);
  b.Add(f);
  pose_report(rec::SUPERVISOR_HOLD);
  valve(5, rec::LEGCTRL_OK, false);  // the controller is fine; the fault stays latched
  EXPECT_EQ(states(), "ok,hold,ok,standby active,fault,ok,");
  pose_report(rec::SUPERVISOR_TRACKING);  // operator reset
  EXPECT_EQ(states(), "ok,hold,ok,standby active,ok,ok,");
  // The colours differ per state.
  const auto color = [&](int leg) {
    const auto& c = Entity(b.scene(), "leg" + std::to_string(leg))->cylinders(0).color();
    return std::make_tuple(c.r(), c.g(), c.b());
  };
  EXPECT_NE(color(1), color(2));
  EXPECT_NE(color(1), color(4));
  EXPECT_NE(color(2), color(4));
}

TEST(BridgeProtocol, ClientRequestsAreCheckedStrictly) {
  using bridge::ClientRequest;
  using bridge::ParseClientText;
  const ClientRequest s = ParseClientText(
      R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":3},{"id":7,"channelId":10}]})");
  ASSERT_EQ(s.kind, ClientRequest::Kind::kSubscribe);
  EXPECT_EQ(s.subscriptions, (std::vector<std::pair<uint32_t, uint32_t>>{{0, 3}, {7, 10}}));
  const ClientRequest u = ParseClientText(R"({"op":"unsubscribe","subscriptionIds":[7]})");
  ASSERT_EQ(u.kind, ClientRequest::Kind::kUnsubscribe);
  EXPECT_EQ(u.unsubscribe_ids, std::vector<uint32_t>{7});
  for (const char* bad : {"", "garbage", "[1,2]", "{}", R"({"op":3})", R"({"op":"getParameters"})",
                          R"({"op":"subscribe"})", R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})",
                          R"({"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]})",
                          R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":1}]})",
                          R"({"op":"unsubscribe","subscriptionIds":["a"]})", "\xff\xfe{\"op\""}) {
    const ClientRequest r = ParseClientText(bad);
    EXPECT_EQ(r.kind, ClientRequest::Kind::kError) << bad;
    EXPECT_FALSE(r.error.empty()) << bad;
  }
  EXPECT_NE(ParseClientText(R"({"op":"advertise"})").error.find("unsupported op 'advertise'"),
            std::string::npos);
}

TEST(BridgeProtocol, ServerMessagesFollowTheSpec) {
  std::string frame;
  bridge::MessageDataFrame(0x01020304u, 0x1122334455667788ull, "abc", frame);
  ASSERT_EQ(frame.size(), 16u);
  EXPECT_EQ(frame[0], 0x01);
  uint32_t sub;
  uint64_t ts;
  std::memcpy(&sub, frame.data() + 1, 4);
  std::memcpy(&ts, frame.data() + 5, 8);
  EXPECT_EQ(sub, 0x01020304u);
  EXPECT_EQ(ts, 0x1122334455667788ull);
  EXPECT_EQ(frame.substr(13), "abc");
  const auto adv = nlohmann::json::parse(bridge::AdvertiseJson({{5, "t", "pkg.T", std::string("\x00\xff\x10", 3)}}));
  EXPECT_EQ(adv["op"], "advertise");
  EXPECT_EQ(adv["channels"][0]["id"], 5);
  EXPECT_EQ(adv["channels"][0]["schema"], "AP8Q");  // base64 of 00 ff 10
  EXPECT_EQ(adv["channels"][0]["schemaEncoding"], "protobuf");
  const auto info = nlohmann::json::parse(bridge::ServerInfoJson("hexa_bridge", "s"));
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_TRUE(info["capabilities"].empty());
  // A status quoting invalid UTF-8 from a client is still valid JSON.
  const auto st = nlohmann::json::parse(bridge::StatusJson(bridge::StatusLevel::kError, "bad \xff op"));
  EXPECT_EQ(st["level"], 2);
}

}  // namespace
}  // namespace hexa

TEST(BridgeConfig, EveryClientQueueIsAFairShareOfTheTotal) {
  hexa::bridge::ServerConfig c;
  c.client_queue_bytes = 4u << 20;
  c.total_queue_bytes = 128u << 20;
  c.max_clients = 32;
  EXPECT_NO_THROW(c.Validate());
  EXPECT_EQ(c.EffectiveClientQueueBytes(), 4u << 20);  // 128 MiB / 32 = 4 MiB
  c.max_clients = 200;
  EXPECT_EQ(c.EffectiveClientQueueBytes(), (128u << 20) / 200);
  EXPECT_LE(c.EffectiveClientQueueBytes() * c.max_clients, c.total_queue_bytes);
  // A queued message is charged beyond its frame for the allocations around it.
  EXPECT_EQ(hexa::bridge::QueuedMessageCost(100), 13 + 100 + hexa::bridge::kQueuedMessageBytes);
  c.max_clients = 0;
  EXPECT_THROW(c.Validate(), std::invalid_argument);
  c.max_clients = 4097;
  EXPECT_THROW(c.Validate(), std::invalid_argument);
  c.max_clients = 4096;  // 32 KiB each: below the 64 KiB a client needs
  try {
    c.Validate();
    ADD_FAILURE() << "accepted 32 KiB per client";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("4096 clients"), std::string::npos) << e.what();
  }
}

TEST(BridgeOperatorInput, OnlyWellFormedCommandsPass) {
  using hexa::bridge::OperatorInput;
  using hexa::bridge::ParseOperatorInput;
  auto ok = ParseOperatorInput(R"({"command": "start", "trajectory": "pitch"})");
  ASSERT_TRUE(ok.ok) << ok.error;
  EXPECT_EQ(ok.input.command, OperatorInput::Command::kStart);
  EXPECT_EQ(ok.input.trajectory, "pitch");
  EXPECT_EQ(ParseOperatorInput(R"({"command": "start"})").input.trajectory, "combined");
  for (const char* c : {"stop", "reset", "home", "stream"}) {
    const auto r = ParseOperatorInput(std::string(R"({"command": ")") + c + "\"}");
    EXPECT_TRUE(r.ok) << c << ": " << r.error;
    EXPECT_STREQ(hexa::bridge::CommandName(r.input.command), c);
  }
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "not valid JSON"},
      {R"({"command": NaN})", "not valid JSON"},
      {R"({"command": "start", "trajectory": Infinity})", "not valid JSON"},
      {"[1]", "not a JSON object"},
      {"{}", "'command' is absent"},
      {R"({"command": null})", "must be a string"},
      {R"({"command": "shutdown"})", "unknown command"},
      {R"({"command": "stop", "x": 1})", "unknown field 'x'"},
      {R"({"command": "start", "trajectory": "data/traj.csv"})", "is not one of"},
      {R"({"command": "start", "trajectory": 1})", "must be a string"},
      {R"({"command": "home", "trajectory": "x"})", "for start only"},
      {R"({"command": "stream", "velocity_m_s": [0, 0, 0]})", "for jog only"}};
  for (const auto& [text, words] : bad) {
    const auto r = ParseOperatorInput(text);
    EXPECT_FALSE(r.ok) << text;
    EXPECT_NE(r.error.find(words), std::string::npos) << text << ": " << r.error;
  }
}

TEST(BridgeOperatorInput, JogAndGoalAreCheckedFieldByField) {
  using hexa::bridge::OperatorInput;
  using hexa::bridge::ParseOperatorInput;
  auto jog = ParseOperatorInput(
      R"({"command": "jog", "frame": "tool", "velocity_m_s": [0.01, 0, -0.02], "angular_velocity_rad_s": [0, 0.1, 0]})");
  ASSERT_TRUE(jog.ok) << jog.error;
  EXPECT_EQ(jog.input.command, OperatorInput::Command::kJog);
  EXPECT_TRUE(jog.input.tool_frame);
  EXPECT_EQ(jog.input.velocity_m_s[2], -0.02);
  EXPECT_EQ(jog.input.angular_velocity_rad_s[1], 0.1);
  auto goal = ParseOperatorInput(
      R"({"command": "goal", "position_m": [0.01, 0.02, 0.45], "orientation_wxyz": [0.7071067811865476, 0, 0, 0.7071067811865476]})");
  ASSERT_TRUE(goal.ok) << goal.error;
  EXPECT_EQ(goal.input.command, OperatorInput::Command::kGoal);
  EXPECT_EQ(goal.input.position_m[2], 0.45);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"command": "jog", "velocity_m_s": [0, 0, 0]})", "'angular_velocity_rad_s' is absent"},
      {R"({"command": "jog", "angular_velocity_rad_s": [0, 0, 0]})", "'velocity_m_s' is absent"},
      {R"({"command": "jog", "velocity_m_s": [0, 0], "angular_velocity_rad_s": [0, 0, 0]})", "array of 3"},
      {R"({"command": "jog", "velocity_m_s": [0, "a", 0], "angular_velocity_rad_s": [0, 0, 0]})", "numbers only"},
      {R"({"command": "jog", "velocity_m_s": [0, NaN, 0], "angular_velocity_rad_s": [0, 0, 0]})", "not valid JSON"},
      {R"({"command": "jog", "velocity_m_s": [0, 1e999, 0], "angular_velocity_rad_s": [0, 0, 0]})", ""},
      {R"({"command": "jog", "velocity_m_s": [5, 0, 0], "angular_velocity_rad_s": [0, 0, 0]})", "jog vx = 5 m/s is absurd"},
      {R"({"command": "jog", "frame": "base", "velocity_m_s": [0, 0, 0], "angular_velocity_rad_s": [0, 0, 0]})", "'frame' must be"},
      {R"({"command": "goal", "position_m": [0, 0, 0.4]})", "'orientation_wxyz' is absent"},
      {R"({"command": "goal", "orientation_wxyz": [1, 0, 0, 0]})", "'position_m' is absent"},
      {R"({"command": "goal", "position_m": [0, 0, 0.4], "orientation_wxyz": [1, 0, 0, 0.1]})", "not a unit quaternion"},
      {R"({"command": "goal", "position_m": [10, 0, 0.4], "orientation_wxyz": [1, 0, 0, 0]})", "absurd"},
      {R"({"command": "stop", "velocity_m_s": [0, 0, 0]})", "for jog only"},
      {R"({"command": "jog", "position_m": [0, 0, 0]})", "for goal only"}};
  for (const auto& [text, words] : bad) {
    const auto r = ParseOperatorInput(text);
    EXPECT_FALSE(r.ok) << text;
    EXPECT_NE(r.error.find(words), std::string::npos) << text << ": " << r.error;
  }
}

TEST(BridgeOperatorInput, FramesAreCheckedFieldByField) {
  using hexa::bridge::OperatorInput;
  using hexa::bridge::ParseOperatorInput;
  // The pivot alone: the tool and work frames are the identity.
  auto pivot = ParseOperatorInput(R"({"command": "frames", "pivot_m": [0, 0.05, 0.2]})");
  ASSERT_TRUE(pivot.ok) << pivot.error;
  EXPECT_EQ(pivot.input.command, OperatorInput::Command::kFrames);
  EXPECT_STREQ(hexa::bridge::CommandName(pivot.input.command), "frames");
  EXPECT_EQ(pivot.input.pivot_m[2], 0.2);
  EXPECT_EQ(pivot.input.tool_orientation_wxyz[0], 1.0);
  EXPECT_EQ(pivot.input.work_orientation_wxyz[0], 1.0);
  EXPECT_EQ(pivot.input.work_position_m[0], 0.0);
  auto all = ParseOperatorInput(
      R"({"command": "frames", "pivot_m": [0, 0, 0.1], "tool_position_m": [0.01, 0, 0.05],
          "tool_orientation_wxyz": [0, 1, 0, 0], "work_position_m": [0.1, 0, 0],
          "work_orientation_wxyz": [0.7071067811865476, 0, 0, 0.7071067811865476]})");
  ASSERT_TRUE(all.ok) << all.error;
  EXPECT_EQ(all.input.tool_position_m[2], 0.05);
  EXPECT_EQ(all.input.tool_orientation_wxyz[1], 1.0);
  EXPECT_EQ(all.input.work_position_m[0], 0.1);
  EXPECT_EQ(all.input.work_orientation_wxyz[3], 0.7071067811865476);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"command": "frames"})", "field 'pivot_m' is absent"},
      {R"({"command": "frames", "tool_position_m": [0, 0, 0]})", "field 'pivot_m' is absent"},
      {R"({"command": "frames", "pivot_m": [0, NaN, 0]})", "not valid JSON"},
      {R"({"command": "frames", "pivot_m": [0, 1e999, 0]})", "not valid JSON"},  // overflow: not JSON
      {R"({"command": "frames", "pivot_m": [0, 0]})", "'pivot_m' must be an array of 3 numbers"},
      {R"({"command": "frames", "pivot_m": [10, 0, 0]})",
       "pivot_m (10, 0, 0) is 10 m from the platform origin: absurd (limit 2 m)"},
      {R"({"command": "frames", "pivot_m": [0, 0, 0], "work_position_m": [0, 3, 0]})",
       "work_position_m (0, 3, 0) is 3 m from the base origin: absurd (limit 2 m)"},
      {R"({"command": "frames", "pivot_m": [0, 0, 0], "tool_orientation_wxyz": [1, 0, 0, 0.1]})",
       "tool_orientation_wxyz (1 0 0 0.1) is not a unit quaternion"},
      {R"({"command": "frames", "pivot_m": [0, 0, 0], "work_orientation_wxyz": [0, 0, 0, 0]})",
       "work_orientation_wxyz (0 0 0 0) is not a unit quaternion"},
      {R"({"command": "frames", "pivot_m": [0, 0, 0], "position_m": [0, 0, 0]})", "for goal only"},
      {R"({"command": "jog", "pivot_m": [0, 0, 0]})", "'pivot_m' is for frames only"},
      {R"({"command": "goal", "position_m": [0, 0, 0.4], "orientation_wxyz": [1, 0, 0, 0],
           "work_orientation_wxyz": [1, 0, 0, 0]})", "'work_orientation_wxyz' is for frames only"}};
  for (const auto& [text, words] : bad) {
    const auto r = ParseOperatorInput(text);
    EXPECT_FALSE(r.ok) << text;
    EXPECT_NE(r.error.find(words), std::string::npos) << text << ": " << r.error;
  }
}

TEST(BridgeOperatorInput, RateLimiterAllowsTheBurstThenTheRate) {
  hexa::bridge::RateLimiter limiter(10, 10);
  int allowed = 0;
  for (int i = 0; i < 1000; ++i) allowed += limiter.Allow(1'000'000'000) ? 1 : 0;
  EXPECT_EQ(allowed, 10);  // 1000 at once: the burst
  allowed = 0;
  for (int64_t t_ms = 1; t_ms <= 2000; ++t_ms)  // 1000 a second for 2 s: the rate
    allowed += limiter.Allow(1'000'000'000 + t_ms * 1'000'000) ? 1 : 0;
  EXPECT_EQ(allowed, 20);
}

TEST(BridgeProtocol, ClientPublishIsParsedOnlyWhenEnabled) {
  using hexa::bridge::ClientRequest;
  const std::string adv =
      R"({"op":"advertise","channels":[{"id":3,"topic":"hexa_OperatorInput","encoding":"json","schemaName":"s"}]})";
  EXPECT_EQ(hexa::bridge::ParseClientText(adv).kind, ClientRequest::Kind::kError);
  const auto r = hexa::bridge::ParseClientText(adv, true);
  ASSERT_EQ(r.kind, ClientRequest::Kind::kAdvertise) << r.error;
  ASSERT_EQ(r.channels.size(), 1u);
  EXPECT_EQ(r.channels[0].id, 3u);
  EXPECT_EQ(r.channels[0].topic, "hexa_OperatorInput");
  EXPECT_EQ(hexa::bridge::ParseClientText(R"({"op":"advertise","channels":[{"id":3}]})", true).kind,
            ClientRequest::Kind::kError);
  const std::string frame("\x01\x07\x00\x00\x00{}", 7);
  const auto m = hexa::bridge::ParseClientBinary(frame);
  ASSERT_TRUE(m.ok) << m.error;
  EXPECT_EQ(m.channel_id, 7u);
  EXPECT_EQ(m.payload, "{}");
  EXPECT_FALSE(hexa::bridge::ParseClientBinary(std::string("\x02\x07\x00\x00\x00", 5)).ok);
  EXPECT_FALSE(hexa::bridge::ParseClientBinary(std::string("\x01\x07", 2)).ok);
  const auto info = nlohmann::json::parse(hexa::bridge::ServerInfoJson("n", "s", true));
  EXPECT_EQ(info["capabilities"], nlohmann::json::array({"clientPublish"}));
}
