// User trajectory given as rows of absolute platform poses (B frame, angles as in pose.hpp):
// the core's side of a CSV trajectory. Reading and parsing the file, with line-numbered
// messages and limits, is config/'s job (hexa/config/csv_trajectory.hpp); the core never opens
// a file. The rows are interpolated by a clamped cubic spline per component (zero velocity at
// the first and last row, C2 inside), held constant outside its span, so that the blend in and
// the stop out of a Trajectory stay continuous.
#pragma once

#include <memory>
#include <vector>

#include "hexa/core/trajectory.hpp"

namespace hexa {

class CsvMotion final : public ReferenceMotion {
 public:
  // Rows: time_s and pose vectors. Throws std::invalid_argument if there are fewer than two
  // rows, a value is not finite, or the times are not strictly increasing.
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

// Full trajectory: blend from `start_xyz_rpy` to the first row, the rows, stop at `rest`
// (pass the last row's pose to stay there).
Trajectory MakeCsvTrajectory(std::shared_ptr<const CsvMotion> motion,
                             const Vector6d& start_xyz_rpy, const Vector6d& rest_xyz_rpy,
                             const TrajectoryTiming& timing);

}  // namespace hexa
