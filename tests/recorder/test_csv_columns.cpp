// Every CSV the recorder writes has a unit in every column header ("name [unit]", SI, "1" for
// dimensionless, "-" for text), and the export says what each file holds (README.txt).
#include <gtest/gtest.h>
#include <google/protobuf/descriptor.pb.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/recording/csv_columns.hpp"
#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "identification.pb.h"
#include "recording.pb.h"
#include "scratch_dir.hpp"
#include "synth.hpp"

namespace {
namespace fs = std::filesystem;
namespace gp = google::protobuf;
using namespace hexa::recorder;

const std::set<std::string> kUnits = {"m", "rad", "s", "ns", "Pa", "V", "N", "kg", "Hz", "m/s",
                                      "m/s^2", "rad/s", "N/s", "N/m", "N s/m", "kg m^2", "1", "-"};

fs::path TempDir() {
  return hexa::testing::ScratchDir(std::string("hexa_csv_test_") +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

std::vector<std::string> SplitHeader(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) out.push_back(cell);
  return out;
}

// Checks "name [unit]" for every cell; returns the names.
std::vector<std::string> CheckHeader(const fs::path& csv) {
  std::ifstream f(csv);
  std::string header;
  EXPECT_TRUE(std::getline(f, header)) << csv;
  const std::regex cell(R"(^([A-Za-z_][A-Za-z0-9_.\[\]]*) \[([^\]]+)\]$)");
  std::vector<std::string> names;
  for (const auto& c : SplitHeader(header)) {
    std::smatch m;
    if (!std::regex_match(c, m, cell)) {
      ADD_FAILURE() << csv.filename() << ": header cell '" << c << "' is not 'name [unit]'";
      continue;
    }
    EXPECT_TRUE(kUnits.count(m[2].str())) << csv.filename() << ": '" << c << "' has unit '" << m[2] << "'";
    names.push_back(m[1].str());
  }
  return names;
}

// Every scalar field of every recorded message type (and of the identification channels) has a
// known unit, walking nested messages as the export does.
void ExpectUnits(const gp::Descriptor& d, const std::string& prefix) {
  for (int i = 0; i < d.field_count(); ++i) {
    const gp::FieldDescriptor& f = *d.field(i);
    if (f.cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE) {
      ExpectUnits(*f.message_type(), prefix + f.name() + ".");
      continue;
    }
    const int n = f.is_repeated() ? 6 : 1;
    for (int k = 0; k < n; ++k) {
      const std::string unit = ColumnUnit(f, f.is_repeated() ? k : -1);
      EXPECT_TRUE(kUnits.count(unit)) << d.full_name() << "." << prefix << f.name() << "[" << k
                                      << "] has unit '" << unit << "'";
    }
  }
}

TEST(CsvColumns, EveryFieldOfTheRecordingSchemasHasAUnit) {
  const gp::FileDescriptor* files[] = {hexa::rec::GroundTruth::descriptor()->file(),
                                       hexa::rec::PlantTruth::descriptor()->file()};
  for (const auto* file : files)
    for (int i = 0; i < file->message_type_count(); ++i) ExpectUnits(*file->message_type(i), "");
  // Known values, not just "some unit".
  const auto* pose = hexa::rec::PoseReport::descriptor()->FindFieldByName("desired_pose");
  EXPECT_EQ(ColumnUnit(*pose, 2), "m");
  EXPECT_EQ(ColumnUnit(*pose, 3), "rad");
  EXPECT_EQ(ElementName(*pose, 5), "desired_pose.yaw");
  const auto* truth = hexa::rec::GroundTruth::descriptor();
  EXPECT_EQ(ColumnUnit(*truth->FindFieldByName("cap_pressure_pa"), 0), "Pa");
  EXPECT_EQ(ElementName(*truth->FindFieldByName("leg_length_m"), 2), "leg_length_m.leg3");
  EXPECT_EQ(ColumnUnit(*truth->FindFieldByName("angular_velocity_rad_s"), 1), "rad/s");
  EXPECT_EQ(ColumnUnit(*hexa::rec::LegSetpoint::descriptor()->FindFieldByName("acceleration_m_s2"), -1),
            "m/s^2");
}

TEST(CsvColumns, ExportHeadersHaveUnitsAndTheReadmeDescribesEveryFile) {
  const fs::path dir = TempDir();
  test::WriteSynthRecording(dir / "s.mcap");
  const ExportResult r = ExportCsv(dir / "s.mcap", dir / "csv", TopicFilter{});
  ASSERT_GE(r.files.size(), 5u);
  std::ifstream readme_in(dir / "csv" / "README.txt");
  std::stringstream readme;
  readme << readme_in.rdbuf();
  for (const auto& [path, rows] : r.files) {
    SCOPED_TRACE(path);
    const auto names = CheckHeader(path);
    EXPECT_GE(names.size(), 4u);
    const std::string file = fs::path(path).filename().string();
    EXPECT_NE(readme.str().find(file + ": topic "), std::string::npos) << readme.str();
  }
  EXPECT_NE(readme.str().find("name [unit]"), std::string::npos);
  const auto pose = CheckHeader(dir / "csv" / "hexa_PoseReport.csv");
  EXPECT_NE(std::find(pose.begin(), pose.end(), "desired_pose.roll"), pose.end());
}

TEST(CsvColumns, ReportCsvHeadersHaveUnits) {
  const fs::path dir = TempDir();
  test::WriteSynthRecording(dir / "s.mcap");
  const SessionReport report = ComputeSessionReport(dir / "s.mcap");
  WriteSessionReport(report, dir.string());
  for (const char* f : {"pose.csv", "legs.csv", "events.csv"}) {
    SCOPED_TRACE(f);
    EXPECT_GE(CheckHeader(dir / f).size(), 4u);
  }
}

}  // namespace

namespace {

// A recording made by another build: its ValveCommand schema lacks friction_scale (field 11) and
// has a field this build does not know. Reading it says so; the same recording with this
// build's schema says nothing.
std::string WriteValveRecording(const fs::path& path, bool other_build) {
  gp::FileDescriptorSet set;
  gp::FileDescriptorProto file;
  hexa::rec::ValveCommand::descriptor()->file()->CopyTo(&file);
  if (other_build) {
    for (auto& m : *file.mutable_message_type()) {
      if (m.name() != "ValveCommand") continue;
      auto* fields = m.mutable_field();
      for (int i = 0; i < fields->size(); ++i)
        if (fields->Get(i).name() == "friction_scale") {
          fields->DeleteSubrange(i, 1);
          break;
        }
      gp::FieldDescriptorProto* extra = m.add_field();
      extra->set_name("valve_current_a");
      extra->set_number(40);
      extra->set_type(gp::FieldDescriptorProto::TYPE_DOUBLE);
      extra->set_label(gp::FieldDescriptorProto::LABEL_OPTIONAL);
      // proto3 optional fields come with a synthetic oneof: drop them all, and the other
      // optional fields' proto3_optional mark, which needs its oneof.
      m.clear_oneof_decl();
      for (auto& f : *m.mutable_field()) {
        f.clear_oneof_index();
        f.clear_proto3_optional();
      }
    }
  }
  *set.add_file() = file;
  McapWriter w;
  w.Open(path);
  const uint16_t schema = w.AddSchema("hexa.rec.ValveCommand", "protobuf", set.SerializeAsString());
  const uint16_t channel = w.AddChannel(schema, "hexa_ValveCommand", "protobuf", {});
  hexa::rec::ValveCommand c;
  c.set_leg_id(1);
  c.set_valve_v(5.0);
  w.Write(channel, 1000, 1000, c.SerializeAsString());
  w.Close();
  return path.string();
}

TEST(SchemaCheck, ARecordingFromAnotherBuildIsNamedAndItsFieldsListed) {
  const fs::path dir = TempDir();
  const McapScanResult other =
      ReadRecording(WriteValveRecording(dir / "other.mcap", true), nullptr);
  ASSERT_EQ(other.problems.size(), 1u);
  const std::string& p = other.problems[0];
  EXPECT_NE(p.find("hexa.rec.ValveCommand differs from this build's (recorded by another build)"),
            std::string::npos) << p;
  EXPECT_NE(p.find("not in the recording: friction_scale"), std::string::npos) << p;
  EXPECT_NE(p.find("unknown to this build: valve_current_a"), std::string::npos) << p;
  const McapScanResult same = ReadRecording(WriteValveRecording(dir / "same.mcap", false), nullptr);
  EXPECT_TRUE(same.problems.empty()) << same.problems.front();
}

}  // namespace
