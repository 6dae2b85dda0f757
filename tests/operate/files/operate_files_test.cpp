// Files of the operator modes: the washout parameter file (deploy/cueing/washout.textproto),
// the trajectory CSV written from taught rows and read back by the CSV parser, and the washout's
// worked examples as trajectory CSVs, checked for feasibility.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/config/washout_file.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/teach.hpp"
#include "hexa/core/user_frames.hpp"
#include "hexa/core/washout.hpp"

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
  std::printf("%s\n", r.error.c_str());
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

namespace hexa {
namespace {

// The worked examples' cues (as hexa_washout writes them, shipped parameters, pivot 0.3 m above
// the platform) pass the supervisor's feasibility check on the reference rig: they can be run
// with --trajectory and recorded.
TEST(WashoutCue, WorkedExamplesAreFeasibleOnTheReferenceRig) {
  const config::WashoutFileResult params = config::LoadWashoutFile(kDefaultFile);
  ASSERT_TRUE(params.ok) << params.error;
  const RigParams rig = MakeReferenceRig();
  for (const char* name : {"braking", "lane-change"}) {
    WashoutFilter filter(params.config);
    UserFramesConfig frames;
    frames.p_PC_P_m = Eigen::Vector3d(0, 0, 0.3);
    Pose neutral;
    neutral.p_BP_B_m = rig.geometry.home_position_m;
    std::vector<double> time_s;
    std::vector<Vector6d> rows;
    for (int k = 0; k * params.config.period_s <= 12.0; ++k) {
      const double t = k * params.config.period_s;
      WashoutOutput out;
      filter.Update(std::string(name) == "braking" ? BrakingExample(t) : LaneChangeExample(t), out);
      time_s.push_back(t);
      rows.push_back(VectorFromPose(PlatformPoseFromDisplacement(neutral, out.displacement, frames)));
    }
    const auto motion = config::ParseCsvTrajectory(config::FormatCsvTrajectory(time_s, rows), name);
    const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
    const Trajectory trajectory =
        MakeCsvTrajectory(motion, home, home, TimingFrom(SupervisorParams{}));
    const FeasibilityReport report = CheckFeasibility(rig, SupervisorParams{}, trajectory);
    double longest = 0.0;
    for (double l : report.max_length_m) longest = std::max(longest, l);
    std::printf("%s cue: feasible %d, longest leg %.4f m (limit %.4f), fastest leg %.3f m/s\n", name,
                report.feasible, longest, report.envelope.max_length_m,
                *std::max_element(report.max_abs_speed_m_s.begin(), report.max_abs_speed_m_s.end()));
    EXPECT_TRUE(report.feasible) << report.message;
  }
}

}  // namespace
}  // namespace hexa
