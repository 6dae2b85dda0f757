// User trajectory from a CSV file (docs/trajectories.md, "CSV user trajectory"): read, parsed and
// validated here, at the edge; the core gets the rows (hexa::CsvMotion) and never opens a file.
//
//   time_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad      <- header, exactly these names
//   0.0,0.0,0.0,0.45,0.0,0.0,0.0
//   ...
//
// Absolute platform poses (B frame, angles as in pose.hpp), at least two rows, every value
// finite. Blank lines and lines starting with '#' are ignored; fields may carry spaces around
// them; CRLF line ends are accepted. Limits (CsvTrajectoryLimits, docs/trajectories.md): file
// size, row count, time span, row spacing, value ranges. They keep every later step bounded:
// the feasibility check samples the whole trajectory at 1 ms inside the supervisor, so a CSV
// spanning 1e9 s used to stall it for hours.
//
// Errors (thrown as CsvTrajectoryError, before any motion) name the file and the 1-based line,
// the value and the limit: "<file>:<line>: <what>". Quoted user text is sanitised and cut
// (hexa/services/text.hpp): a 10 MB field never becomes a 10 MB message.
#pragma once

#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hexa/core/csv_trajectory.hpp"

namespace hexa::config {

inline constexpr const char* kCsvTrajectoryHeader = "time_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad";

struct CsvTrajectoryLimits {
  std::size_t max_file_bytes = 64u << 20;  // 64 MiB: ~800 000 rows of full-precision values
  std::size_t max_rows = 1'000'000;
  // Last minus first time. The supervisor checks feasibility at 1 ms over the whole trajectory
  // (~0.3-1.3 us per sample measured, docs/robustness.md): 1800 s is at most ~2.4 s of checking.
  double max_span_s = 1800.0;
  // Rows closer than one plant tick cannot be followed by a 1 kHz loop (and make the spline's
  // accelerations meaningless).
  double min_spacing_s = 1e-3;
  double max_abs_time_s = 1e6;         // absolute times: keeps the 1 ms spacing exact in a double
  double max_abs_position_m = 100.0;   // sanity bound; the rig's stroke is checked by feasibility
  double max_abs_roll_yaw_rad = 3.14159265358979323846;
  double max_abs_pitch_rad = 1.5;      // roll/pitch/yaw are singular at +-90 deg
};

class CsvTrajectoryError : public std::runtime_error {
 public:
  CsvTrajectoryError(const std::string& message, int line)
      : std::runtime_error(message), line_(line) {}
  int line() const { return line_; }  // 1-based line of the offending row, 0 if no line

 private:
  int line_;
};

// Parses CSV text; `name` is used in messages (normally the file path).
std::shared_ptr<const CsvMotion> ParseCsvTrajectory(std::string_view text, std::string_view name,
                                                    const CsvTrajectoryLimits& limits = {});
// Reads and parses a file. "<path>:0: cannot open file: <reason>" if it cannot be read,
// "<path>:0: file is N bytes, more than the limit M" before reading a huge file.
std::shared_ptr<const CsvMotion> LoadCsvTrajectory(const std::string& path,
                                                   const CsvTrajectoryLimits& limits = {});

// The text of a trajectory CSV (header + one row per pose, every value in the shortest form
// that reads back to the same double), e.g. the rows of a taught recording (core/teach.hpp).
// `comment` (may be empty) becomes '#' lines above the header. ParseCsvTrajectory reads it
// back to the same rows.
std::string FormatCsvTrajectory(const std::vector<double>& time_s,
                                const std::vector<Vector6d>& xyz_rpy,
                                const std::string& comment = {});

}  // namespace hexa::config
