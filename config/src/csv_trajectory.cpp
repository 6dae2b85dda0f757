// CSV user trajectory: strict parser with line-numbered messages and bounded values; the rows
// go to hexa::CsvMotion (core), which interpolates them.
#include "hexa/config/csv_trajectory.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "hexa/services/text.hpp"

namespace hexa::config {
namespace {

constexpr std::array<const char*, 7> kColumnNames{"time_s",   "x_m",       "y_m",    "z_m",
                                                  "roll_rad", "pitch_rad", "yaw_rad"};
constexpr std::size_t kMaxNameBytes = 512;  // file name as it appears in messages

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

// Splits at commas into `fields` (reused between lines); stops counting past `max_fields`
// (a line of a million commas is not split into a million views).
void SplitFields(std::string_view line, std::size_t max_fields,
                 std::vector<std::string_view>& fields, std::size_t& count) {
  fields.clear();
  count = 0;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = line.find(',', begin);
    const std::string_view field =
        Trim(line.substr(begin, comma == std::string_view::npos ? std::string_view::npos
                                                                : comma - begin));
    if (fields.size() < max_fields) fields.push_back(field);
    ++count;
    if (comma == std::string_view::npos) return;
    begin = comma + 1;
  }
}

std::string Quote(std::string_view s) { return "\"" + text::Excerpt(s) + "\""; }

std::string Num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
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

class Parser {
 public:
  Parser(std::string_view name, const CsvTrajectoryLimits& limits)
      : name_(text::Sanitize(name, kMaxNameBytes)), limits_(limits) {}

  [[noreturn]] void Fail(int line, const std::string& what) const {
    throw CsvTrajectoryError(name_ + ":" + std::to_string(line) + ": " + what, line);
  }

  std::shared_ptr<const CsvMotion> Parse(std::string_view text) {
    bool header_seen = false;
    int line_number = 0;
    std::size_t pos = 0;
    std::vector<std::string_view> fields;
    std::size_t field_count = 0;
    while (pos < text.size()) {
      std::size_t end = text.find('\n', pos);
      if (end == std::string_view::npos) end = text.size();
      const std::string_view line = Trim(text.substr(pos, end - pos));
      pos = end + 1;
      ++line_number;
      if (line.empty() || line.front() == '#') continue;
      SplitFields(line, kColumnNames.size() + 1, fields, field_count);
      if (!header_seen) {
        bool ok = field_count == kColumnNames.size();
        for (std::size_t c = 0; ok && c < fields.size(); ++c) ok = fields[c] == kColumnNames[c];
        if (!ok) {
          Fail(line_number, "bad header " + Quote(line) + ", expected \"" + kCsvTrajectoryHeader + "\"");
        }
        header_seen = true;
        continue;
      }
      if (field_count != kColumnNames.size()) {
        Fail(line_number, "expected " + std::to_string(kColumnNames.size()) + " columns, found " +
                              std::to_string(field_count));
      }
      if (times_.size() >= limits_.max_rows) {
        Fail(line_number, "more than " + std::to_string(limits_.max_rows) +
                              " data rows (limit of a CSV trajectory)");
      }
      Row(line_number, fields);
    }
    if (!header_seen) {
      Fail(std::max(line_number, 1),
           std::string("empty file, expected the header \"") + kCsvTrajectoryHeader + "\"");
    }
    if (times_.size() < 2) {
      Fail(line_number, "too short: " + std::to_string(times_.size()) +
                            " data row(s), at least 2 are required");
    }
    return std::make_shared<const CsvMotion>(std::move(times_), std::move(poses_));
  }

 private:
  void Row(int line, const std::vector<std::string_view>& fields) {
    std::array<double, 7> v{};
    for (std::size_t c = 0; c < kColumnNames.size(); ++c) {
      const std::string column = "column " + std::to_string(c + 1) + " (" + kColumnNames[c] + ")";
      if (fields[c].empty()) Fail(line, column + ": empty value");
      if (!ParseNumber(fields[c], v[c])) Fail(line, column + ": " + Quote(fields[c]) + " is not a number");
      if (!std::isfinite(v[c])) Fail(line, column + ": " + Quote(fields[c]) + " is not finite");
    }
    const std::string t_text = text::Excerpt(fields[0]);
    if (times_.empty() && !(std::abs(v[0]) <= limits_.max_abs_time_s)) {
      // Later rows are bounded through the span limit.
      Fail(line, "time_s " + t_text + " is outside [-" + Num(limits_.max_abs_time_s) + ", " +
                     Num(limits_.max_abs_time_s) + "] s");
    }
    if (!times_.empty()) {
      if (!(v[0] > times_.back())) {
        Fail(line, "time_s " + t_text + " is not greater than " + previous_time_text_ +
                       " on line " + std::to_string(previous_line_));
      }
      const double spacing_s = v[0] - times_.back();
      if (!(spacing_s >= limits_.min_spacing_s * (1.0 - 1e-9))) {
        Fail(line, "time_s " + t_text + " is only " + Num(spacing_s) + " s after " +
                       previous_time_text_ + " on line " + std::to_string(previous_line_) +
                       ": rows must be at least " + Num(limits_.min_spacing_s) +
                       " s (one plant tick) apart");
      }
      const double span_s = v[0] - times_.front();
      if (!(span_s <= limits_.max_span_s)) {
        Fail(line, "time_s " + t_text + " is " + Num(span_s) + " s after the first row (line " +
                       std::to_string(first_line_) + "): a CSV trajectory may span at most " +
                       Num(limits_.max_span_s) + " s");
      }
    } else {
      first_line_ = line;
    }
    for (std::size_t c = 1; c <= 3; ++c) {
      if (!(std::abs(v[c]) <= limits_.max_abs_position_m)) {
        Fail(line, std::string(kColumnNames[c]) + " " + text::Excerpt(fields[c]) +
                       " is outside [-" + Num(limits_.max_abs_position_m) + ", " +
                       Num(limits_.max_abs_position_m) + "] m");
      }
    }
    for (std::size_t c : {std::size_t{4}, std::size_t{6}}) {
      if (!(std::abs(v[c]) <= limits_.max_abs_roll_yaw_rad)) {
        Fail(line, std::string(kColumnNames[c]) + " " + text::Excerpt(fields[c]) +
                       " is outside [-pi, pi] rad");
      }
    }
    if (!(std::abs(v[5]) < limits_.max_abs_pitch_rad)) {
      Fail(line, "pitch_rad " + text::Excerpt(fields[5]) + " is outside (-" +
                     Num(limits_.max_abs_pitch_rad) + ", " + Num(limits_.max_abs_pitch_rad) +
                     "): roll/pitch/yaw are singular at +-90 deg");
    }
    Vector6d q;
    for (int k = 0; k < 6; ++k) q[k] = v[static_cast<std::size_t>(k) + 1];
    times_.push_back(v[0]);
    poses_.push_back(q);
    previous_line_ = line;
    previous_time_text_ = t_text;
  }

  std::string name_;
  const CsvTrajectoryLimits& limits_;
  std::vector<double> times_;
  std::vector<Vector6d> poses_;
  int first_line_ = 0;
  int previous_line_ = 0;
  std::string previous_time_text_;
};

}  // namespace

std::shared_ptr<const CsvMotion> ParseCsvTrajectory(std::string_view text, std::string_view name,
                                                    const CsvTrajectoryLimits& limits) {
  return Parser(name, limits).Parse(text);
}

std::shared_ptr<const CsvMotion> LoadCsvTrajectory(const std::string& path,
                                                   const CsvTrajectoryLimits& limits) {
  const std::string shown = text::Sanitize(path, kMaxNameBytes);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw CsvTrajectoryError(shown + ":0: cannot open file: " + std::strerror(errno), 0);
  }
  if (!S_ISREG(st.st_mode)) throw CsvTrajectoryError(shown + ":0: not a regular file", 0);
  if (static_cast<std::size_t>(st.st_size) > limits.max_file_bytes) {
    throw CsvTrajectoryError(shown + ":0: file is " + std::to_string(st.st_size) +
                                 " bytes, more than the limit of " +
                                 std::to_string(limits.max_file_bytes) + " bytes",
                             0);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CsvTrajectoryError(shown + ":0: cannot open file: " + std::strerror(errno), 0);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw CsvTrajectoryError(shown + ":0: cannot read file", 0);
  const std::string text = buffer.str();
  if (text.size() > limits.max_file_bytes) {  // grew while reading
    throw CsvTrajectoryError(shown + ":0: file is larger than the limit of " +
                                 std::to_string(limits.max_file_bytes) + " bytes",
                             0);
  }
  return ParseCsvTrajectory(text, path, limits);
}

}  // namespace hexa::config
