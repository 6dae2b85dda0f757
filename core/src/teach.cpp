// Teach and replay (see teach.hpp, docs/operate.md).
#include "hexa/core/teach.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "hexa/core/csv_trajectory.hpp"
#include "hexa/core/math_constants.hpp"
#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

constexpr double kMaxSpan_s = 1800.0;   // the CSV's limits (config/csv_trajectory.hpp)
constexpr double kMaxAbsPitch_rad = 1.5;

TeachResult Refuse(const char* format, double a, double b = 0.0, double c = 0.0) {
  TeachResult r;
  char text[200];
  std::snprintf(text, sizeof(text), format, a, b, c);
  r.message = text;
  return r;
}

double Unwrap(double previous, double angle) {
  return previous + std::remainder(angle - previous, 2.0 * kPi);
}

}  // namespace

void TeachConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.InClosed("teach.row_period_s", row_period_s, 0.001, 1.0, "row period");
  c.InClosed("teach.smoothing_window_s", smoothing_window_s, 0.0, 2.0, "smoothing window");
  c.InClosed("teach.max_gap_s", max_gap_s, 0.001, 10.0, "largest gap");
  ThrowIfIssues(issues, "teach");
}

TeachResult TrajectoryRowsFromSamples(const std::vector<TeachSample>& samples,
                                      const TeachConfig& config) {
  config.Validate();
  std::vector<double> t;
  std::vector<Vector6d> q;
  t.reserve(samples.size());
  q.reserve(samples.size());
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const TeachSample& s = samples[i];
    if (!std::isfinite(s.time_s) || !s.pose.p_BP_B_m.allFinite() || !s.pose.R_BP.allFinite()) {
      ++dropped;
      continue;
    }
    if (!t.empty() && !(s.time_s > t.back())) {
      return Refuse("sample %.0f: time %.6f s is not after the previous sample's %.6f s",
                    static_cast<double>(i), s.time_s, t.back());
    }
    if (!t.empty() && s.time_s - t.back() > config.max_gap_s) {
      return Refuse("a gap of %.3f s in the recording at %.3f s (largest allowed %.3f s)",
                    s.time_s - t.back(), t.back(), config.max_gap_s);
    }
    Vector6d v = VectorFromPose(s.pose);
    if (!(std::abs(v[4]) < kMaxAbsPitch_rad)) {
      return Refuse("at %.3f s: pitch %.4f rad is beyond the CSV's limit %.1f rad", s.time_s, v[4],
                    kMaxAbsPitch_rad);
    }
    if (!q.empty()) {
      v[3] = Unwrap(q.back()[3], v[3]);
      v[5] = Unwrap(q.back()[5], v[5]);
    }
    if (!(std::abs(v[3]) <= kPi && std::abs(v[5]) <= kPi)) {
      return Refuse("at %.3f s: roll %.4f / yaw %.4f rad turned beyond +-pi", s.time_s, v[3], v[5]);
    }
    t.push_back(s.time_s);
    q.push_back(v);
  }
  if (t.size() < 2) {
    return Refuse("%.0f usable sample(s) (%.0f not finite): at least 2 are needed",
                  static_cast<double>(t.size()), static_cast<double>(dropped));
  }
  if (t.back() - t.front() > kMaxSpan_s) {
    return Refuse("the recording spans %.1f s, more than a CSV trajectory may (%.0f s)",
                  t.back() - t.front(), kMaxSpan_s);
  }
  // Centred moving average over +-window/2 (two pointers: O(n)).
  std::vector<Vector6d> smooth(q.size());
  const double half = 0.5 * config.smoothing_window_s;
  std::size_t lo = 0, hi = 0;
  Vector6d sum = Vector6d::Zero();
  for (std::size_t i = 0; i < q.size(); ++i) {
    while (hi < q.size() && t[hi] <= t[i] + half) sum += q[hi++];
    while (t[lo] < t[i] - half) sum -= q[lo++];
    smooth[i] = sum / static_cast<double>(hi - lo);
  }
  TeachResult result;
  result.dropped_not_finite = dropped;
  const double span = t.back() - t.front();
  const std::size_t rows = static_cast<std::size_t>(std::floor(span / config.row_period_s + 1e-9));
  result.time_s.reserve(rows + 2);
  result.xyz_rpy.reserve(rows + 2);
  std::size_t k = 0;
  for (std::size_t r = 0; r <= rows; ++r) {
    const double time = t.front() + static_cast<double>(r) * config.row_period_s;
    while (k + 2 < t.size() && t[k + 1] <= time) ++k;
    const double w = std::clamp((time - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0);
    result.time_s.push_back(time - t.front());
    result.xyz_rpy.push_back((1.0 - w) * smooth[k] + w * smooth[k + 1]);
  }
  // The last sample as the last row unless a row already sits within 1 ms of it (the CSV's
  // spacing rule).
  if (span - result.time_s.back() >= 1e-3) {
    result.time_s.push_back(span);
    result.xyz_rpy.push_back(smooth.back());
  }
  result.ok = true;
  return result;
}

double EasedBlendDuration(const Vector6d& from_xyz_rpy, const Vector6d& to_xyz_rpy,
                          const EaseLimits& limits) {
  const double h_lin = (to_xyz_rpy.head<3>() - from_xyz_rpy.head<3>()).norm();
  const double h_ang = (to_xyz_rpy.tail<3>() - from_xyz_rpy.tail<3>()).norm();
  const double peak_acceleration = 10.0 / std::sqrt(3.0);  // max sigma''
  double T = limits.min_duration_s;
  T = std::max(T, 1.875 * h_lin / limits.max_speed_m_s);
  T = std::max(T, std::sqrt(peak_acceleration * h_lin / limits.max_acceleration_m_s2));
  T = std::max(T, std::cbrt(60.0 * h_lin / limits.max_jerk_m_s3));
  T = std::max(T, 1.875 * h_ang / limits.max_angular_speed_rad_s);
  T = std::max(T, std::sqrt(peak_acceleration * h_ang / limits.max_angular_acceleration_rad_s2));
  T = std::max(T, std::cbrt(60.0 * h_ang / limits.max_angular_jerk_rad_s3));
  return T;
}

Trajectory MakeReplayTrajectory(const std::vector<double>& time_s,
                                const std::vector<Vector6d>& xyz_rpy,
                                const Vector6d& current_xyz_rpy, const TrajectoryTiming& timing,
                                const EaseLimits& limits) {
  auto motion = std::make_shared<const CsvMotion>(time_s, xyz_rpy);
  TrajectoryTiming eased = timing;
  eased.blend_duration_s =
      std::max(timing.blend_duration_s, EasedBlendDuration(current_xyz_rpy, xyz_rpy.front(), limits));
  return MakeCsvTrajectory(motion, current_xyz_rpy, xyz_rpy.back(), eased);
}

}  // namespace hexa
