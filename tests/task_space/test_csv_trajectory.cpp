// CSV user trajectories: every malformed file is rejected with its exact line-numbered
// message; a valid file is interpolated through its rows with continuous velocity.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "hexa/core/csv_trajectory.hpp"
#include "hexa/core/feasibility.hpp"

namespace hexa {
namespace {

const std::string kDir = HEXA_TASK_SPACE_CSV_DIR;
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
               "pitch_rad 1.6 is outside (-1.5, 1.5): roll/pitch/yaw are singular at +-90 deg"}),
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
    EXPECT_EQ(std::string(e.what()), path + ":0: cannot open file");
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

}  // namespace
}  // namespace hexa
