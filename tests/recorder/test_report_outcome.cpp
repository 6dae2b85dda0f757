// What the session report says about how a session went, from the recording alone: a
// session that never tracked gets no table of zeros, a hot-standby take-over is listed
// although no FaultEvent names it, samples the recorder lost make a "completed" session not
// completed; and a recording split into parts by size (each part complete, the oldest deleted).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/recording/rotation.hpp"
#include "hexa/services/json.hpp"
#include "recording.pb.h"
#include "scratch_dir.hpp"
#include "synth.hpp"

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;

fs::path TempDir() {
  return hexa::testing::ScratchDir(
      std::string("hexa_rec_outcome_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A 1 s session, 1 kHz legs, 200 Hz supervisor, every tick recorded. Leg 3's valve commands
// come from its primary up to `primary_until_tick`, from its hot standby after (0: primary
// throughout). The supervisor reports `state` throughout. Without `ground_truth` the plant
// publishes none (a rig's device).
void WriteSession(const std::string& path, rec::SupervisorState state, uint64_t primary_until_tick,
                  bool ground_truth = true) {
  McapWriterConfig config;
  config.sync = McapSyncMode::kNone;
  RecordingWriter w(config);
  w.Open(path);
  const std::map<std::string, std::string> meta1{{kMetaPeriodS, "0.001"}};
  const std::map<std::string, std::string> meta5{{kMetaPeriodS, "0.005"}};
  const uint16_t c_sens = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(), meta1);
  const uint16_t c_valve = w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(), meta1);
  const uint16_t c_gt = w.AddTopic("hexa_GroundTruth", *rec::GroundTruth::descriptor(), meta1);
  const uint16_t c_pose = w.AddTopic("hexa_PoseReport", *rec::PoseReport::descriptor(), meta5);
  for (uint64_t tick = 1; tick <= 1000; ++tick) {
    const uint64_t t_ns = test::kSynthStartNs + tick * 1'000'000ull;
    rec::GroundTruth g;
    test::FillHeader(g.mutable_header(), tick);
    for (double v : {0.0, 0.0, 0.5}) g.add_position_m(v);
    for (double v : {1.0, 0.0, 0.0, 0.0}) g.add_orientation_wxyz(v);
    for (int i = 0; i < 6; ++i) g.add_applied_valve_v(tick % 2 ? 5.0 : 5.5);
    if (ground_truth) w.Write(c_gt, t_ns, t_ns, g);
    for (uint32_t leg = 1; leg <= 6; ++leg) {
      rec::LegSensors s;
      s.set_leg_id(leg);
      test::FillHeader(s.mutable_header(), tick);
      s.set_length_m(0.5);
      w.Write(c_sens, t_ns, t_ns, s);
      rec::ValveCommand c;
      c.set_leg_id(leg);
      test::FillHeader(c.mutable_header(), tick);
      c.set_valve_v(5.0);
      c.set_desired_length_m(0.5);
      c.set_controller(rec::CONTROLLER_BSSMC);
      c.set_standby(leg == 3 && primary_until_tick > 0 && tick > primary_until_tick);
      w.Write(c_valve, t_ns, t_ns, c);
    }
    if (tick % 5 == 0) {
      rec::PoseReport p;
      test::FillHeader(p.mutable_header(), tick);
      p.set_state(state);
      for (int i = 0; i < 6; ++i) {
        p.add_desired_pose(i == 2 ? 0.5 : 0.0);
        p.add_estimated_pose(i == 2 ? 0.5 : 0.0);
        p.add_error_pose(0.0);
      }
      w.Write(c_pose, t_ns, t_ns, p);
    }
  }
  w.Close();
}

TEST(SessionReportOutcome, ASessionThatNeverTrackedHasNoTableOfZeros) {
  const fs::path dir = TempDir();
  const std::string path = (dir / "held.mcap").string();
  WriteSession(path, rec::SUPERVISOR_HOLD, 0);
  SessionReport r = ComputeSessionReport(path);
  r.meta["completed"] = "NO";
  WriteSessionReport(r, dir.string());
  const std::string md = Slurp(dir / "report.md");
  EXPECT_NE(md.find("Not tracked: the supervisor never reached TRACKING (final state HOLD)"),
            std::string::npos) << md;
  EXPECT_EQ(md.find("| RMSE vs ground truth"), std::string::npos) << md;
  EXPECT_EQ(md.find("0.000"), std::string::npos) << md;
  const auto json = hexa::json::Value::parse(Slurp(dir / "report.json"));
  EXPECT_TRUE(json["rmse_vs_ground_truth"]["x_m"].is_null()) << json.dump();
  EXPECT_TRUE(json["rmse_vs_ground_truth"]["yaw_rad"].is_null()) << json.dump();
  EXPECT_TRUE(json["leg_length_rmse_m"][0].is_null()) << json.dump();
}

TEST(SessionReportOutcome, AStandbyTakeOverIsListedWithItsTick) {
  const fs::path dir = TempDir();
  const std::string path = (dir / "takeover.mcap").string();
  WriteSession(path, rec::SUPERVISOR_TRACKING, 400);
  const SessionReport r = ComputeSessionReport(path);
  WriteSessionReport(r, dir.string());
  const std::string md = Slurp(dir / "report.md");
  const std::string faults = md.substr(md.find("## Faults"));
  EXPECT_EQ(faults.find("none"), std::string::npos) << faults;
  EXPECT_NE(faults.find("take-over (no FaultEvent): leg 3: the hot standby drives the valve from "
                        "tick 401 (t = 0.401 s; the primary's last command at tick 400), 600 commands"),
            std::string::npos)
      << faults;
  const auto json = hexa::json::Value::parse(Slurp(dir / "report.json"));
  ASSERT_EQ(json["takeovers"].size(), 1u);
  EXPECT_EQ(json["takeovers"][0].get<std::string>().rfind("leg 3: the hot standby", 0), 0u);
  // The plots mark the same take-over at the same tick (events.csv, one rule: takeover.hpp).
  EXPECT_NE(Slurp(dir / "events.csv").find("0.401,takeover,3,\"leg 3 standby takes over\""),
            std::string::npos)
      << Slurp(dir / "events.csv");
  // A primary throughout: no take-over, "none".
  WriteSession(path, rec::SUPERVISOR_TRACKING, 0);
  WriteSessionReport(ComputeSessionReport(path), dir.string());
  EXPECT_NE(Slurp(dir / "report.md").find("## Faults\n\nnone\n"), std::string::npos);
}

// Valve activity comes from the voltages the plant applied (GroundTruth). A rig's device
// publishes no GroundTruth: the activity is unknown, '-' and null, not 0.
TEST(SessionReportOutcome, ValveActivityWithoutGroundTruthIsUnknownNotZero) {
  const fs::path dir = TempDir();
  const std::string path = (dir / "valves.mcap").string();
  WriteSession(path, rec::SUPERVISOR_TRACKING, 0);
  const SessionReport truth = ComputeSessionReport(path);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(truth.valve_mean_abs_step_v[i], 0.5, 1e-12) << "leg " << i + 1;
  WriteSession(path, rec::SUPERVISOR_TRACKING, 0, /*ground_truth=*/false);
  const SessionReport rig = ComputeSessionReport(path);
  WriteSessionReport(rig, dir.string());
  const std::string md = Slurp(dir / "report.md");
  EXPECT_NE(md.find("| valve mean abs step V/tick | - | - | - | - | - | - |"), std::string::npos) << md;
  EXPECT_NE(md.find("| valve saturated % | - | - | - | - | - | - |"), std::string::npos) << md;
  EXPECT_NE(md.find("the valve activity is unknown"), std::string::npos) << md;
  const auto json = hexa::json::Value::parse(Slurp(dir / "report.json"));
  EXPECT_TRUE(json["valve_mean_abs_step_v_per_tick"][0].is_null()) << json.dump();
  EXPECT_TRUE(json["valve_saturated_fraction"][5].is_null()) << json.dump();
}

// The synthetic recording lacks 5 LegSensors samples and 1 ImuSample: the recorder lost them.
TEST(SessionReportOutcome, LostSamplesMakeACompletedSessionNotCompleted) {
  const fs::path dir = TempDir();
  const std::string path = (dir / "synth.mcap").string();
  test::WriteSynthRecording(path);
  SessionReport r = ComputeSessionReport(path);
  r.meta["completed"] = "yes";
  WriteSessionReport(r, dir.string());
  const std::string md = Slurp(dir / "report.md");
  EXPECT_EQ(md.find("- completed: yes"), std::string::npos) << md;
  EXPECT_NE(md.find("- completed: NO: the trajectory ran to its end, but the recording lost 6 of "),
            std::string::npos) << md;
  EXPECT_NE(md.find("- recording: the recording lost 6 of "), std::string::npos) << md;
  EXPECT_EQ(hexa::json::Value::parse(Slurp(dir / "report.json"))["recording_lost_samples"], 6);
  // Nothing lost: completed stays completed.
  WriteSession(path, rec::SUPERVISOR_TRACKING, 0);
  SessionReport whole = ComputeSessionReport(path);
  whole.meta["completed"] = "yes";
  WriteSessionReport(whole, dir.string());
  EXPECT_NE(Slurp(dir / "report.md").find("- completed: yes\n"), std::string::npos);
  EXPECT_EQ(hexa::json::Value::parse(Slurp(dir / "report.json"))["recording_lost_samples"], 0);
}

TEST(RecordingRotation, PartsBySizeAreCompleteAndTheOldestAreDeleted) {
  const fs::path dir = TempDir();
  const std::string path = (dir / "session.mcap").string();
  McapWriterConfig config;
  config.sync = McapSyncMode::kNone;
  config.compression = McapCompression::kNone;
  RecordingWriter w(config);
  w.Open(path);
  const uint16_t ch = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(),
                                 {{kMetaPeriodS, "0.001"}});
  RotationConfig rc;
  rc.split_bytes = 20'000;
  rc.keep_files = 3;
  RecordingRotation rotation(rc, path, 0);
  uint64_t written = 0;
  for (uint64_t tick = 1; tick <= 3000; ++tick) {
    rec::LegSensors s;
    s.set_leg_id(1);
    test::FillHeader(s.mutable_header(), tick);
    s.set_length_m(0.5);
    w.Write(ch, tick * 1'000'000ull, tick * 1'000'000ull, s);
    ++written;
    if (tick % 100 == 0) {
      w.mcap().FlushChunk();
      if (rotation.Due(w.mcap(), tick * 1'000'000ull)) rotation.Rotate(w.mcap(), tick * 1'000'000ull);
    }
  }
  w.Close();
  ASSERT_GE(rotation.deleted().size(), 1u) << "the test should rotate more than keep_files times";
  ASSERT_EQ(rotation.parts().size(), 2u);  // keep_files 3 = 2 closed parts + the open file
  const unsigned first_kept = static_cast<unsigned>(rotation.deleted().size()) + 1;
  EXPECT_EQ(rotation.parts().front(), RecordingRotation::PartPath(path, first_kept));
  EXPECT_EQ(RecordingRotation::PartPath(path, 12), (dir / "session-0012.mcap").string());
  for (const auto& gone : rotation.deleted()) EXPECT_FALSE(fs::exists(gone)) << gone;
  // Every file left reads alone, complete, with the channel and consecutive sequence numbers.
  uint64_t messages = 0;
  for (const std::string& file : {rotation.parts()[0], rotation.parts()[1], path}) {
    SCOPED_TRACE(file);
    const RecordingInfo info = Inspect(file);
    EXPECT_TRUE(info.complete);
    ASSERT_EQ(info.channels.size(), 1u);
    EXPECT_EQ(info.channels[0].topic, "hexa_LegSensors");
    EXPECT_EQ(info.channels[0].missing, 0u);
    EXPECT_LE(fs::file_size(file), 20'000u + 12'000u);  // the limit + one flush interval's chunk
    messages += info.messages;
  }
  EXPECT_LT(messages, written);  // the deleted parts held the rest
  EXPECT_GT(messages, 0u);
}

}  // namespace
}  // namespace hexa::recorder
