// hexa_washout: runs the classical washout filter (docs/motion_stream.md "Motion cueing") on a
// vehicle motion (a worked example, or a CSV of accelerations and rates) and writes the
// platform's cue as a trajectory CSV, so that the cue can be run, recorded and viewed with
// hexa_session --trajectory FILE.csv. Prints the cue's peaks.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/config/washout_file.hpp"
#include "hexa/core/math_constants.hpp"
#include "hexa/core/user_frames.hpp"
#include "hexa/core/washout.hpp"
#include "hexa/services/cli.hpp"

namespace {

constexpr const char* kVehicleHeader = "time_s,ax_m_s2,ay_m_s2,az_m_s2,wx_rad_s,wy_rad_s,wz_rad_s";

// Vehicle rows: time_s and the six inputs, held between rows (zero-order hold).
bool ReadVehicleCsv(const std::string& path, std::vector<double>& time_s,
                    std::vector<hexa::Vector6d>& rows, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open";
    return false;
  }
  std::string line;
  int number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      if (line != kVehicleHeader) {
        error = path + ":" + std::to_string(number) + ": header must be " + kVehicleHeader;
        return false;
      }
      header = true;
      continue;
    }
    std::istringstream fields(line);
    std::string field;
    std::vector<double> values;
    while (std::getline(fields, field, ',')) {
      char* end = nullptr;
      const double v = std::strtod(field.c_str(), &end);
      if (end == field.c_str() || !std::isfinite(v)) {
        error = path + ":" + std::to_string(number) + ": '" + field.substr(0, 32) + "' is not a finite number";
        return false;
      }
      values.push_back(v);
    }
    if (values.size() != 7) {
      error = path + ":" + std::to_string(number) + ": 7 values expected, " + std::to_string(values.size()) + " found";
      return false;
    }
    if (!time_s.empty() && !(values[0] > time_s.back())) {
      error = path + ":" + std::to_string(number) + ": time_s is not increasing";
      return false;
    }
    time_s.push_back(values[0]);
    hexa::Vector6d r;
    for (int k = 0; k < 6; ++k) r[k] = values[k + 1];
    rows.push_back(r);
  }
  if (time_s.empty()) error = path + ": no rows";
  return !time_s.empty();
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_washout",
                        "Runs the classical washout filter on a vehicle motion and writes the "
                        "platform cue as a trajectory CSV (run it with --trajectory FILE.csv).");
  cli.AddOption("params", "file", "washout parameter file (protobuf text)",
                std::string(HEXA_SOURCE_DIR) + "/deploy/cueing/washout.textproto");
  cli.AddChoice("example", {"braking", "lane-change", "none"},
                "a worked example of docs/operate.md as the vehicle motion", "braking");
  cli.AddOption("vehicle-csv", "file", std::string("vehicle motion instead of an example: ") + kVehicleHeader);
  cli.AddOption("duration-s", "s", "how long to run the filter", "12");
  cli.AddOption("home-z-m", "m", "neutral height of the platform origin", "0.45");
  cli.AddOption("pivot-z-m", "m", "pivot above the platform origin (e.g. the occupant's head)", "0");
  cli.AddOption("output", "file.csv", "the trajectory CSV to write (none: print the peaks only)");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  auto duration = cli.GetDouble("duration-s", 0.01, 1800.0);
  auto home_z = cli.GetDouble("home-z-m", 0.0, 10.0);
  auto pivot_z = cli.GetDouble("pivot-z-m", -0.5, 0.5);
  if (!duration || !home_z || !pivot_z) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  const hexa::config::WashoutFileResult params = hexa::config::LoadWashoutFile(cli.Get("params"));
  if (!params.ok) {
    std::fprintf(stderr, "%s\n", params.error.c_str());
    return 1;
  }
  std::vector<double> vehicle_t;
  std::vector<hexa::Vector6d> vehicle;
  if (cli.Has("vehicle-csv")) {
    std::string error;
    if (!ReadVehicleCsv(cli.Get("vehicle-csv"), vehicle_t, vehicle, error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
  } else if (cli.Get("example") == "none") {
    std::fprintf(stderr, "error: give --example or --vehicle-csv\n");
    return 2;
  }
  hexa::WashoutFilter filter(params.config);
  hexa::UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(0, 0, *pivot_z);
  hexa::Pose neutral;
  neutral.p_BP_B_m = Eigen::Vector3d(0, 0, *home_z);
  const double T = params.config.period_s;
  std::vector<double> time_s;
  std::vector<hexa::Vector6d> rows;
  hexa::Vector6d peak = hexa::Vector6d::Zero();
  double peak_tilt_rate = 0.0, rate_limited_s = 0.0;
  std::size_t v = 0;
  for (long k = 0; k * T <= *duration + 1e-12; ++k) {
    const double t = k * T;
    hexa::WashoutInput in;
    if (!vehicle_t.empty()) {
      while (v + 1 < vehicle_t.size() && vehicle_t[v + 1] <= t) ++v;
      if (t >= vehicle_t[v]) {
        in.acceleration_m_s2 = vehicle[v].head<3>();
        in.angular_rate_rad_s = vehicle[v].tail<3>();
      }
    } else {
      in = cli.Get("example") == "braking" ? hexa::BrakingExample(t) : hexa::LaneChangeExample(t);
    }
    hexa::WashoutOutput out;
    filter.Update(in, out);
    peak = peak.cwiseMax(out.displacement.cwiseAbs());
    peak_tilt_rate = std::max(peak_tilt_rate, out.tilt_rate_rad_s.cwiseAbs().maxCoeff());
    if (out.tilt_rate_limited) rate_limited_s += T;
    time_s.push_back(t);
    rows.push_back(hexa::VectorFromPose(hexa::PlatformPoseFromDisplacement(neutral, out.displacement, frames)));
  }
  const double deg = 180.0 / hexa::kPi;
  std::printf("hexa_washout: %.2f s: peak x %.1f y %.1f z %.1f mm, roll %.2f pitch %.2f yaw %.2f deg; "
              "tilt rate peak %.2f deg/s (limit %.2f), rate-limited %.2f s\n",
              time_s.back(), peak[0] * 1e3, peak[1] * 1e3, peak[2] * 1e3, peak[3] * deg,
              peak[4] * deg, peak[5] * deg, peak_tilt_rate * deg,
              params.config.tilt.rate_limit_rad_s * deg, rate_limited_s);
  if (cli.Has("output")) {
    std::ofstream out(cli.Get("output"), std::ios::binary);
    out << hexa::config::FormatCsvTrajectory(
        time_s, rows, "washout cue by hexa_washout (" + cli.Get("params") + ", " +
                          (cli.Has("vehicle-csv") ? cli.Get("vehicle-csv") : cli.Get("example")) + ")");
    if (!out) {
      std::fprintf(stderr, "error: cannot write %s\n", cli.Get("output").c_str());
      return 1;
    }
  }
  return 0;
}
