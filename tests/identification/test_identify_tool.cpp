// hexa_identify end to end on recordings of the in-process identification experiment
// (hexa_sim --experiment identify, the services' code path): a good recording gives an overlay
// that loads next to the rig file (round trip through the rig validator); bad input - no
// excitation, no pressure channels, too short, a different rig, no file - gives an error
// naming what is missing, and no overlay.
#include <gtest/gtest.h>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/text_format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/recording/recording.hpp"
#include "recording.pb.h"
#include "recording_input.hpp"

namespace fs = std::filesystem;

namespace hexa {
namespace {

struct ToolRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

ToolRun Execute(const std::string& command) {
  ToolRun r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) r.output.append(buf, n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A recording whose sensor schema has the potentiometer but no pressure fields (a rig without
// pressure sensors), with open-loop valve commands.
void WritePotentiometerOnlyRecording(const std::string& path) {
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(R"(
    name: "potentiometer_only.proto" package: "hexa.test" syntax: "proto3"
    message_type { name: "Header"
      field { name: "tick" number: 1 type: TYPE_UINT64 label: LABEL_OPTIONAL } }
    message_type { name: "LegSensors"
      field { name: "leg_id" number: 1 type: TYPE_UINT32 label: LABEL_OPTIONAL }
      field { name: "header" number: 2 type: TYPE_MESSAGE type_name: ".hexa.test.Header"
              label: LABEL_OPTIONAL }
      field { name: "length_m" number: 3 type: TYPE_DOUBLE label: LABEL_OPTIONAL } })",
                                                            &file));
  google::protobuf::DescriptorPool pool;
  const google::protobuf::FileDescriptor* fd = pool.BuildFile(file);
  ASSERT_NE(fd, nullptr);
  const google::protobuf::Descriptor* d = fd->FindMessageTypeByName("LegSensors");
  google::protobuf::DynamicMessageFactory factory(&pool);
  std::unique_ptr<google::protobuf::Message> m(factory.GetPrototype(d)->New());
  const google::protobuf::Reflection* r = m->GetReflection();
  recorder::RecordingWriter w;
  w.Open(path);
  const uint16_t sensors = w.AddTopic("hexa_LegSensors", *d, {{recorder::kMetaPeriodS, "0.001"}});
  const uint16_t valves =
      w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(), {{recorder::kMetaPeriodS, "0.001"}});
  rec::ValveCommand c;
  for (std::uint64_t k = 0; k < 100; ++k) {
    r->SetUInt32(m.get(), d->FindFieldByName("leg_id"), 1);
    google::protobuf::Message* h = r->MutableMessage(m.get(), d->FindFieldByName("header"));
    h->GetReflection()->SetUInt64(h, h->GetDescriptor()->FindFieldByName("tick"), k);
    r->SetDouble(m.get(), d->FindFieldByName("length_m"), 0.6);
    w.Write(sensors, k * 1'000'000, k * 1'000'000, *m);
    c.set_leg_id(1);
    c.mutable_header()->set_tick(k);
    c.set_valve_v(5.5);
    c.set_controller(rec::CONTROLLER_NONE);
    w.Write(valves, k * 1'000'000, k * 1'000'000, c);
  }
  w.Close();
}

// The recordings of the ctest fixture identification.make_recordings (CMakeLists.txt): legs 1
// and 4 excited for 20 s each (long.mcap), leg 1 and for 2 s (short.mcap), profile realistic, seed 1.
class IdentifyTool : public ::testing::Test {
 protected:
  static ToolRun Identify(const std::string& args) {
    return Execute(std::string(HEXA_IDENTIFY_BIN) + " --no-plots --method lsq " + args);
  }
  const std::string dir_ = HEXA_IDENTIFY_TEST_DIR;
};

TEST_F(IdentifyTool, IdentifiedOverlayRoundTripsThroughTheRigValidator) {
  ASSERT_TRUE(fs::exists(dir_ + "/long.mcap")) << "the fixture identification.make_recordings did not run";
  const std::string out = dir_ + "/good";
  const ToolRun r = Identify(dir_ + "/long.mcap --legs 1 --min-samples 300 --out " + out +
                         " --truth-overlay " + dir_ + "/truth.textproto");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string overlay = out + "/identified.textproto";
  ASSERT_TRUE(fs::exists(overlay)) << r.output;
  // Loaded next to the rig file as a service loads it, the overlay is what was written.
  const config::OverlayResult parsed = config::LoadRigOverlay(overlay);
  ASSERT_TRUE(parsed.ok) << parsed.error;
  const config::ConfigResult loaded = config::LoadSystemConfig(config::DefaultRigFile(), {overlay});
  ASSERT_TRUE(loaded.ok) << loaded.error;
  const ControllerModel model = config::MakeControllerModel(loaded.config);
  const config::LegOverride& leg1 = parsed.overlay.leg[0];
  ASSERT_TRUE(leg1.polytropic_extend.volume.has_value()) << ReadText(overlay);
  EXPECT_EQ(model.legs[0].model.polytropic.extend.volume, *leg1.polytropic_extend.volume);
  ASSERT_TRUE(leg1.friction_extend.coulomb_n.has_value()) << ReadText(overlay);
  EXPECT_EQ(model.legs[0].model.friction.extend.coulomb_n, *leg1.friction_extend.coulomb_n);
  // Not the nominal value: the overlay carries an identification.
  EXPECT_NE(*leg1.friction_extend.coulomb_n, loaded.config.rig.friction.extend.coulomb_n);
  // Legs not identified keep the rig file's values.
  EXPECT_EQ(model.legs[1].model.friction.extend.coulomb_n, loaded.config.rig.friction.extend.coulomb_n);
  EXPECT_TRUE(config::LoadSystemConfig(config::DefaultRigFile(), {dir_ + "/truth.textproto"}).ok);
  EXPECT_TRUE(fs::exists(out + "/identification.md"));
  EXPECT_TRUE(fs::exists(out + "/identification.json"));
}

// The payload scale hexa_identify estimated from one leg's acceleration channel (its log).
double PayloadScaleOfLeg(const std::string& output, int leg) {
  const std::string key = "leg " + std::to_string(leg) + ": payload scale ";
  const std::size_t at = output.find(key);
  return at == std::string::npos ? std::nan("") : std::stod(output.substr(at + key.size(), 16));
}

// The kinematic calibration reaches the identification (--rig-overlay, e.g. hexa_calibrate's
// overlay): the `realistic` plant's joints and potentiometers differ from the rig file's (up
// to 2 mm, 1 mm, 0.5 %); they enter the force each leg must exert (the platform's inverse
// dynamics) and the measured motion. The payload scale is one property of the platform, but
// each leg's acceleration channel gives its own estimate: without the calibration legs 1 and
// 4 disagree by 2 % (leg 4's joints and potentiometer are off most), with the plant's TRUE
// calibration as the overlay they agree to a few 0.1 %. Before --rig-overlay existed
// hexa_identify used the rig file's nominal joints whatever the rig's calibration.
TEST_F(IdentifyTool, TheKinematicCalibrationReachesTheIdentification) {
  ASSERT_TRUE(fs::exists(dir_ + "/long.mcap")) << "the fixture identification.make_recordings did not run";
  const identify::IdentificationRecording rec = identify::ReadIdentificationRecording(dir_ + "/long.mcap");
  ASSERT_TRUE(rec.truth.has_value());
  const std::string cal = dir_ + "/true_calibration.textproto";
  {
    std::ofstream f(cal);
    f.precision(17);
    f << "rig_name: \"" << rec.truth->rig_name() << "\"\n"
      << "provenance { method: \"the plant's true calibration (test)\" date: \"-\" }\n";
    for (const auto& leg : rec.truth->leg()) {
      ASSERT_EQ(leg.p_ba_b_m_size(), 3);
      ASSERT_EQ(leg.p_pb_p_m_size(), 3);
      f << "leg { leg_id: " << leg.leg_id() << " p_BA_B_m { x: " << leg.p_ba_b_m(0) << " y: " << leg.p_ba_b_m(1)
        << " z: " << leg.p_ba_b_m(2) << " } p_PB_P_m { x: " << leg.p_pb_p_m(0) << " y: " << leg.p_pb_p_m(1)
        << " z: " << leg.p_pb_p_m(2) << " } potentiometer_offset_m: " << leg.potentiometer_offset_m()
        << " potentiometer_gain: " << leg.potentiometer_gain() << " }\n";
    }
  }
  const std::string common = dir_ + "/long.mcap --legs 1,4 --min-samples 300";
  const ToolRun plain = Identify(common + " --out " + dir_ + "/uncalibrated");
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  const ToolRun calibrated = Identify(common + " --rig-overlay " + cal + " --out " + dir_ + "/calibrated");
  ASSERT_EQ(calibrated.exit_code, 0) << calibrated.output;
  EXPECT_NE(calibrated.output.find("rig overlays applied"), std::string::npos) << calibrated.output;
  // Without the calibration the tool says so, naming the legs and the way to calibrate.
  EXPECT_NE(plain.output.find("warning: no kinematic calibration for leg(s) 1 4"), std::string::npos)
      << plain.output;
  EXPECT_NE(plain.output.find("--rig-overlay calibration.textproto"), std::string::npos) << plain.output;
  EXPECT_EQ(calibrated.output.find("no kinematic calibration"), std::string::npos) << calibrated.output;
  const double plain_gap = std::abs(PayloadScaleOfLeg(plain.output, 1) - PayloadScaleOfLeg(plain.output, 4));
  const double calibrated_gap =
      std::abs(PayloadScaleOfLeg(calibrated.output, 1) - PayloadScaleOfLeg(calibrated.output, 4));
  std::printf("payload scale, leg 1 - leg 4: nominal joints %.4f, calibrated %.4f\n", plain_gap, calibrated_gap);
  ASSERT_TRUE(std::isfinite(plain_gap)) << plain.output;
  ASSERT_TRUE(std::isfinite(calibrated_gap)) << calibrated.output;
  EXPECT_LT(calibrated_gap, 0.25 * plain_gap);
}

TEST_F(IdentifyTool, ALegThatWasNeverExcitedIsNamed) {
  ASSERT_TRUE(fs::exists(dir_ + "/long.mcap")) << "the fixture identification.make_recordings did not run";
  const ToolRun r = Identify(dir_ + "/long.mcap --legs 2 --out " + dir_ + "/leg2");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("leg 2: no excitation"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ + "/leg2/identified.textproto"));
}

TEST_F(IdentifyTool, ATooShortRecordingSaysHowManySamplesItHas) {
  ASSERT_TRUE(fs::exists(dir_ + "/short.mcap")) << "the fixture identification.make_recordings did not run";
  const ToolRun r = Identify(dir_ + "/short.mcap --legs 1 --out " + dir_ + "/short");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("too few usable samples"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("too short"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ + "/short/identified.textproto"));
}

TEST_F(IdentifyTool, ARecordingWithoutPressureChannelsIsRefused) {
  const std::string path = dir_ + "/no_pressure.mcap";
  WritePotentiometerOnlyRecording(path);
  const ToolRun r = Identify(path + " --legs 1 --out " + dir_ + "/no_pressure");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no chamber / supply pressure fields"), std::string::npos) << r.output;
}

TEST_F(IdentifyTool, ARecordingOfAnotherRigIsRefused) {
  ASSERT_TRUE(fs::exists(dir_ + "/long.mcap")) << "the fixture identification.make_recordings did not run";
  // The same rig file under another rig's name.
  std::string text = ReadText(config::DefaultRigFile());
  const std::string from = "rig_name: \"HexaTaar-R\"";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "rig_name: \"HexaTaar-Other\"");
  const std::string rig = dir_ + "/other_rig.textproto";
  std::ofstream(rig) << text;
  const ToolRun r = Identify(dir_ + "/long.mcap --legs 1 --rig " + rig + " --out " + dir_ + "/other");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("recorded on rig 'HexaTaar-R'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("HexaTaar-Other"), std::string::npos) << r.output;
}

TEST_F(IdentifyTool, AMissingRecordingIsNamed) {
  const ToolRun r = Identify(dir_ + "/nonexistent.mcap --out " + dir_ + "/none");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("nonexistent.mcap"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace hexa
