// CSV user trajectory: strict parser with line-numbered messages, clamped cubic spline.
#include "hexa/core/csv_trajectory.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace hexa {
namespace {

constexpr std::array<const char*, 7> kColumnNames{"time_s",   "x_m",       "y_m",    "z_m",
                                                  "roll_rad", "pitch_rad", "yaw_rad"};

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = line.find(',', begin);
    if (comma == std::string_view::npos) {
      fields.push_back(Trim(line.substr(begin)));
      return fields;
    }
    fields.push_back(Trim(line.substr(begin, comma - begin)));
    begin = comma + 1;
  }
}

[[noreturn]] void Fail(std::string_view name, int line, const std::string& what) {
  std::ostringstream os;
  os << name << ':' << line << ": " << what;
  throw CsvTrajectoryError(os.str(), line);
}

// Strict number: the whole field must be a decimal floating-point literal (an optional
// leading '+' is accepted; from_chars does not take it).
bool ParseNumber(std::string_view text, double& value) {
  std::string_view digits = text;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  if (digits.empty()) return false;
  const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  return result.ec == std::errc() && result.ptr == digits.data() + digits.size();
}

// Thomas algorithm for the clamped spline moments (diagonally dominant, no pivoting).
std::vector<Vector6d> ClampedSplineMoments(const std::vector<double>& t,
                                           const std::vector<Vector6d>& y) {
  const std::size_t n = t.size();
  std::vector<double> lower(n, 0.0), diag(n, 0.0), upper(n, 0.0);
  std::vector<Vector6d> rhs(n, Vector6d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0) {
      const double h = t[1] - t[0];
      diag[i] = 2.0 * h;
      upper[i] = h;
      rhs[i] = 6.0 * ((y[1] - y[0]) / h);  // f'(t_0) = 0
    } else if (i == n - 1) {
      const double h = t[i] - t[i - 1];
      lower[i] = h;
      diag[i] = 2.0 * h;
      rhs[i] = -6.0 * ((y[i] - y[i - 1]) / h);  // f'(t_n) = 0
    } else {
      const double h0 = t[i] - t[i - 1], h1 = t[i + 1] - t[i];
      lower[i] = h0;
      diag[i] = 2.0 * (h0 + h1);
      upper[i] = h1;
      rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
    }
  }
  for (std::size_t i = 1; i < n; ++i) {
    const double m = lower[i] / diag[i - 1];
    diag[i] -= m * upper[i - 1];
    rhs[i] -= m * rhs[i - 1];
  }
  std::vector<Vector6d> moments(n, Vector6d::Zero());
  moments[n - 1] = rhs[n - 1] / diag[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) {
    moments[i] = (rhs[i] - upper[i] * moments[i + 1]) / diag[i];
  }
  return moments;
}

}  // namespace

CsvMotion::CsvMotion(std::vector<double> time_s, std::vector<Vector6d> xyz_rpy)
    : time_s_(std::move(time_s)), q_(std::move(xyz_rpy)) {
  if (time_s_.size() < 2 || time_s_.size() != q_.size()) {
    throw std::invalid_argument("CsvMotion: need at least two rows of equal count");
  }
  for (std::size_t i = 1; i < time_s_.size(); ++i) {
    if (!(time_s_[i] > time_s_[i - 1])) {
      throw std::invalid_argument("CsvMotion: times must be strictly increasing");
    }
  }
  second_derivative_ = ClampedSplineMoments(time_s_, q_);
}

void CsvMotion::Evaluate(double tau_s, PoseVectorState& state) const noexcept {
  if (tau_s <= time_s_.front() || tau_s >= time_s_.back()) {
    state.q = tau_s <= time_s_.front() ? q_.front() : q_.back();
    state.q_dot.setZero();  // clamped ends: the spline arrives at rest
    state.q_ddot.setZero();
    return;
  }
  // Segment i with t_i <= tau < t_{i+1}; upper_bound is a binary search, no allocation.
  const auto it = std::upper_bound(time_s_.begin(), time_s_.end(), tau_s);
  const std::size_t i = static_cast<std::size_t>(it - time_s_.begin()) - 1;
  const double h = time_s_[i + 1] - time_s_[i];
  const double a = (time_s_[i + 1] - tau_s) / h;
  const double b = 1.0 - a;
  const Vector6d& m0 = second_derivative_[i];
  const Vector6d& m1 = second_derivative_[i + 1];
  state.q = a * q_[i] + b * q_[i + 1] + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * (h * h / 6.0);
  state.q_dot = (q_[i + 1] - q_[i]) / h - ((3.0 * a * a - 1.0) * h / 6.0) * m0 +
                ((3.0 * b * b - 1.0) * h / 6.0) * m1;
  state.q_ddot = a * m0 + b * m1;
}

std::shared_ptr<const CsvMotion> ParseCsvTrajectory(std::string_view text,
                                                    std::string_view name) {
  std::vector<double> times;
  std::vector<Vector6d> poses;
  std::vector<int> row_lines;
  std::vector<std::string_view> time_texts;
  bool header_seen = false;
  int line_number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view raw = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    const std::string_view line = Trim(raw);
    if (line.empty() || line.front() == '#') continue;

    const std::vector<std::string_view> fields = SplitFields(line);
    if (!header_seen) {
      bool ok = fields.size() == kColumnNames.size();
      for (std::size_t c = 0; ok && c < fields.size(); ++c) ok = fields[c] == kColumnNames[c];
      if (!ok) {
        Fail(name, line_number,
             "bad header \"" + std::string(line) + "\", expected \"" + kCsvTrajectoryHeader +
                 "\"");
      }
      header_seen = true;
      continue;
    }
    if (fields.size() != kColumnNames.size()) {
      Fail(name, line_number,
           "expected " + std::to_string(kColumnNames.size()) + " columns, found " +
               std::to_string(fields.size()));
    }
    std::array<double, 7> values{};
    for (std::size_t c = 0; c < fields.size(); ++c) {
      const std::string column = "column " + std::to_string(c + 1) + " (" + kColumnNames[c] + ")";
      if (fields[c].empty()) Fail(name, line_number, column + ": empty value");
      if (!ParseNumber(fields[c], values[c])) {
        Fail(name, line_number, column + ": \"" + std::string(fields[c]) + "\" is not a number");
      }
      if (!std::isfinite(values[c])) {
        Fail(name, line_number, column + ": \"" + std::string(fields[c]) + "\" is not finite");
      }
    }
    if (!times.empty() && !(values[0] > times.back())) {
      Fail(name, line_number,
           "time_s " + std::string(fields[0]) + " is not greater than " +
               std::string(time_texts.back()) + " on line " + std::to_string(row_lines.back()));
    }
    if (std::abs(values[5]) >= kCsvMaxAbsPitch_rad) {
      Fail(name, line_number,
           "pitch_rad " + std::string(fields[5]) +
               " is outside (-1.5, 1.5): roll/pitch/yaw are singular at +-90 deg");
    }
    Vector6d q;
    for (int k = 0; k < 6; ++k) q[k] = values[static_cast<std::size_t>(k) + 1];
    times.push_back(values[0]);
    poses.push_back(q);
    row_lines.push_back(line_number);
    time_texts.push_back(fields[0]);
  }
  if (!header_seen) {
    Fail(name, std::max(line_number, 1),
         std::string("empty file, expected the header \"") + kCsvTrajectoryHeader + "\"");
  }
  if (times.size() < 2) {
    Fail(name, line_number,
         "too short: " + std::to_string(times.size()) +
             " data row(s), at least 2 are required");
  }
  return std::make_shared<const CsvMotion>(std::move(times), std::move(poses));
}

std::shared_ptr<const CsvMotion> LoadCsvTrajectory(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CsvTrajectoryError(path + ":0: cannot open file", 0);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  return ParseCsvTrajectory(text, path);
}

Trajectory MakeCsvTrajectory(std::shared_ptr<const CsvMotion> motion,
                             const Vector6d& start_xyz_rpy, const Vector6d& rest_xyz_rpy,
                             const TrajectoryTiming& timing) {
  return Trajectory(std::move(motion), start_xyz_rpy, rest_xyz_rpy, timing);
}

}  // namespace hexa
