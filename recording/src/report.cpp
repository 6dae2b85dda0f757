#include "hexa/recording/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hexa/core/pose.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/services/json.hpp"
#include "report_events.hpp"
#include "hexa/services/text.hpp"
#include "recording.pb.h"

namespace hexa::recorder {
namespace {

constexpr double kTickS = 0.001;
constexpr double kRadToDeg = 57.29577951308232;

// Invalid UTF-8 in a string field is repaired as ReadRecording does (it has already counted
// the message in the scan's problems).
template <typename T>
T Parse(const McapMessageView& view, const std::string& topic) {
  T msg;
  if (ParseRepairingUtf8(view.data, msg) == ParseOutcome::kFailed)
    throw std::runtime_error("cannot parse a message of " + topic);
  return msg;
}

template <typename Rep>
std::array<double, 6> Six(const Rep& r) {
  std::array<double, 6> a{};
  for (int i = 0; i < 6 && i < r.size(); ++i) a[i] = r.Get(i);
  return a;
}

Vector6d ToVec(const std::array<double, 6>& a) {
  Vector6d v;
  for (int i = 0; i < 6; ++i) v[i] = a[i];
  return v;
}

std::string Fixed3(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

std::string SupervisorStateName(int s) {
  static const char* kNames[] = {"IDLE", "BLENDING", "TRACKING", "STOPPING", "HOLD"};
  return s >= 0 && s < 5 ? kNames[s] : "UNKNOWN";
}

struct TickSlot {
  bool truth = false;
  std::array<double, 6> truth_pose{};
  std::array<double, 6> applied_v{};
  std::array<bool, 6> sensor{};
  std::array<double, 6> sensor_length_m{};
  std::array<int64_t, 6> sensor_time_ns{};
  std::array<bool, 6> command{};
  std::array<double, 6> command_desired_m{};
  std::array<double, 6> command_v{};
  std::array<int64_t, 6> command_time_ns{};
  std::array<bool, 6> command_bssmc{};
  std::array<double, 6> command_friction_scale{};  // NaN: the field is not in the recording
};

}  // namespace

SessionReport ComputeSessionReport(const std::string& path,
                                   const std::function<void(double)>& progress) {
  return ComputeSessionReport(std::vector<std::string>{path}, progress);
}

SessionReport ComputeSessionReport(const std::vector<std::string>& parts,
                                   const std::function<void(double)>& progress) {
  if (parts.empty()) throw std::invalid_argument("ComputeSessionReport: no recording");
  // Progress: the parts are read twice (the figures, then the loss analysis of hexa_recorder
  // info), each read half of the work, each part an equal share of it.
  const double part_share = 1.0 / static_cast<double>(parts.size());
  std::size_t part_index = 0;
  const auto scan_options = [&](bool loss_analysis, double half) {
    McapScanOptions o;
    if (loss_analysis) o = McapScanOptions{true, true, {}};
    if (progress)
      o.progress = [&progress, &part_index, part_share, half](uint64_t done, uint64_t size) {
        const double in_part = static_cast<double>(done) / static_cast<double>(std::max<uint64_t>(size, 1));
        progress(half + 0.5 * part_share * (static_cast<double>(part_index) + in_part));
      };
    return o;
  };
  SessionReport r;
  const std::string& path = parts.back();  // named in messages
  for (const auto& part : parts) r.recording += (r.recording.empty() ? "" : " ") + part;
  std::vector<TickSlot> ticks;
  auto slot = [&](uint64_t tick) -> TickSlot& {
    if (tick > 50'000'000) throw std::runtime_error(path + ": tick " + std::to_string(tick) + " is implausible");
    if (ticks.size() <= tick) ticks.resize(tick + 1);
    return ticks[tick];
  };
  struct PoseSample {
    uint64_t tick;
    int state;
    std::array<double, 6> desired, estimated;
  };
  std::vector<PoseSample> poses;
  std::map<std::string, rec::NodeStatus> last_status;
  uint64_t first_log = UINT64_MAX, last_log = 0;
  // Per leg: the last tick of a primary's command and every tick of a standby's (both write
  // every tick while alive: the plant chooses, docs/faults.md).
  std::array<uint64_t, 6> last_primary_tick{};
  std::array<std::vector<uint64_t>, 6> standby_ticks;
  std::array<bool, 6> any_primary{};
  EventCollector events;

  const auto on_message = [&](const McapChannel& ch, const McapMessageView& view,
                              const google::protobuf::Message&) {
        first_log = std::min(first_log, view.log_time_ns);
        last_log = std::max(last_log, view.log_time_ns);
        ++r.messages[ch.topic];
        if (ch.topic == "hexa_GroundTruth") {
          const auto g = Parse<rec::GroundTruth>(view, ch.topic);
          TickSlot& s = slot(g.header().tick());
          const Eigen::Quaterniond q(g.orientation_wxyz(0), g.orientation_wxyz(1),
                                     g.orientation_wxyz(2), g.orientation_wxyz(3));
          Pose pose;
          pose.p_BP_B_m = {g.position_m(0), g.position_m(1), g.position_m(2)};
          pose.R_BP = q.toRotationMatrix();
          const Vector6d v = VectorFromPose(pose);
          for (int i = 0; i < 6; ++i) s.truth_pose[i] = v[i];
          s.applied_v = Six(g.applied_valve_v());
          s.truth = true;
          events.OnTruth(g.header().tick(), g.header().source_time_ns());
          if (g.command_age_ticks_size() == 6) {
            r.command_age_recorded = true;
            for (int i = 0; i < 6; ++i) {
              const int32_t age = g.command_age_ticks(i);
              const int bin = age < 0 ? 6 : age <= 2 ? age : age < 8 ? 3 : age < 16 ? 4 : 5;
              ++r.command_age[static_cast<std::size_t>(i)][static_cast<std::size_t>(bin)];
            }
          }
        } else if (ch.topic == "hexa_LegSensors") {
          const auto m = Parse<rec::LegSensors>(view, ch.topic);
          if (m.leg_id() < 1 || m.leg_id() > 6) return;
          TickSlot& s = slot(m.header().tick());
          const int i = static_cast<int>(m.leg_id()) - 1;
          if (s.sensor[i]) return;  // a lockstep re-send of the same tick: keep the first
          s.sensor[i] = true;
          s.sensor_length_m[i] = m.length_m();
          s.sensor_time_ns[i] = m.header().source_time_ns();
        } else if (ch.topic == "hexa_ValveCommand") {
          const auto m = Parse<rec::ValveCommand>(view, ch.topic);
          if (m.leg_id() < 1 || m.leg_id() > 6) return;
          TickSlot& s = slot(m.header().tick());
          const int i = static_cast<int>(m.leg_id()) - 1;
          const auto leg = static_cast<std::size_t>(i);
          if (m.standby()) {
            standby_ticks[leg].push_back(m.header().tick());
          } else {
            last_primary_tick[leg] = std::max<uint64_t>(last_primary_tick[leg], m.header().tick());
            any_primary[leg] = true;
          }
          events.OnValveCommand(m.leg_id(), m.header().tick(), m.standby());
          if (s.command[i]) return;
          s.command[i] = true;
          s.command_desired_m[i] = m.desired_length_m();
          s.command_v[i] = m.valve_v();
          s.command_time_ns[i] = m.header().source_time_ns();
          s.command_bssmc[i] = m.controller() == rec::CONTROLLER_BSSMC;
          s.command_friction_scale[i] = m.has_friction_scale() ? m.friction_scale() : std::nan("");
        } else if (ch.topic == "hexa_PoseReport") {
          const auto m = Parse<rec::PoseReport>(view, ch.topic);
          events.OnPose(m.header().tick(), static_cast<int>(m.state()));
          poses.push_back({m.header().tick(), static_cast<int>(m.state()), Six(m.desired_pose()),
                           Six(m.estimated_pose())});
        } else if (ch.topic == "hexa_NodeStatus") {
          const auto m = Parse<rec::NodeStatus>(view, ch.topic);
          last_status[m.node_name()] = m;
        } else if (ch.topic == "hexa_FaultEvent") {
          const auto m = Parse<rec::FaultEvent>(view, ch.topic);
          std::ostringstream os;
          os << m.source_node() << ": leg " << m.leg_id() << " tick " << m.tick() << " "
             << rec::FaultReason_Name(m.reason()) << ": " << m.detail();
          r.faults.push_back(os.str());
          events.OnFault(m);
        } else if (ch.topic == "hexa_OperatorCommand") {
          events.OnOperator(Parse<rec::OperatorCommand>(view, ch.topic));
        }
      };
  r.complete_file = true;
  for (part_index = 0; part_index < parts.size(); ++part_index) {
    const McapScanResult scan = ReadRecording(parts[part_index], on_message, scan_options(false, 0.0));
    r.complete_file = r.complete_file && scan.complete;
    r.warnings.insert(r.warnings.end(), scan.problems.begin(), scan.problems.end());
  }
  r.events = events.Finish();
  if (first_log <= last_log) r.wall_time_s = static_cast<double>(last_log - first_log) * 1e-9;

  // Task space over the TRACKING window, at the supervisor ticks.
  std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.tick < b.tick; });
  AxisErrorAccumulator vs_truth, vs_measured;
  for (const auto& p : poses) {
    if (p.tick < ticks.size() && ticks[p.tick].truth) {
      r.pose_rows.push_back({p.tick * kTickS, p.desired, ticks[p.tick].truth_pose, p.estimated});
      if (p.state == 2) {
        vs_truth.Add(ToVec(p.desired), ToVec(ticks[p.tick].truth_pose));
        vs_measured.Add(ToVec(p.desired), ToVec(p.estimated));
      }
    }
  }
  if (!poses.empty()) r.final_supervisor_state = SupervisorStateName(poses.back().state);
  r.pose_samples_tracking = vs_truth.count();
  r.rmse_vs_truth = vs_truth.Rmse();
  r.relative_vs_truth = vs_truth.RelativeError();
  r.rmse_vs_measured = vs_measured.Rmse();
  r.relative_vs_measured = vs_measured.RelativeError();

  // Joint space: each tick takes the supervisor state of the newest pose report at or
  // before it (the state the legs' setpoints came from).
  std::array<ScalarErrorAccumulator, 6> legs;
  std::array<double, 6> valve_step_sum{}, valve_saturated{};
  std::size_t valve_ticks = 0;
  std::array<double, 6> prev_v{};
  bool have_prev_v = false;
  std::vector<double> latencies;
  std::size_t pose_index = 0;
  int state = -1;
  for (uint64_t tick = 0; tick < ticks.size(); ++tick) {
    while (pose_index < poses.size() && poses[pose_index].tick <= tick) state = poses[pose_index++].state;
    const TickSlot& s = ticks[tick];
    SessionReport::LegRow row{tick * kTickS, {}, {}, {}, {}};
    bool any = false, any_command = false;
    for (int i = 0; i < 6; ++i) {
      row.friction_scale[i] = s.command[i] ? s.command_friction_scale[i] : std::nan("");
      any_command = any_command || s.command[i];
      if (s.command[i] && s.command_bssmc[i] && state == 2) {
        SessionReport::FrictionScale& f = r.friction_scale[static_cast<std::size_t>(i)];
        ++f.bssmc_commands;
        const double theta = s.command_friction_scale[i];
        if (!std::isnan(theta)) {
          f.min = f.commands == 0 ? theta : std::min(f.min, theta);
          f.max = f.commands == 0 ? theta : std::max(f.max, theta);
          f.end = theta;
          ++f.commands;
        }
      }
      if (s.command[i] && s.sensor[i]) {
        latencies.push_back(static_cast<double>(s.command_time_ns[i] - s.sensor_time_ns[i]) * 1e-9);
        if (state == 2) legs[i].Add(s.command_desired_m[i], s.sensor_length_m[i]);
      }
      row.desired_length_m[i] = s.command[i] ? s.command_desired_m[i] : std::nan("");
      row.measured_length_m[i] = s.sensor[i] ? s.sensor_length_m[i] : std::nan("");
      row.valve_v[i] = s.truth ? s.applied_v[i] : std::nan("");
      any = any || s.sensor[i] || s.command[i];
    }
    if (any) r.leg_rows.push_back(row);
    if (any_command) {
      std::array<double, 6> none;
      none.fill(std::nan(""));
      r.command_friction_scale.resize(tick + 1, none);
      r.command_friction_scale[tick] = row.friction_scale;
    }
    if (s.truth && state == 2) {
      for (int i = 0; i < 6; ++i) {
        if (have_prev_v) valve_step_sum[i] += std::abs(s.applied_v[i] - prev_v[i]);
        valve_saturated[i] += (s.applied_v[i] < 0.05 || s.applied_v[i] > 9.95) ? 1.0 : 0.0;
      }
      if (have_prev_v) ++valve_ticks;
    }
    if (s.truth) {
      prev_v = s.applied_v;
      have_prev_v = true;
      // Ticks without a GroundTruth sample (lost in real time) stay NaN: unknown, not 0 V.
      std::array<double, 6> unknown;
      unknown.fill(std::nan(""));
      r.applied_valve_v.resize(tick + 1, unknown);
      r.applied_valve_v[tick] = s.applied_v;
      r.sim_time_s = tick * kTickS;
    }
  }
  for (int i = 0; i < 6; ++i) {
    r.leg_length_rmse_m[i] = legs[i].Rmse();
    r.leg_length_max_abs_m[i] = legs[i].MaxAbs();
  }
  for (int i = 0; i < 6 && valve_ticks > 0; ++i) {
    r.valve_mean_abs_step_v[i] = valve_step_sum[i] / static_cast<double>(valve_ticks);
    r.valve_saturated_fraction[i] = valve_saturated[i] / static_cast<double>(valve_ticks + 1);
  }
  r.latency_pairs = latencies.size();
  r.latency_s = ComputePercentiles(std::move(latencies));

  // Deadline misses as each reader counted them (NodeStatus of the reading node).
  for (const auto& [node, st] : last_status) {
    std::string topic;
    if (node == "plant") topic = "hexa_ValveCommand (plant)";
    else if (node.rfind("leg", 0) == 0) topic = "hexa_LegSensors (leg controllers)";
    else if (node == "supervisor") topic = "hexa_ImuSample (supervisor)";
    else continue;
    r.deadline_misses[topic] += st.deadline_missed_total();
  }
  // Per part (a gap across two parts' boundary is not counted).
  for (part_index = 0; part_index < parts.size(); ++part_index) {
    const RecordingInfo info = Inspect(parts[part_index], scan_options(true, 0.5));
    for (const auto& ch : info.channels) {
      if (!ch.loss_analysed) continue;
      r.missing[ch.topic] += ch.missing;
      // The plant's streams: a gap in them is the recorder's loss. (A leg controller may skip
      // ticks in real time and the supervisor may run late, so their gaps are not.)
      if (ch.topic == "hexa_LegSensors" || ch.topic == "hexa_GroundTruth" ||
          ch.topic == "hexa_ImuSample") {
        r.recording_lost_samples += ch.missing;
        for (const auto& l : ch.streams) r.recording_expected_samples += l.expected;
      }
    }
  }
  // A standby that wrote after the primary's last command drove the valve from then on (the
  // plant applies the live primary, else the live standby).
  for (std::size_t leg = 0; leg < 6; ++leg) {
    auto& ticks = standby_ticks[leg];
    std::sort(ticks.begin(), ticks.end());
    const auto first = any_primary[leg] ? std::upper_bound(ticks.begin(), ticks.end(), last_primary_tick[leg])
                                        : ticks.begin();
    if (first == ticks.end()) continue;  // the primary answered to the end
    const auto standby_commands = static_cast<std::size_t>(ticks.end() - first);
    std::ostringstream os;
    os << "leg " << leg + 1 << ": the hot standby drives the valve from tick " << *first
       << " (t = " << Fixed3(static_cast<double>(*first) * kTickS) << " s; "
       << (any_primary[leg] ? "the primary's last command at tick " + std::to_string(last_primary_tick[leg])
                            : std::string("no command of the primary recorded"))
       << "), " << standby_commands << " commands";
    r.takeovers.push_back(os.str());
  }
  return r;
}

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
  m << " |\n| valve mean abs step V/tick";
  for (double v : r.valve_mean_abs_step_v) m << " | " << Num(v).substr(0, 5);
  m << " |\n| valve saturated %";
  for (double v : r.valve_saturated_fraction) m << " | " << Num(100 * v).substr(0, 5);
  m << " |\n\nValve activity is taken over the tracking window from the voltages the plant "
       "applied: a smooth command moves a few hundredths of a volt per 1 ms tick; chattering "
       "shows as large steps and time at 0 or 10 V.\n\n";
}

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
    m << "\n## Faults\n\n";
    if (r.faults.empty() && r.takeovers.empty()) m << "none\n";
    for (const auto& f : r.faults) m << "- " << f << "\n";
    for (const auto& t : r.takeovers) m << "- take-over (no FaultEvent): " << t << "\n";
    m << "\n## Plots\n\nsummary.png, pose_tracking.png, pose_error.png, leg_lengths.png, "
         "valve_voltages.png, path_3d.png (the tracking window shaded, faults, HOLD, take-overs "
         "and operator commands marked: events.csv; what each marks: plots.json)\n";
  }
  WriteEventsCsv(r.events, dir + "/events.csv");
  {
    std::ofstream p(dir + "/pose.csv");
    p << "time_s [s]";
    for (const char* w : {"desired", "true", "measured"})
      for (int i = 0; i < 6; ++i) p << "," << w << "_" << kAxes[i] << (i < 3 ? " [m]" : " [rad]");
    p << "\n";
    char buf[32];
    for (const auto& row : r.pose_rows) {
      std::snprintf(buf, sizeof buf, "%.3f", row.time_s);
      p << buf;
      for (const auto* arr : {&row.desired, &row.truth, &row.measured})
        for (double v : *arr) p << "," << Num(v);
      p << "\n";
    }
  }
  {
    std::ofstream l(dir + "/legs.csv");
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
}

}  // namespace hexa::recorder
