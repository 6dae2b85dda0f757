// What the recorder's tools read back from a recording: info counts and loss, the session
// report, diff, CSV export, the tick loss tracker and loss events.
#include <gtest/gtest.h>

#include "recorder_scratch.hpp"
#include <google/protobuf/util/message_differencer.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/services/json.hpp"
#include "recording.pb.h"
#include "synth.hpp"

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;

TEST(RecordingInfo, CountsAndLossOfTheSyntheticRecordingAreExact) {
  const fs::path dir = TempDir();
  const std::string path = dir / "synth.mcap";
  McapWriterConfig cfg;
  cfg.chunk_max_bytes = 64 * 1024;
  test::WriteSynthRecording(path, cfg);
  const RecordingInfo info = Inspect(path);
  EXPECT_TRUE(info.complete);
  EXPECT_GT(info.chunks, 5u);
  uint64_t total = 0;
  std::map<std::string, const ChannelInfo*> by_topic;
  for (const auto& c : info.channels) by_topic[c.topic] = &c;
  for (const auto& [topic, n] : test::SynthExpectedCounts()) {
    ASSERT_TRUE(by_topic.count(topic)) << topic;
    EXPECT_EQ(by_topic[topic]->count, n) << topic;
    total += n;
  }
  EXPECT_EQ(info.messages, total);
  EXPECT_EQ(info.channels.size(), test::SynthExpectedCounts().size());

  const ChannelInfo& sens = *by_topic["hexa_LegSensors"];
  ASSERT_TRUE(sens.loss_analysed);
  ASSERT_EQ(sens.streams.size(), 6u);
  EXPECT_EQ(sens.missing, 5u);
  for (const auto& s : sens.streams) {
    EXPECT_EQ(s.step_ticks, 1u) << s.key;
    EXPECT_EQ(s.expected, 1000u) << s.key;
    EXPECT_EQ(s.missing, s.key == "leg 3" ? 5u : 0u) << s.key;
    EXPECT_EQ(s.gaps, s.key == "leg 3" ? 1u : 0u) << s.key;
  }
  EXPECT_EQ(by_topic["hexa_ValveCommand"]->missing, 1u);
  const ChannelInfo& imu = *by_topic["hexa_ImuSample"];
  ASSERT_EQ(imu.streams.size(), 1u);
  EXPECT_EQ(imu.streams[0].step_ticks, 5u);
  EXPECT_EQ(imu.streams[0].missing, 1u);
  EXPECT_EQ(imu.streams[0].max_gap_ticks, 10u);
  EXPECT_EQ(by_topic["hexa_LegSetpoint"]->missing, 0u);
  EXPECT_FALSE(by_topic["hexa_NodeStatus"]->loss_analysed);  // event topic (period 0)
  EXPECT_FALSE(by_topic["hexa_FaultEvent"]->loss_analysed);
  // 1 kHz topics: (n - 1) / span. GroundTruth has 1000 samples 999 ms apart.
  EXPECT_NEAR(by_topic["hexa_GroundTruth"]->rate_hz, 1000.0, 1e-9);
  // Per simulated second, from the ticks (999 ticks span 1000 samples; six legs per tick).
  EXPECT_NEAR(by_topic["hexa_GroundTruth"]->sim_rate_hz, 1000.0, 1e-9);
  EXPECT_NEAR(by_topic["hexa_LegSensors"]->sim_rate_hz, 6000.0, 30.0);
  EXPECT_NE(FormatInfo(info).find("sim_hz"), std::string::npos);
  EXPECT_EQ(by_topic["hexa_LegSensors"]->metadata.at(kMetaPeriodS), "0.001");
  // Loss events: the plant's ticks 50 (ImuSample) and 100-104 (leg 3's LegSensors), leg 2's
  // ValveCommand of tick 500.
  EXPECT_EQ(info.loss_events.events.at("plant"), 6u);
  EXPECT_EQ(info.loss_events.events.at("leg 2"), 1u);
  EXPECT_EQ(info.loss_events.total_events, 7u);
  EXPECT_EQ(info.loss_events.total_samples, 7u);
  const std::string text = FormatInfo(info);
  EXPECT_NE(text.find("hexa_LegSensors"), std::string::npos);
  EXPECT_NE(text.find("leg 3"), std::string::npos);
  EXPECT_NE(text.find("loss events (missing samples per producer and tick, one per lost batch): 7 for 7 samples"),
            std::string::npos)
      << text;
}

// The late ticks of the report come from the plant's GroundTruth.command_age_ticks, per leg.
TEST(SessionReport, CommandAgesPerLegComeFromTheGroundTruth) {
  const fs::path dir = TempDir();
  const std::string path = dir / "synth_ages.mcap";
  test::WriteSynthRecording(path);
  const SessionReport r = ComputeSessionReport(path);
  ASSERT_TRUE(r.command_age_recorded);
  for (int leg = 1; leg <= 6; ++leg) {
    const auto expected = test::SynthCommandAges(leg);
    for (int b = 0; b < SessionReport::kAgeBins; ++b)
      EXPECT_EQ(r.command_age[leg - 1][b], expected[b]) << "leg " << leg << " bin " << b;
  }
}

// The legs' adapted friction scale theta (ValveCommand.friction_scale): per leg, its value at
// the leg's last command of the tracking window, min and max over that window only (ticks 1..4
// read 0.5, before the first TRACKING pose report); in report.md one line per leg, in
// report.json and legs.csv.
TEST(SessionReport, FrictionScalePerLegOverTheTrackingWindow) {
  const fs::path dir = TempDir();
  const std::string path = dir / "synth_theta.mcap";
  test::WriteSynthRecording(path);
  const SessionReport r = ComputeSessionReport(path);
  ASSERT_TRUE(r.AnyBsSmcLeg());
  for (uint32_t leg = 1; leg <= 6; ++leg) {
    SCOPED_TRACE("leg " + std::to_string(leg));
    const auto& f = r.friction_scale[leg - 1];
    const uint64_t commands = leg == 2 ? 995 : 996;  // ticks 5..1000; leg 2 misses tick 500
    EXPECT_EQ(f.bssmc_commands, commands);
    EXPECT_EQ(f.commands, commands);
    EXPECT_EQ(f.end, test::SynthFrictionScale(leg, 1000));
    EXPECT_EQ(f.min, 1.0 + 0.01 * leg);  // (tick + 10 leg) % 250 = 0 at tick 250 - 10 leg
    EXPECT_EQ(f.max, 1.0 + 0.01 * leg + 1e-4 * 249.0);
    ASSERT_EQ(r.command_friction_scale.size(), 1001u);
    for (uint64_t tick : {1ull, 4ull, 5ull, 499ull, 1000ull})
      EXPECT_EQ(r.command_friction_scale[tick][leg - 1], test::SynthFrictionScale(leg, tick)) << tick;
  }
  EXPECT_TRUE(std::isnan(r.command_friction_scale[500][1])) << "leg 2 has no command at tick 500";
  EXPECT_TRUE(std::isnan(r.command_friction_scale[0][0])) << "no command at tick 0";

  WriteSessionReport(r, dir.string());
  auto slurp = [&](const char* name) {
    std::ifstream in(dir / name);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  const std::string md = slurp("report.md");
  EXPECT_NE(md.find("## Adapted friction scale theta over the tracking window (BS-SMC)"), std::string::npos) << md;
  // Leg 3: end 1 + 0.03 + 0.0030, min 1.03, max 1.03 + 0.0249.
  EXPECT_NE(md.find("| 3 | 1.0330 | 1.0300 | 1.0549 | 996 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 2 | 1.0220 | 1.0200 | 1.0449 | 995 |"), std::string::npos) << md;
  const std::string json = slurp("report.json");
  const auto report = hexa::json::Value::parse(json);
  const auto& leg1 = report["friction_scale_per_leg"][0];
  EXPECT_EQ(leg1["bssmc_commands"], 996) << json;
  EXPECT_EQ(leg1["commands"], 996) << json;
  EXPECT_NEAR(leg1["end"].get<double>(), 1.011, 1e-9) << json;
  EXPECT_NEAR(leg1["min"].get<double>(), 1.01, 1e-9) << json;
  EXPECT_NEAR(leg1["max"].get<double>(), 1.0349, 1e-9) << json;
  const std::string csv = slurp("legs.csv");
  EXPECT_NE(csv.find(",valve_v_6 [V],friction_scale_1 [1],friction_scale_2 [1],friction_scale_3 [1],"
                     "friction_scale_4 [1],friction_scale_5 [1],friction_scale_6 [1]\n"),
            std::string::npos);
}

// Only a BS-SMC session has the figure: a PI session none; a BS-SMC recording from before the
// field says "not recorded" instead of a made-up theta.
TEST(SessionReport, FrictionScaleOnlyForBsSmcAndOnlyWhenRecorded) {
  const fs::path dir = TempDir();
  auto slurp = [&](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  {
    const std::string path = dir / "synth_pi.mcap";
    test::WriteSynthRecording(path, {}, 0.0, 0, 0, false, test::SynthController::kPi);
    const SessionReport r = ComputeSessionReport(path);
    EXPECT_FALSE(r.AnyBsSmcLeg());
    fs::create_directories(dir / "pi");
    WriteSessionReport(r, (dir / "pi").string());
    EXPECT_EQ(slurp(dir / "pi" / "report.md").find("friction scale"), std::string::npos);
    EXPECT_TRUE(hexa::json::Value::parse(slurp(dir / "pi" / "report.json"))["friction_scale_per_leg"].is_null());
  }
  {
    const std::string path = dir / "synth_old.mcap";
    test::WriteSynthRecording(path, {}, 0.0, 0, 0, false,
                              test::SynthController::kBsSmcWithoutFrictionScale);
    const SessionReport r = ComputeSessionReport(path);
    ASSERT_TRUE(r.AnyBsSmcLeg());
    for (int i = 0; i < 6; ++i) {
      EXPECT_GT(r.friction_scale[i].bssmc_commands, 0u);
      EXPECT_EQ(r.friction_scale[i].commands, 0u);
      EXPECT_TRUE(std::isnan(r.command_friction_scale[1000][i]));
    }
    fs::create_directories(dir / "old");
    WriteSessionReport(r, (dir / "old").string());
    EXPECT_NE(slurp(dir / "old" / "report.md").find("| 1 | not recorded | - | - | 996 |"),
              std::string::npos);
  }
}

TEST(RecordingDiff, FindsTheFirstDifferingTickAndTheSizeOfTheDifference) {
  const fs::path dir = TempDir();
  test::WriteSynthRecording(dir / "a.mcap");
  test::WriteSynthRecording(dir / "b.mcap");
  test::WriteSynthRecording(dir / "c.mcap", {}, 0.25, 4, 700);
  const DiffReport same = DiffValveCommands(dir / "a.mcap", dir / "b.mcap", 0.0);
  EXPECT_TRUE(same.identical);
  ASSERT_EQ(same.legs.size(), 6u);
  for (const auto& l : same.legs) {
    EXPECT_EQ(l.max_abs_diff_v, 0.0);
    EXPECT_EQ(l.common_ticks, l.leg_id == 2 ? 999u : 1000u);
  }
  const DiffReport d = DiffValveCommands(dir / "a.mcap", dir / "c.mcap", 1e-9);
  EXPECT_FALSE(d.identical);
  for (const auto& l : d.legs) {
    if (l.leg_id != 4) {
      EXPECT_FALSE(l.differs) << l.leg_id;
      continue;
    }
    EXPECT_TRUE(l.differs);
    EXPECT_EQ(l.first_diff_tick, 700u);
    EXPECT_NEAR(l.max_abs_diff_v, 0.25, 1e-12);
    // 301 of 1000 ticks differ by 0.25 V.
    EXPECT_NEAR(l.rms_diff_v, 0.25 * std::sqrt(301.0 / 1000.0), 1e-12);
  }
  // A tolerance above the offset hides it.
  EXPECT_TRUE(DiffValveCommands(dir / "a.mcap", dir / "c.mcap", 0.3).identical);
}

TEST(RecordingExport, WritesOneCsvPerTopicWithEveryField) {
  const fs::path dir = TempDir();
  test::WriteSynthRecording(dir / "s.mcap");
  const ExportResult r = ExportCsv(dir / "s.mcap", dir / "csv", TopicFilter{{"hexa_Leg*", "hexa_OperatorCommand"}, {"hexa_LegSetpoint"}});
  ASSERT_EQ(r.files.size(), 2u);
  std::ifstream f(dir / "csv" / "hexa_LegSensors.csv");
  std::string header, first;
  std::getline(f, header);
  std::getline(f, first);
  EXPECT_EQ(header,
            "log_time_ns [ns],publish_time_ns [ns],sequence [1],leg_id [1],header.tick [1],"
            "header.sim_time_s [s],header.source_time_ns [ns],length_m [m],cap_pressure_pa [Pa],"
            "rod_pressure_pa [Pa],supply_pressure_pa [Pa]");
  EXPECT_EQ(first.substr(first.find(",0,") + 3, 6), "1,1,0.");  // sequence 0, leg 1, tick 1
  uint64_t rows = 1;
  for (std::string line; std::getline(f, line);) ++rows;
  EXPECT_EQ(rows, test::SynthExpectedCounts().at("hexa_LegSensors"));
  std::ifstream op(dir / "csv" / "hexa_OperatorCommand.csv");
  std::getline(op, header);
  std::getline(op, first);
  EXPECT_NE(first.find(",OPERATOR_START,combined,\"/tmp/x, \"\"quoted\"\".csv\","), std::string::npos)
      << first;
}

// A stream that starts late or stops early against the other instances of its topic is
// reported (a recorder that matched one leg's writer late recorded it from tick 71 on, and
// the gaps between its first and last tick could not show it). Not counted as missing.
TEST(RecordingInfo, InstancesThatStartLateOrEndEarlyAreReported) {
  const fs::path dir = TempDir();
  const std::string path = dir / "partial.mcap";
  {
    McapWriterConfig cfg;
    cfg.sync = McapSyncMode::kNone;
    RecordingWriter w(cfg);
    w.Open(path);
    const uint16_t ch = w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(),
                                   {{kMetaPeriodS, "0.001"}});
    rec::ValveCommand v;
    for (uint64_t tick = 0; tick <= 100; ++tick) {
      for (uint32_t leg = 1; leg <= 3; ++leg) {
        if (leg == 2 && tick < 71) continue;   // matched late
        if (leg == 3 && tick > 90) continue;   // stopped early
        v.set_leg_id(leg);
        test::FillHeader(v.mutable_header(), tick);
        w.Write(ch, 1'000'000 * (tick + 1), 1'000'000 * (tick + 1), v);
      }
    }
    w.Close();
  }
  const RecordingInfo info = Inspect(path);
  ASSERT_EQ(info.channels.size(), 1u);
  const ChannelInfo& c = info.channels[0];
  ASSERT_EQ(c.streams.size(), 3u);
  EXPECT_EQ(c.missing, 0u);
  for (const auto& l : c.streams) {
    EXPECT_EQ(l.late_start_ticks, l.key == "leg 2" ? 71u : 0u) << l.key;
    EXPECT_EQ(l.early_end_ticks, l.key == "leg 3" ? 10u : 0u) << l.key;
  }
  const std::string text = FormatInfo(info);
  EXPECT_NE(text.find("PARTIAL: starts 71 ticks after and ends 0 ticks before"), std::string::npos)
      << text;
  EXPECT_NE(text.find("PARTIAL: starts 0 ticks after and ends 10 ticks before"), std::string::npos)
      << text;
  fs::remove_all(dir);
}

// A sample that arrives after a later one (an exclusive-ownership hand-over: the standby's
// answer of tick n lands after the primary's n+1..n+10) fills the hole its lateness opened.
// Before, every such reordering was counted as missing ticks although each tick was recorded.
TEST(TickLossTracker, LateSamplesThatFillAHoleAreNotMissing) {
  TickLossTracker t;
  for (uint64_t k = 0; k < 100; ++k) t.Add("leg 1", k);
  for (uint64_t k = 111; k < 200; ++k) t.Add("leg 1", k);  // ticks 100..110 come later
  for (uint64_t k = 100; k <= 110; ++k) t.Add("leg 1", k);
  t.Add("leg 1", 150);  // a plain duplicate
  const auto r = t.Results();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].expected, 200u);
  EXPECT_EQ(r[0].missing, 0u);
  EXPECT_EQ(r[0].gaps, 0u);
  EXPECT_EQ(r[0].filled_late, 11u);
  EXPECT_EQ(r[0].not_increasing, 12u);
  EXPECT_EQ(r[0].max_gap_ticks, 1u);
}

TEST(TickLossTracker, APartlyFilledHoleLeavesItsUnfilledRunsAsGaps) {
  TickLossTracker t;
  for (uint64_t k = 0; k <= 100; k += 5) t.Add("-", k);  // step 5
  for (uint64_t k = 150; k <= 300; k += 5) t.Add("-", k);  // 105..145 missing: 9 ticks
  t.Add("-", 120);                                          // one of them arrives late
  t.Add("-", 122);                                          // off the step: not a hole's tick
  const auto r = t.Results();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].step_ticks, 5u);
  EXPECT_EQ(r[0].missing, 8u);   // 105 110 115 | 125 130 135 140 145
  EXPECT_EQ(r[0].gaps, 2u);      // split in two by 120
  EXPECT_EQ(r[0].filled_late, 1u);
  EXPECT_EQ(r[0].max_gap_ticks, 30u);  // 120 -> 150: five ticks missing in a row, plus a step
}

TEST(TickLossTracker, AHoleNothingFillsIsCountedAsBefore) {
  TickLossTracker t;
  for (uint64_t k = 0; k < 50; ++k) t.Add("leg 2", k);
  for (uint64_t k = 60; k < 100; ++k) t.Add("leg 2", k);
  const auto r = t.Results();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].missing, 10u);
  EXPECT_EQ(r[0].gaps, 1u);
  EXPECT_EQ(r[0].max_gap_ticks, 11u);
  EXPECT_EQ(r[0].filled_late, 0u);
}

TEST(TickLossTracker, MissingTicksAreTheCountedHolesLessTheLateOnes) {
  TickLossTracker t;
  for (uint64_t k = 0; k <= 100; k += 5) t.Add("-", k);
  for (uint64_t k = 150; k <= 300; k += 5) t.Add("-", k);
  t.Add("-", 120);  // fills one tick of the hole 105..145
  const auto m = t.MissingTicks();
  ASSERT_EQ(m.count("-"), 1u);
  EXPECT_EQ(m.at("-"), (std::vector<uint64_t>{105, 110, 115, 125, 130, 135, 140, 145}));
  EXPECT_EQ(m.at("-").size(), t.Results()[0].missing);
}

// Loss events: one per producer and tick with anything missing. A lost datagram of the plant
// carrying a tick's six LegSensors and its GroundTruth is one event of 7 samples; the ValveCommands
// of two legs lost at the same tick are two events (two processes, two datagrams).
TEST(LossEvents, GroupMissingSamplesByProducerAndTick) {
  LossEventCounter c;
  std::map<std::string, std::vector<uint64_t>> sensors;
  for (int leg = 1; leg <= 6; ++leg) sensors[LegStreamKey(leg)] = {10, 20};
  sensors[LegStreamKey(3)].push_back(30);  // tick 30: only leg 3's sample
  c.AddTopic("hexa_LegSensors", sensors);
  c.AddTopic("hexa_GroundTruth", {{"", {10, 40}}});
  c.AddTopic("hexa_ValveCommand", {{LegStreamKey(1), {10}}, {LegStreamKey(2), {10, 11}}});
  c.AddTopic("hexa_LegSetpoint", {{LegStreamKey(1), {15}}, {LegStreamKey(2), {15}}});
  c.AddTopic("hexa_PoseReport", {{"", {15, 25}}});
  const LossEvents e = c.Finish();
  EXPECT_EQ(e.events.at("plant"), 4u);    // ticks 10, 20, 30, 40
  EXPECT_EQ(e.samples.at("plant"), 15u);  // 6 + 6 + 1 sensors, 2 truth
  EXPECT_EQ(e.events.at("leg 1"), 1u);
  EXPECT_EQ(e.events.at("leg 2"), 2u);
  EXPECT_EQ(e.events.at("supervisor"), 2u);  // ticks 15 (two setpoints and a pose), 25
  EXPECT_EQ(e.samples.at("supervisor"), 4u);
  EXPECT_EQ(e.total_events, 9u);
  EXPECT_EQ(e.total_samples, 15u + 1u + 2u + 4u);
  EXPECT_EQ(ProducerOf("hexa_ImuSample", ""), "plant");
  EXPECT_EQ(ProducerOf("hexa_TrackerPose", ""), "plant");
}

}  // namespace
}  // namespace hexa::recorder
