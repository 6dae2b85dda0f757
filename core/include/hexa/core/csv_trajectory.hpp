// User trajectory from a CSV file (docs/task_space.md, "CSV format").
//
//   time_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad      <- header, exactly these names
//   0.0,0.0,0.0,0.45,0.0,0.0,0.0
//   ...
//
// Absolute platform poses (B frame, angles as in pose.hpp), times strictly increasing, at
// least two rows, every value finite, |pitch| < 1.5 rad (roll/pitch/yaw are singular at
// 90 deg). Blank lines and lines starting with '#' are ignored; fields may carry spaces
// around them; CRLF line ends are accepted. The rows are interpolated by a clamped cubic
// spline per component (zero velocity at the first and last row, C2 inside), held constant
// outside its span, so that the blend in and the stop out of a Trajectory stay continuous.
//
// Errors (thrown as CsvTrajectoryError, before any motion) name the file and the 1-based
// line: "<file>:<line>: <what>".
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hexa/core/trajectory.hpp"

namespace hexa {

inline constexpr const char* kCsvTrajectoryHeader =
    "time_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad";
inline constexpr double kCsvMaxAbsPitch_rad = 1.5;

class CsvTrajectoryError : public std::runtime_error {
 public:
  CsvTrajectoryError(const std::string& message, int line)
      : std::runtime_error(message), line_(line) {}
  int line() const { return line_; }  // 1-based line of the offending row, 0 if no line

 private:
  int line_;
};

class CsvMotion final : public ReferenceMotion {
 public:
  // Rows: time_s and pose vectors; validated by the parser. Throws std::invalid_argument if
  // the times are not strictly increasing or there are fewer than two rows.
  CsvMotion(std::vector<double> time_s, std::vector<Vector6d> xyz_rpy);
  void Evaluate(double tau_s, PoseVectorState& state) const noexcept override;
  double start_time_s() const noexcept override { return time_s_.front(); }
  double end_time_s() const noexcept override { return time_s_.back(); }
  std::size_t size() const { return time_s_.size(); }
  const std::vector<double>& time_s() const { return time_s_; }
  const std::vector<Vector6d>& xyz_rpy() const { return q_; }

 private:
  std::vector<double> time_s_;
  std::vector<Vector6d> q_;
  std::vector<Vector6d> second_derivative_;  // spline moments M_i
};

// Parses CSV text; `name` is used in messages (normally the file path).
std::shared_ptr<const CsvMotion> ParseCsvTrajectory(std::string_view text, std::string_view name);
// Reads and parses a file. "<path>:0: cannot open file" if it cannot be read.
std::shared_ptr<const CsvMotion> LoadCsvTrajectory(const std::string& path);

// Full trajectory: blend from `start_xyz_rpy` to the first row, the rows, stop at `rest`
// (pass the last row's pose to stay there).
Trajectory MakeCsvTrajectory(std::shared_ptr<const CsvMotion> motion,
                             const Vector6d& start_xyz_rpy, const Vector6d& rest_xyz_rpy,
                             const TrajectoryTiming& timing);

}  // namespace hexa
