// Trajectory CSV text from rows (see csv_trajectory.hpp, docs/trajectories.md "CSV user
// trajectory"): the writing side of ParseCsvTrajectory.
#include <sstream>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/core/param_checks.hpp"

namespace hexa::config {

std::string FormatCsvTrajectory(const std::vector<double>& time_s,
                                const std::vector<Vector6d>& xyz_rpy, const std::string& comment) {
  std::ostringstream out;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
  out << kCsvTrajectoryHeader << "\n";
  for (std::size_t i = 0; i < time_s.size() && i < xyz_rpy.size(); ++i) {
    out << FormatParam(time_s[i]);
    for (int k = 0; k < 6; ++k) out << "," << FormatParam(xyz_rpy[i][k]);
    out << "\n";
  }
  return out.str();
}

}  // namespace hexa::config
