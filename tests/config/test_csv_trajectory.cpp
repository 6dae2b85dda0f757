// CSV user trajectories (config/, the core gets the rows): every malformed or out-of-limit file
// is rejected with its exact line-numbered message naming value and limit; messages stay
// bounded and valid UTF-8 whatever the file holds; a valid file is interpolated through its
// rows with continuous velocity; no accepted CSV makes the feasibility check run unbounded.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/supervisor.hpp"

namespace hexa::config {
namespace {

const std::string kDir = HEXA_CONFIG_TEST_DIR "/csv";
const std::string kHeader = "time_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad";

struct BadCsv {
  const char* file;
  int line;
  std::string what;
};

class MalformedCsv : public ::testing::TestWithParam<BadCsv> {};

TEST_P(MalformedCsv, RejectedWithFileLineAndReason) {
  const BadCsv& c = GetParam();
  const std::string path = kDir + "/" + c.file;
  try {
    LoadCsvTrajectory(path);
    FAIL() << path << " was accepted";
  } catch (const CsvTrajectoryError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":" + std::to_string(c.line) + ": " + c.what);
    EXPECT_EQ(e.line(), c.line);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Files, MalformedCsv,
    ::testing::Values(
        BadCsv{"empty.csv", 1, "empty file, expected the header \"" + kHeader + "\""},
        BadCsv{"comments_only.csv", 2, "empty file, expected the header \"" + kHeader + "\""},
        BadCsv{"bad_header_name.csv", 1,
               "bad header \"time,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad\", expected \"" +
                   kHeader + "\""},
        BadCsv{"bad_header_missing_column.csv", 1,
               "bad header \"time_s,x_m,y_m,z_m,roll_rad,pitch_rad\", expected \"" + kHeader +
                   "\""},
        BadCsv{"wrong_column_count.csv", 4, "expected 7 columns, found 6"},
        BadCsv{"extra_column.csv", 3, "expected 7 columns, found 8"},
        BadCsv{"non_numeric.csv", 3, "column 2 (x_m): \"abc\" is not a number"},
        BadCsv{"trailing_garbage.csv", 3, "column 4 (z_m): \"0.45x\" is not a number"},
        BadCsv{"empty_value.csv", 3, "column 3 (y_m): empty value"},
        BadCsv{"nan_value.csv", 3, "column 5 (roll_rad): \"nan\" is not finite"},
        BadCsv{"inf_value.csv", 3, "column 7 (yaw_rad): \"-inf\" is not finite"},
        BadCsv{"time_decreasing.csv", 4, "time_s 0.4 is not greater than 0.5 on line 3"},
        BadCsv{"time_repeated.csv", 5, "time_s 0.5 is not greater than 0.5 on line 4"},
        BadCsv{"header_only.csv", 1, "too short: 0 data row(s), at least 2 are required"},
        BadCsv{"one_row.csv", 2, "too short: 1 data row(s), at least 2 are required"},
        BadCsv{"pitch_out_of_range.csv", 3,
               "pitch_rad 1.6 is outside (-1.5, 1.5): roll/pitch/yaw are singular at +-90 deg"},
        BadCsv{"span_1e9.csv", 3,
               "time_s 1e9 is 1000000000 s after the first row (line 2): a CSV trajectory may "
               "span at most 1800 s"},
        BadCsv{"spacing_below_tick.csv", 4,
               "time_s 0.0015 is only 0.0005 s after 0.001 on line 3: rows must be at least "
               "0.001 s (one plant tick) apart"},
        BadCsv{"position_out_of_range.csv", 3, "x_m 150 is outside [-100, 100] m"},
        BadCsv{"roll_out_of_range.csv", 3, "roll_rad 4 is outside [-pi, pi] rad"},
        BadCsv{"time_out_of_range.csv", 2, "time_s 2e6 is outside [-1000000, 1000000] s"}),
    [](const ::testing::TestParamInfo<BadCsv>& info) {
      std::string name = info.param.file;
      return name.substr(0, name.size() - 4);
    });

TEST(CsvTrajectory, MissingFileNamed) {
  const std::string path = kDir + "/does_not_exist.csv";
  try {
    LoadCsvTrajectory(path);
    FAIL();
  } catch (const CsvTrajectoryError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":0: cannot open file: No such file or directory");
  }
}

TEST(CsvTrajectory, ValidFileInterpolatesThroughRowsWithContinuousVelocity) {
  const auto motion = LoadCsvTrajectory(kDir + "/valid.csv");
  ASSERT_EQ(motion->size(), 41u);
  EXPECT_DOUBLE_EQ(motion->start_time_s(), 0.0);
  EXPECT_NEAR(motion->end_time_s(), 4.0, 1e-12);
  PoseVectorState s;
  // The spline passes through every row.
  for (std::size_t i = 1; i + 1 < motion->size(); ++i) {
    motion->Evaluate(motion->time_s()[i], s);
    EXPECT_LT((s.q - motion->xyz_rpy()[i]).cwiseAbs().maxCoeff(), 1e-12) << "row " << i;
  }
  // Zero velocity at both ends (clamped spline), so holding the end poses is C1.
  motion->Evaluate(1e-9, s);
  EXPECT_LT(s.q_dot.cwiseAbs().maxCoeff(), 1e-6);
  motion->Evaluate(4.0 - 1e-9, s);
  EXPECT_LT(s.q_dot.cwiseAbs().maxCoeff(), 1e-6);
  // Velocity is the derivative of position and continuous across knots.
  const double h = 1e-6;
  for (double t = 0.05; t < 3.95; t += 0.0371) {
    PoseVectorState a, b, c;
    motion->Evaluate(t - h, a);
    motion->Evaluate(t, b);
    motion->Evaluate(t + h, c);
    EXPECT_LT(((c.q - a.q) / (2 * h) - b.q_dot).cwiseAbs().maxCoeff(), 1e-6) << t;
    EXPECT_LT(((c.q_dot - a.q_dot) / (2 * h) - b.q_ddot).cwiseAbs().maxCoeff(), 1e-4) << t;
  }
  for (double knot : {0.1, 1.0, 2.3, 3.9}) {
    PoseVectorState left, right;
    motion->Evaluate(knot - 1e-9, left);
    motion->Evaluate(knot + 1e-9, right);
    EXPECT_LT((left.q_dot - right.q_dot).cwiseAbs().maxCoeff(), 1e-6) << knot;
    EXPECT_LT((left.q_ddot - right.q_ddot).cwiseAbs().maxCoeff(), 1e-5) << knot;
  }
}

TEST(CsvTrajectory, ValidFileMakesAFeasibleTrajectoryThatBlendsAndReturnsHome) {
  const RigParams rig = MakeReferenceRig();
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  const Trajectory traj =
      MakeCsvTrajectory(LoadCsvTrajectory(kDir + "/valid.csv"), home, home, TrajectoryTiming{});
  EXPECT_NEAR(traj.tracking_end_s() - traj.tracking_start_s(), 4.0, 1e-12);
  const FeasibilityReport report = CheckFeasibility(rig, SupervisorParams{}, traj);
  EXPECT_TRUE(report.feasible) << report.message;
  TrajectorySample end;
  traj.Evaluate(traj.duration_s(), end);
  EXPECT_LT((end.vector.q - home).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(end.vector.q_dot.cwiseAbs().maxCoeff(), 1e-12);
}

std::string WriteTemp(const std::string& name, const std::string& bytes) {
  const std::string path = std::string(HEXA_CONFIG_TEST_TMP_DIR) + "/" + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

bool ValidUtf8NoControls(const std::string& s) {
  // Structural check only (the sanitiser has its own tests): no byte >= 0xF8, no control
  // character but tab.
  for (unsigned char c : s) {
    if (c >= 0xF8 || (c < 0x20 && c != '\t') || c == 0x7F) return false;
  }
  return true;
}

// Random bytes in a CSV must not end up in FaultEvent.detail, log lines and the recording.
TEST(CsvTrajectory, RandomBytesGiveABoundedValidMessage) {
  std::mt19937_64 rng(12);
  for (int k = 0; k < 200; ++k) {
    std::string bytes(1 + rng() % 4000, '\0');
    for (auto& c : bytes) c = static_cast<char>(rng() & 0xff);
    if (k % 2 == 0) bytes = std::string(kCsvTrajectoryHeader) + "\n0,0,0,0.45,0,0,0\n1," + bytes;
    try {
      ParseCsvTrajectory(bytes, "random.csv");
      FAIL() << "random bytes accepted";
    } catch (const CsvTrajectoryError& e) {
      const std::string what = e.what();
      EXPECT_LT(what.size(), 400u) << what;
      EXPECT_TRUE(ValidUtf8NoControls(what)) << ::testing::PrintToString(what);
      EXPECT_EQ(what.rfind("random.csv:", 0), 0u) << what;
    }
  }
}

TEST(CsvTrajectory, HugeValueIsNotEchoed) {
  const std::string huge(10 * 1024 * 1024, '7');
  for (const std::string& text :
       {std::string(kCsvTrajectoryHeader) + "\n0,0,0,0.45,0,0,0\n1," + huge + "x,0,0.45,0,0,0\n",
        huge + "\n"}) {
    try {
      ParseCsvTrajectory(text, "huge.csv");
      FAIL();
    } catch (const CsvTrajectoryError& e) {
      EXPECT_LT(std::string(e.what()).size(), 300u);
      EXPECT_NE(std::string(e.what()).find("[...]"), std::string::npos) << e.what();
    }
  }
}

TEST(CsvTrajectory, FileSizeAndRowCountAreLimited) {
  CsvTrajectoryLimits limits;
  limits.max_file_bytes = 100;
  const std::string big = std::string(kCsvTrajectoryHeader) + "\n" + std::string(200, '#') + "\n";
  const std::string path = WriteTemp("big.csv", big);
  try {
    LoadCsvTrajectory(path, limits);
    FAIL();
  } catch (const CsvTrajectoryError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":0: file is " + std::to_string(big.size()) +
                                         " bytes, more than the limit of 100 bytes");
  }
  std::filesystem::remove(path);
  CsvTrajectoryLimits rows;
  rows.max_rows = 3;
  std::string text = std::string(kCsvTrajectoryHeader) + "\n";
  for (int i = 0; i < 5; ++i) text += std::to_string(i) + ",0,0,0.45,0,0,0\n";
  try {
    ParseCsvTrajectory(text, "rows.csv", rows);
    FAIL();
  } catch (const CsvTrajectoryError& e) {
    EXPECT_EQ(std::string(e.what()), "rows.csv:5: more than 3 data rows (limit of a CSV trajectory)");
  }
  // The limits admit a trajectory that spans the whole 1800 s.
  const auto ok = ParseCsvTrajectory(std::string(kCsvTrajectoryHeader) +
                                     "\n0,0,0,0.45,0,0,0\n1800,0,0,0.45,0,0,0\n", "long.csv");
  EXPECT_EQ(ok->end_time_s(), 1800.0);
}

// A CSV spanning 1e9 s must not hang the supervisor in its feasibility check. Whatever rows
// reach the core (even built in code, bypassing the parser), the check is bounded.
TEST(CsvTrajectory, FeasibilityOfAnyTrajectoryIsBounded) {
  const RigParams rig = MakeReferenceRig();
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  const auto rows = std::make_shared<const CsvMotion>(std::vector<double>{0.0, 1e9},
                                                      std::vector<Vector6d>{home, home});
  const auto t0 = std::chrono::steady_clock::now();
  const FeasibilityReport r = CheckFeasibility(
      rig, SupervisorParams{}, MakeCsvTrajectory(rows, home, home, TrajectoryTiming{}));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_FALSE(r.feasible);
  EXPECT_EQ(r.violation, FeasibilityViolation::kTooLong);
  EXPECT_EQ(r.message, "trajectory lasts 1e+09 s (blend, motion and stop), more than the limit "
                       "of 2000 s that can be checked before motion");
  // ... and the supervisor turns it into HOLD with that message.
  Supervisor sup(rig, SupervisorParams{});
  const StartRequest request = sup.PrepareRowsStart(rows);
  EXPECT_FALSE(request.feasibility.feasible);
}

}  // namespace
}  // namespace hexa::config
