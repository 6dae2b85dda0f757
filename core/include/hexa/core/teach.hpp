// Teach and replay (docs/operate.md "Teach and replay"): measured poses of a recording (the
// supervisor's estimate, or the setpoints of a jog session) turned into the rows of a
// trajectory CSV (docs/trajectories.md "CSV user trajectory"), and the eased start of its
// replay from the platform's current pose. Outside the control cycle: allocates, never opens
// a file (config/ writes the CSV text).
#pragma once

#include <string>
#include <vector>

#include "hexa/core/pose.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {

struct TeachConfig {
  double row_period_s = 0.02;        // rows of the CSV, every 20 ms (>= 1 ms: the CSV's rule)
  double smoothing_window_s = 0.05;  // centred moving average of the measured poses; 0 = off
  double max_gap_s = 0.5;            // samples further apart: a hole in the recording, refused
  // Throws std::invalid_argument naming field, value and limit.
  void Validate() const;
};

struct TeachSample {
  double time_s = 0.0;
  Pose pose;
};

struct TeachResult {
  bool ok = false;
  std::string message;                 // why not, naming the sample and its value
  std::vector<double> time_s;          // from 0, every row_period_s, last = the span
  std::vector<Vector6d> xyz_rpy;       // roll and yaw unwrapped (continuous)
  std::size_t dropped_not_finite = 0;  // samples left out (a NaN estimate)
};

// Steps: drop non-finite samples (counted); refuse fewer than two, times not strictly
// increasing, a gap above max_gap_s, a span above 1800 s, |pitch| >= 1.5 rad or an unwrapped
// |roll|, |yaw| above pi (the CSV's limits); roll / yaw unwrapped; moving average over
// +-window/2 (fewer samples at the ends); resampled linearly every row_period_s from the first
// sample, the last row at the last sample; times shifted to start at 0.
TeachResult TrajectoryRowsFromSamples(const std::vector<TeachSample>& samples,
                                      const TeachConfig& config);

// Limits of the eased start: the blend from the current pose to the first row is the
// minimum-jerk quintic of trajectory.hpp, whose peaks are 1.875 h/T (speed), 5.7735 h/T^2
// (acceleration, 10/sqrt(3)) and 60 h/T^3 (jerk) for a move of h in T. The shortest T
// that keeps |dp| and |d rpy| (norms) within the limits, and at least min_duration_s.
struct EaseLimits {
  double max_speed_m_s = 0.05;
  double max_acceleration_m_s2 = 0.25;
  double max_jerk_m_s3 = 2.5;
  double max_angular_speed_rad_s = 0.2;
  double max_angular_acceleration_rad_s2 = 1.0;
  double max_angular_jerk_rad_s3 = 10.0;
  double min_duration_s = 1.0;
};
double EasedBlendDuration(const Vector6d& from_xyz_rpy, const Vector6d& to_xyz_rpy,
                          const EaseLimits& limits);

// The replay: rows as a CsvMotion, blended in from the current pose over the eased duration
// (at least timing.blend_duration_s), back to rest at its last row. Throws
// std::invalid_argument for invalid rows (CsvMotion's rules).
Trajectory MakeReplayTrajectory(const std::vector<double>& time_s,
                                const std::vector<Vector6d>& xyz_rpy,
                                const Vector6d& current_xyz_rpy, const TrajectoryTiming& timing,
                                const EaseLimits& limits);

}  // namespace hexa
