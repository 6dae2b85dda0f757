// The session report written out: report.json, report.md, events.csv, pose.csv and legs.csv
// (the figures ComputeSessionReport found; report.cpp).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <stdexcept>

#include "hexa/recording/report.hpp"
#include "hexa/services/json.hpp"
#include "report_events.hpp"

namespace hexa::recorder {
namespace {

constexpr double kRadToDeg = 57.29577951308232;

std::string Fixed3(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

}  // namespace

namespace {

const char* kAxes[6] = {"x", "y", "z", "roll", "pitch", "yaw"};

// Paper Table 9 (pure motions, the moving axis) and Table 10 (combined), in cm and deg.
bool PaperValue(const std::string& trajectory, int axis, double& value) {
  static const double kTable9[6] = {0.782, 0.841, 0.197, 1.012, 1.346, 1.836};
  static const double kTable10[6] = {0.845, 1.205, 0.296, 1.193, 1.817, 2.433};
  if (trajectory == "combined") {
    value = kTable10[axis];
    return true;
  }
  for (int i = 0; i < 6; ++i) {
    if (trajectory == kAxes[i] && i == axis) {
      value = kTable9[i];
      return true;
    }
  }
  return false;
}

// A number in report.md's text ("%.9g"; a figure that is not finite reads "null", as in
// report.json).
std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// Per-axis figures as report.json writes them: {"x_m": ..., "roll_rad": ...}, or for a
// relative error {"x": ...} with null where the paper gives no figure (a < 0).
json::Value AxisJson(const std::array<double, 6>& a, bool relative) {
  json::Value o = json::Value::object();
  for (int i = 0; i < 6; ++i) {
    const std::string key = std::string(kAxes[i]) + (relative ? "" : (i < 3 ? "_m" : "_rad"));
    o[key] = relative && a[i] < 0 ? json::Value(nullptr) : json::Value(a[i]);
  }
  return o;
}

// `session`: the session facts as report.md states them.
json::Value ReportJson(const SessionReport& r, const std::map<std::string, std::string>& session) {
  json::Value j;
  j["recording"] = r.recording;
  j["session"] = json::Value::object();
  for (const auto& [k, v] : session) j["session"][k] = v;
  j["recording_complete"] = r.complete_file;
  j["final_supervisor_state"] = r.final_supervisor_state;
  j["tracking_pose_samples"] = r.pose_samples_tracking;
  j["recording_lost_samples"] = r.recording_lost_samples;
  j["recording_expected_samples"] = r.recording_expected_samples;
  // Not tracked: no figure (null), never an error of 0.
  const bool tracked = r.pose_samples_tracking > 0;
  auto axes = [&](const std::array<double, 6>& a, bool relative) {
    json::Value o = AxisJson(a, relative);
    if (!tracked)
      for (auto& [key, value] : o.items()) value = nullptr;
    return o;
  };
  auto legs = [&](const std::array<double, 6>& a) {
    return tracked ? json::Value(a) : json::Value(std::vector<std::nullptr_t>(6, nullptr));
  };
  j["rmse_vs_ground_truth"] = axes(r.rmse_vs_truth, false);
  j["relative_error_vs_ground_truth"] = axes(r.relative_vs_truth, true);
  j["rmse_vs_measured_pose"] = axes(r.rmse_vs_measured, false);
  j["relative_error_vs_measured_pose"] = axes(r.relative_vs_measured, true);
  j["leg_length_rmse_m"] = legs(r.leg_length_rmse_m);
  j["leg_length_max_abs_error_m"] = legs(r.leg_length_max_abs_m);
  j["valve_mean_abs_step_v_per_tick"] = r.valve_mean_abs_step_v;
  j["valve_saturated_fraction"] = r.valve_saturated_fraction;
  j["deadline_misses"] = json::Value::object();
  for (const auto& [k, v] : r.deadline_misses) j["deadline_misses"][k] = v;
  j["command_age_bins"] = {"0", "1", "2", "3-7", "8-15", ">=16", "none"};
  j["command_age_per_leg"] = nullptr;
  if (r.command_age_recorded) j["command_age_per_leg"] = r.command_age;
  j["friction_scale_per_leg"] = nullptr;
  if (r.AnyBsSmcLeg()) {
    json::Value legs = json::Value::array();
    for (const auto& f : r.friction_scale) {
      if (f.bssmc_commands == 0) {
        legs.push_back(nullptr);
        continue;
      }
      const bool have = f.commands > 0;
      legs.push_back({{"bssmc_commands", f.bssmc_commands},
                      {"commands", f.commands},
                      {"end", have ? json::Value(f.end) : json::Value(nullptr)},
                      {"min", have ? json::Value(f.min) : json::Value(nullptr)},
                      {"max", have ? json::Value(f.max) : json::Value(nullptr)}});
    }
    j["friction_scale_per_leg"] = legs;
  }
  j["missing_samples"] = json::Value::object();
  for (const auto& [k, v] : r.missing) j["missing_samples"][k] = v;
  j["messages"] = json::Value::object();
  for (const auto& [k, v] : r.messages) j["messages"][k] = v;
  j["control_round_trip_latency_s"] = {{"count", r.latency_pairs},
                                       {"median", r.latency_s.median},
                                       {"p99", r.latency_s.p99},
                                       {"max", r.latency_s.max}};
  j["wall_time_s"] = r.wall_time_s;
  j["sim_time_s"] = r.sim_time_s;
  j["faults"] = r.faults;
  j["takeovers"] = r.takeovers;
  j["recording_warnings"] = r.warnings;
  return j;
}

}  // namespace

// The task-space RMSE table and the leg-length / valve figures of report.md, over the TRACKING
// window; a session that never tracked gets a sentence instead of a table of zeros.
void WriteTrackingFigures(std::ostream& m, const SessionReport& r, const std::string& trajectory) {
  m << "## Task-space RMSE over the tracking window (paper Table 9 / 10 layout)\n\n";
  if (r.pose_samples_tracking == 0) {
    if (r.final_supervisor_state.empty())
      m << "Not tracked: the recording holds no pose report of the supervisor";
    else
      m << "Not tracked: the supervisor never reached TRACKING (final state "
        << r.final_supervisor_state << ")";
    m << ", so there is no tracking error to give (no RMSE, no leg-length figures). The "
         "Faults section and the session's log say why.\n\n";
    return;
  }
  if (r.final_supervisor_state == "HOLD") {
    m << "The session was held: the figures cover the " << r.pose_samples_tracking
      << " pose samples (" << Fixed3(static_cast<double>(r.pose_samples_tracking) * 0.005)
      << " s at 5 ms) tracked before the hold, not the whole window.\n\n";
  }
  m << "| | X cm | Y cm | Z cm | rot X deg | rot Y deg | rot Z deg |\n|---|---|---|---|---|---|---|\n";
  auto row = [&](const char* name, const std::array<double, 6>& a, bool rel) {
    m << "| " << name;
    for (int i = 0; i < 6; ++i) {
      char buf[32];
      if (rel) {
        if (a[i] < 0) std::snprintf(buf, sizeof buf, "-");
        else std::snprintf(buf, sizeof buf, "%.2f%%", 100 * a[i]);
      } else {
        std::snprintf(buf, sizeof buf, "%.3f", a[i] * (i < 3 ? 100.0 : kRadToDeg));
      }
      m << " | " << buf;
    }
    m << " |\n";
  };
  row("RMSE vs ground truth", r.rmse_vs_truth, false);
  row("relative error vs ground truth", r.relative_vs_truth, true);
  row("RMSE vs measured pose (GQFK + IMU)", r.rmse_vs_measured, false);
  row("relative error vs measured pose", r.relative_vs_measured, true);
  bool any_paper = false;
  std::array<double, 6> paper{};
  for (int i = 0; i < 6; ++i) {
    double v = 0;
    if (PaperValue(trajectory, i, v)) {
      paper[i] = v / (i < 3 ? 100.0 : kRadToDeg);
      any_paper = true;
    } else {
      paper[i] = std::nan("");
    }
  }
  if (any_paper) {
    m << "| paper (Table " << (trajectory == "combined" ? "10" : "9") << ")";
    for (int i = 0; i < 6; ++i) {
      char buf[32];
      if (std::isnan(paper[i])) std::snprintf(buf, sizeof buf, "-");
      else std::snprintf(buf, sizeof buf, "%.3f", paper[i] * (i < 3 ? 100.0 : kRadToDeg));
      m << " | " << buf;
    }
    m << " |\n";
  }
  m << "\nRelative error = RMSE / peak-to-peak of the desired motion on that axis (the paper "
       "does not define its own); '-' = no motion on that axis.\n\n";
  m << "## Leg-length RMSE (desired incl. outer-loop correction vs potentiometer)\n\n"
       "| leg | 1 | 2 | 3 | 4 | 5 | 6 |\n|---|---|---|---|---|---|---|\n| RMSE mm";
  for (double v : r.leg_length_rmse_m) m << " | " << Num(1000 * v).substr(0, 6);
  m << " |\n| max mm";
  for (double v : r.leg_length_max_abs_m) m << " | " << Num(1000 * v).substr(0, 6);
  const auto cell = [](double v) { return std::isfinite(v) ? Num(v).substr(0, 5) : std::string("-"); };
  m << " |\n| valve mean abs step V/tick";
  for (double v : r.valve_mean_abs_step_v) m << " | " << cell(v);
  m << " |\n| valve saturated %";
  for (double v : r.valve_saturated_fraction) m << " | " << cell(100 * v);
  m << " |\n\nValve activity is taken over the tracking window from the voltages the plant "
       "applied: a smooth command moves a few hundredths of a volt per 1 ms tick; chattering "
       "shows as large steps and time at 0 or 10 V.";
  if (!std::isfinite(r.valve_mean_abs_step_v[0]))
    m << " '-': no GroundTruth was recorded in the tracking window (a rig's device publishes "
         "none: the voltages its valves got are not known), so the valve activity is unknown.";
  m << "\n\n";
}

namespace {

void WriteFrictionScaleTable(std::ostream& m, const SessionReport& r) {
  if (r.AnyBsSmcLeg()) {
    m << "## Adapted friction scale theta over the tracking window (BS-SMC)\n\n"
         "| leg | end | min | max | commands |\n|---|---|---|---|---|\n";
    for (int i = 0; i < 6; ++i) {
      const auto& f = r.friction_scale[i];
      char buf[96];
      if (f.bssmc_commands == 0)
        std::snprintf(buf, sizeof buf, "- | - | - | 0 (not BS-SMC)");
      else if (f.commands == 0)
        std::snprintf(buf, sizeof buf, "not recorded | - | - | %llu",
                      static_cast<unsigned long long>(f.bssmc_commands));
      else
        std::snprintf(buf, sizeof buf, "%.4f | %.4f | %.4f | %llu", f.end, f.min, f.max,
                      static_cast<unsigned long long>(f.commands));
      m << "| " << i + 1 << " | " << buf << " |\n";
    }
    m << "\ntheta scales eq 14's friction estimate at speed (1 = nominal); end = the leg's last "
         "command in the window. 'not recorded': the recording predates the field.\n\n";
  }
}

void WriteTimingSection(std::ostream& m, const SessionReport& r) {
  m << "## Timing\n\n";
  m << "- control round trip (sensor sample written -> valve command written, same leg and "
       "tick): median "
    << Num(r.latency_s.median * 1e6) << " us, p99 " << Num(r.latency_s.p99 * 1e6) << " us, max "
    << Num(r.latency_s.max * 1e6) << " us over " << r.latency_pairs << " pairs\n";
  for (const auto& [k, v] : r.deadline_misses) m << "- deadline misses " << k << ": " << v << "\n";
  if (r.command_age_recorded) {
    m << "\nAge of the command the plant applied (ticks; >= 1 = a late tick: the command "
         "for the sensor sample before it had not arrived):\n\n| leg | 0 | 1 | 2 | 3-7 | 8-15 | "
         ">= 16 | none | late ticks |\n|---|---|---|---|---|---|---|---|---|\n";
    for (int i = 0; i < 6; ++i) {
      const auto& a = r.command_age[i];
      uint64_t total = 0, late = 0;
      for (int b = 0; b < SessionReport::kAgeBins; ++b) total += a[b];
      for (int b = 1; b < 6; ++b) late += a[b];
      m << "| " << i + 1;
      for (int b = 0; b < SessionReport::kAgeBins; ++b) m << " | " << a[b];
      char pct[32];
      std::snprintf(pct, sizeof pct, "%.3f %%", total ? 100.0 * late / total : 0.0);
      m << " | " << late << " (" << pct << ") |\n";
    }
    m << "\n";
  }
  for (const auto& [k, v] : r.missing) m << "- samples missing (from tick numbers) " << k << ": " << v << "\n";
  m << "\n(In real time a leg controller answers only the newest sensor sample of its leg, so "
       "gaps in hexa_ValveCommand there are ticks it skipped, not samples the recorder lost.)\n";
}

void WritePoseCsv(const SessionReport& r, const std::string& path) {
  std::ofstream p(path);
  p << "time_s [s]";
  for (const char* w : {"desired", "true", "measured"})
    for (int i = 0; i < 6; ++i) p << "," << w << "_" << kAxes[i] << (i < 3 ? " [m]" : " [rad]");
  p << "\n";
  char buf[32];
  for (const auto& row : r.pose_rows) {
    std::snprintf(buf, sizeof buf, "%.3f", row.time_s);
    p << buf;
    for (const auto* arr : {&row.desired, &row.truth, &row.measured})
      for (double v : *arr) p << "," << (std::isnan(v) ? "nan" : Num(v));
    p << "\n";
  }
}

void WriteLegsCsv(const SessionReport& r, const std::string& path) {
  std::ofstream l(path);
  l << "time_s [s]";
  for (const char* w : {"desired_length_m_%d [m]", "measured_length_m_%d [m]", "valve_v_%d [V]",
                        "friction_scale_%d [1]"})
    for (int i = 1; i <= 6; ++i) {
      char name[40];
      std::snprintf(name, sizeof name, w, i);
      l << "," << name;
    }
  l << "\n";
  char buf[32];
  for (const auto& row : r.leg_rows) {
    std::snprintf(buf, sizeof buf, "%.3f", row.time_s);
    l << buf;
    for (const auto* arr : {&row.desired_length_m, &row.measured_length_m, &row.valve_v,
                            &row.friction_scale})
      for (double v : *arr) l << "," << (std::isnan(v) ? "nan" : Num(v));
    l << "\n";
  }
}

}  // namespace

void WriteSessionReport(const SessionReport& r, const std::string& dir) {
  const auto meta = [&](const char* k) {
    auto it = r.meta.find(k);
    return it == r.meta.end() ? std::string() : it->second;
  };
  const std::string trajectory = meta("trajectory");
  char lost_line[160] = "";
  if (r.recording_lost_samples > 0)
    std::snprintf(lost_line, sizeof lost_line,
                  "the recording lost %llu of %llu samples of the plant's streams (%.3f %%)",
                  static_cast<unsigned long long>(r.recording_lost_samples),
                  static_cast<unsigned long long>(r.recording_expected_samples),
                  r.recording_expected_samples
                      ? 100.0 * static_cast<double>(r.recording_lost_samples) /
                            static_cast<double>(r.recording_expected_samples)
                      : 0.0);
  // A session whose trajectory ran to its end but whose recording lost samples did not
  // complete: its figures miss what was lost (hexa_session exits 7).
  std::map<std::string, std::string> session = r.meta;
  if (r.recording_lost_samples > 0 && meta("completed") == "yes")
    session["completed"] = std::string("NO: the trajectory ran to its end, but ") + lost_line;
  {
    std::string error;
    if (!json::WriteFile(dir + "/report.json", ReportJson(r, session), 2, error)) throw std::runtime_error(error);
  }
  {
    std::ofstream m(dir + "/report.md");
    if (!m) throw std::runtime_error("cannot write " + dir + "/report.md");
    m << "# Session report\n\n![summary: facts, RMSE, events, errors, path](summary.png)\n\n";
    for (const auto& [k, v] : session) m << "- " << k << ": " << v << "\n";
    m << "- recording: `" << r.recording << "`" << (r.complete_file ? "" : " (INCOMPLETE FILE)")
      << "\n- simulated time " << Num(r.sim_time_s) << " s, wall time " << Num(r.wall_time_s)
      << " s\n- final supervisor state: " << r.final_supervisor_state
      << "\n- tracking window: " << r.pose_samples_tracking << " pose samples (5 ms)\n";
    for (const auto& w : r.warnings) m << "- recording warning: " << w << "\n";
    if (r.recording_lost_samples > 0)
      m << "- recording: " << lost_line << " (per topic under Timing); the figures below miss them\n";
    m << "\n";
    WriteTrackingFigures(m, r, trajectory);
    WriteFrictionScaleTable(m, r);
    WriteTimingSection(m, r);
    m << "\n## Faults\n\n";
    if (r.faults.empty() && r.takeovers.empty()) m << "none\n";
    for (const auto& f : r.faults) m << "- " << f << "\n";
    for (const auto& t : r.takeovers) m << "- take-over (no FaultEvent): " << t << "\n";
    m << "\n## Plots\n\nsummary.png, pose_tracking.png, pose_error.png, leg_lengths.png, "
         "valve_voltages.png, path_3d.png (the tracking window shaded, faults, HOLD, take-overs "
         "and operator commands marked: events.csv; what each marks: plots.json)\n";
  }
  WriteEventsCsv(r.events, dir + "/events.csv");
  WritePoseCsv(r, dir + "/pose.csv");
  WriteLegsCsv(r, dir + "/legs.csv");
}

}  // namespace hexa::recorder
