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

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "hexa/config/rig_config.hpp"
#include "hexa/recorder/recording.hpp"
#include "recording.pb.h"

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

// The recordings of the ctest fixture identification.make_recordings (CMakeLists.txt): leg 1
// excited for 20 s (long.mcap) and for 2 s (short.mcap), profile realistic, seed 1.
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
