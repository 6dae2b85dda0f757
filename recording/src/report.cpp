// The session report computed from a recording (RMSE over the tracking window, leg errors,
// valve activity, timing, loss, faults and take-overs). Written by report_write.cpp.
#include "hexa/recording/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hexa/core/pose.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/takeover.hpp"
#include "report_events.hpp"
#include "recording.pb.h"

namespace hexa::recorder {
namespace {

constexpr double kTickS = 0.001;

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
  std::array<bool, 6> command_coupled{};
};

}  // namespace

SessionReport ComputeSessionReport(const std::string& path,
                                   const std::function<void(double)>& progress) {
  return ComputeSessionReport(std::vector<std::string>{path}, progress);
}

namespace {

struct PoseSample {
  uint64_t tick;
  int state;
  std::array<double, 6> desired, estimated;
};

// What the report needs of a recording, gathered in one read of every part: per tick the
// truth, sensors and commands; the pose reports; each node's last status; the take-overs
// and the plot events.
class SessionCollector {
 public:
  SessionCollector(const std::string& path, SessionReport& r) : path_(path), r_(r) {}

  void OnMessage(const McapChannel& ch, const McapMessageView& view) {
    first_log = std::min(first_log, view.log_time_ns);
    last_log = std::max(last_log, view.log_time_ns);
    ++r_.messages[ch.topic];
    if (ch.topic == "hexa_GroundTruth") {
      OnGroundTruth(Parse<rec::GroundTruth>(view, ch.topic));
    } else if (ch.topic == "hexa_LegSensors") {
      OnLegSensors(Parse<rec::LegSensors>(view, ch.topic));
    } else if (ch.topic == "hexa_ValveCommand") {
      OnValveCommand(Parse<rec::ValveCommand>(view, ch.topic));
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
      r_.faults.push_back(os.str());
      events.OnFault(m);
    } else if (ch.topic == "hexa_OperatorCommand") {
      events.OnOperator(Parse<rec::OperatorCommand>(view, ch.topic));
    }
  }

  std::vector<TickSlot> ticks;
  std::vector<PoseSample> poses;
  std::map<std::string, rec::NodeStatus> last_status;
  uint64_t first_log = UINT64_MAX, last_log = 0;
  // Every command of a primary and of a standby (both write every tick while alive: the plant
  // chooses, docs/faults.md).
  TakeoverDetector takeovers;
  EventCollector events;

 private:
  TickSlot& Slot(uint64_t tick) {
    if (tick > 50'000'000) throw std::runtime_error(path_ + ": tick " + std::to_string(tick) + " is implausible");
    if (ticks.size() <= tick) ticks.resize(tick + 1);
    return ticks[tick];
  }

  void OnGroundTruth(const rec::GroundTruth& g) {
    TickSlot& s = Slot(g.header().tick());
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
      r_.command_age_recorded = true;
      for (int i = 0; i < 6; ++i) {
        const int32_t age = g.command_age_ticks(i);
        const int bin = age < 0 ? 6 : age <= 2 ? age : age < 8 ? 3 : age < 16 ? 4 : 5;
        ++r_.command_age[static_cast<std::size_t>(i)][static_cast<std::size_t>(bin)];
      }
    }
  }

  void OnLegSensors(const rec::LegSensors& m) {
    if (m.leg_id() < 1 || m.leg_id() > 6) return;
    TickSlot& s = Slot(m.header().tick());
    const int i = static_cast<int>(m.leg_id()) - 1;
    if (s.sensor[i]) return;  // a lockstep re-send of the same tick: keep the first
    s.sensor[i] = true;
    s.sensor_length_m[i] = m.length_m();
    s.sensor_time_ns[i] = m.header().source_time_ns();
  }

  void OnValveCommand(const rec::ValveCommand& m) {
    if (m.leg_id() < 1 || m.leg_id() > 6) return;
    TickSlot& s = Slot(m.header().tick());
    const int i = static_cast<int>(m.leg_id()) - 1;
    takeovers.Add(m.leg_id(), m.header().tick(), m.standby());
    if (s.command[i]) return;
    s.command[i] = true;
    s.command_desired_m[i] = m.desired_length_m();
    s.command_v[i] = m.valve_v();
    s.command_time_ns[i] = m.header().source_time_ns();
    s.command_bssmc[i] = m.controller() == rec::CONTROLLER_BSSMC;
    s.command_friction_scale[i] = m.has_friction_scale() ? m.friction_scale() : std::nan("");
    s.command_coupled[i] = m.coupled();
  }

  const std::string& path_;  // named in messages
  SessionReport& r_;
};

void ComputeTaskSpace(std::vector<PoseSample>& poses, const std::vector<TickSlot>& ticks,
                      SessionReport& r) {
  // Task space over the TRACKING window, at the supervisor ticks.
  std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.tick < b.tick; });
  AxisErrorAccumulator vs_truth, vs_measured;
  // A plant that simulates nothing (a remote I/O board) publishes no ground truth: the rows
  // then carry NaN for it, and only the measured pose has a tracking error.
  const bool any_truth = std::any_of(ticks.begin(), ticks.end(), [](const TickSlot& s) { return s.truth; });
  std::array<double, 6> no_truth;
  no_truth.fill(std::nan(""));
  for (const auto& p : poses) {
    const bool truth = p.tick < ticks.size() && ticks[p.tick].truth;
    if (truth || (!any_truth && p.tick < ticks.size())) {
      r.pose_rows.push_back({p.tick * kTickS, p.desired, truth ? ticks[p.tick].truth_pose : no_truth, p.estimated});
      if (p.state == 2) {
        if (truth) vs_truth.Add(ToVec(p.desired), ToVec(ticks[p.tick].truth_pose));
        vs_measured.Add(ToVec(p.desired), ToVec(p.estimated));
      }
    }
  }
  if (!poses.empty()) r.final_supervisor_state = SupervisorStateName(poses.back().state);
  r.pose_samples_tracking = any_truth ? vs_truth.count() : vs_measured.count();
  r.rmse_vs_truth = vs_truth.Rmse();
  r.relative_vs_truth = vs_truth.RelativeError();
  if (!any_truth) r.rmse_vs_truth.fill(std::nan(""));  // unknown, not zero
  r.rmse_vs_measured = vs_measured.Rmse();
  r.relative_vs_measured = vs_measured.RelativeError();

}

void ComputeJointSpace(const std::vector<PoseSample>& poses, const std::vector<TickSlot>& ticks,
                       SessionReport& r) {
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
  const bool have_truth = std::any_of(ticks.begin(), ticks.end(), [](const TickSlot& s) { return s.truth; });
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
    if (any && !have_truth) r.sim_time_s = tick * kTickS;  // no ground truth: the sensors' ticks
    if (any_command) {
      std::array<double, 6> none;
      none.fill(std::nan(""));
      r.command_friction_scale.resize(tick + 1, none);
      r.command_friction_scale[tick] = row.friction_scale;
      std::array<int, 6> coupled;
      for (int i = 0; i < 6; ++i) coupled[i] = s.command[i] ? (s.command_coupled[i] ? 1 : 0) : -1;
      r.command_coupled.resize(tick + 1, {-1, -1, -1, -1, -1, -1});
      r.command_coupled[tick] = coupled;
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
  // Without GroundTruth in the tracking window (a rig's device: what the valves got is not
  // known) the activity is unknown (NaN; null in report.json), not 0.
  for (int i = 0; i < 6; ++i) {
    r.valve_mean_abs_step_v[i] = valve_ticks > 0 ? valve_step_sum[i] / static_cast<double>(valve_ticks) : std::nan("");
    r.valve_saturated_fraction[i] =
        valve_ticks > 0 ? valve_saturated[i] / static_cast<double>(valve_ticks + 1) : std::nan("");
  }
  r.latency_pairs = latencies.size();
  r.latency_s = ComputePercentiles(std::move(latencies));
}

void AddDeadlineMisses(const std::map<std::string, rec::NodeStatus>& last_status, SessionReport& r) {
  // Deadline misses as each reader counted them (NodeStatus of the reading node).
  for (const auto& [node, st] : last_status) {
    std::string topic;
    if (node == "plant") topic = "hexa_ValveCommand (plant)";
    else if (node.rfind("leg", 0) == 0) topic = "hexa_LegSensors (leg controllers)";
    else if (node == "supervisor") topic = "hexa_ImuSample (supervisor)";
    else continue;
    r.deadline_misses[topic] += st.deadline_missed_total();
  }
}

void AddTakeovers(const std::vector<Takeover>& found, SessionReport& r) {
  for (const Takeover& t : found) {  // the rule: takeover.hpp
    std::ostringstream os;
    os << "leg " << t.leg << ": the hot standby drives the valve from tick " << t.first_standby_tick
       << " (t = " << Fixed3(static_cast<double>(t.first_standby_tick) * kTickS) << " s; "
       << (t.last_primary_tick ? "the primary's last command at tick " + std::to_string(*t.last_primary_tick)
                               : std::string("no command of the primary recorded"))
       << "), " << t.standby_commands << " commands";
    r.takeovers.push_back(os.str());
  }
}

}  // namespace

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
  for (const auto& part : parts) r.recording += (r.recording.empty() ? "" : " ") + part;
  SessionCollector c(parts.back(), r);
  const auto on_message = [&c](const McapChannel& ch, const McapMessageView& view,
                               const google::protobuf::Message&) { c.OnMessage(ch, view); };
  r.complete_file = true;
  for (part_index = 0; part_index < parts.size(); ++part_index) {
    const McapScanResult scan = ReadRecording(parts[part_index], on_message, scan_options(false, 0.0));
    r.complete_file = r.complete_file && scan.complete;
    r.warnings.insert(r.warnings.end(), scan.problems.begin(), scan.problems.end());
  }
  const std::vector<Takeover> found = c.takeovers.Find();
  r.events = c.events.Finish(found);
  if (c.first_log <= c.last_log) r.wall_time_s = static_cast<double>(c.last_log - c.first_log) * 1e-9;
  ComputeTaskSpace(c.poses, c.ticks, r);
  ComputeJointSpace(c.poses, c.ticks, r);
  AddDeadlineMisses(c.last_status, r);
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
  AddTakeovers(found, r);
  return r;
}

}  // namespace hexa::recorder
