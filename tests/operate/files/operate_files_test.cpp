// Files of the operator modes: the washout parameter file (deploy/cueing/washout.textproto) and
// the trajectory CSV written from taught rows, read back by the CSV parser.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/config/washout_file.hpp"
#include "hexa/core/teach.hpp"

namespace hexa {
namespace {

const std::string kDefaultFile = std::string(HEXA_SOURCE_DIR) + "/deploy/cueing/washout.textproto";

// The shipped file and the struct's defaults say the same thing.
TEST(WashoutFile, TheShippedFileLoadsAndEqualsTheDefaults) {
  const config::WashoutFileResult r = config::LoadWashoutFile(kDefaultFile);
  ASSERT_TRUE(r.ok) << r.error;
  const WashoutConfig d;
  EXPECT_EQ(r.config.period_s, d.period_s);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(r.config.translation[i].scale, d.translation[i].scale);
    EXPECT_EQ(r.config.translation[i].frequency_rad_s, d.translation[i].frequency_rad_s);
    EXPECT_EQ(r.config.translation[i].break_frequency_rad_s, d.translation[i].break_frequency_rad_s);
    EXPECT_EQ(r.config.translation[i].displacement_limit_m, d.translation[i].displacement_limit_m);
    EXPECT_EQ(r.config.rotation[i].frequency_rad_s, d.rotation[i].frequency_rad_s);
    EXPECT_EQ(r.config.rotation[i].angle_limit_rad, d.rotation[i].angle_limit_rad);
  }
  EXPECT_EQ(r.config.tilt.rate_limit_rad_s, d.tilt.rate_limit_rad_s);
  EXPECT_EQ(r.config.tilt.angle_limit_rad, d.tilt.angle_limit_rad);
}

std::string ShippedText() {
  std::string text;
  FILE* f = std::fopen(kDefaultFile.c_str(), "rb");
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), f)) > 0) text.append(buffer, n);
  std::fclose(f);
  return text;
}

TEST(WashoutFile, AnOutOfRangeValueIsNamedWithItsLine) {
  std::string text = ShippedText();
  const std::string from = "rate_limit_rad_s: 0.0524";
  text.replace(text.find(from), from.size(), "rate_limit_rad_s: 2");
  const config::WashoutFileResult r = config::ParseWashoutFile(text, "w.textproto");
  ASSERT_FALSE(r.ok);
  ASSERT_EQ(r.issues.size(), 1u);
  EXPECT_EQ(r.issues[0].field, "tilt.rate_limit_rad_s");
  EXPECT_EQ(r.issues[0].line, 17);  // the tilt line of the shipped file
  EXPECT_NE(r.error.find("tilt rate limit is out of range"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("limit [0.0001, 1]"), std::string::npos) << r.error;
}

TEST(WashoutFile, AMissingFieldAndAnUnknownOneAreRefused) {
  std::string text = ShippedText();
  const std::string from = "damping: 1.0 rate_limit_rad_s";
  text.replace(text.find(from), from.size(), "rate_limit_rad_s");
  config::WashoutFileResult r = config::ParseWashoutFile(text, "w.textproto");
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.error.find("required field 'damping' is missing from block 'tilt'"),
            std::string::npos) << r.error;
  r = config::ParseWashoutFile("period_s: 0.005\nwashout_gain: 2\n", "w.textproto");
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.error.find("washout_gain"), std::string::npos) << r.error;
  EXPECT_FALSE(config::LoadWashoutFile("/nonexistent/w.textproto").ok);
}

TEST(TeachCsv, TaughtRowsWriteAndReadBackExactly) {
  std::vector<TeachSample> samples;
  for (int k = 0; k <= 400; ++k) {
    Vector6d v;
    v << 0.02 * std::sin(k * 0.01), 0.001 * k / 400.0, 0.45, 0.0, 0.03 * std::cos(k * 0.02), 0.1;
    samples.push_back({k * 0.005, PoseFromVector(v)});
  }
  const TeachResult rows = TrajectoryRowsFromSamples(samples, TeachConfig{});
  ASSERT_TRUE(rows.ok) << rows.message;
  const std::string text = config::FormatCsvTrajectory(rows.time_s, rows.xyz_rpy,
                                                       "taught from a test\nsecond line");
  EXPECT_EQ(text.rfind("# taught from a test\n# second line\ntime_s,x_m,", 0), 0u) << text.substr(0, 80);
  const auto motion = config::ParseCsvTrajectory(text, "taught.csv");
  ASSERT_EQ(motion->size(), rows.time_s.size());
  for (std::size_t i = 0; i < rows.time_s.size(); ++i) {
    EXPECT_EQ(motion->time_s()[i], rows.time_s[i]);
    EXPECT_EQ(motion->xyz_rpy()[i], rows.xyz_rpy[i]);
  }
}

}  // namespace
}  // namespace hexa
