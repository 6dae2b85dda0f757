// Deterministic samples of every wire type of idl/hexa.idl, and field-by-field comparison:
// shared by the publisher helper (which writes Make<T>(seq)) and the subscriber helper (which
// recomputes Make<T>(seq) from the received sequence number and compares every field).
// Every field gets a value distinct from every other field of the same sample, so a swapped,
// truncated or dropped field is a mismatch. source_time_ns is stamped at write and checked
// against the DDS source timestamp instead.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "hexa.h"

namespace hexa::comm::test {

// Field k of sample seq; negative for odd k, with a fractional part that survives exactly.
inline double V(uint64_t seq, int k) {
  const double magnitude = static_cast<double>(seq) * 1000.0 + k * 1.25 + 0.0625;
  return (k % 2 == 1) ? -magnitude : magnitude;
}

inline void Header(hexa_msg_SampleHeader& h, uint64_t seq) {
  h.tick = seq + (uint64_t{1} << 33);
  h.sim_time_s = static_cast<double>(seq) * 0.001 + 0.5;
  h.source_time_ns = 0;  // stamped by WriteNow
}

inline void CopyString(char* dst, std::size_t size, const std::string& s) {
  std::memset(dst, 0, size);
  std::strncpy(dst, s.c_str(), size - 1);
}

// A string of exactly `len` characters that depends on seq.
inline std::string Text(const char* prefix, uint64_t seq, std::size_t len) {
  std::string s = std::string(prefix) + "-" + std::to_string(seq) + "-";
  while (s.size() < len) s.push_back(static_cast<char>('a' + (s.size() + seq) % 26));
  s.resize(len);
  return s;
}

template <typename T>
T Make(uint64_t seq);

template <>
inline hexa_msg_LegSensors Make(uint64_t seq) {
  hexa_msg_LegSensors s{};
  s.leg_id = static_cast<uint8_t>(1 + seq % 6);
  Header(s.header, seq);
  s.length_m = V(seq, 1);
  s.cap_pressure_pa = V(seq, 2);
  s.rod_pressure_pa = V(seq, 3);
  s.supply_pressure_pa = V(seq, 4);
  s.relayed_present = (seq % 2) == 0;
  s.relayed_tick = seq * 3 + (uint64_t{1} << 41);
  for (int i = 0; i < 6; ++i) {
    s.relayed_valid[i] = ((seq + static_cast<uint64_t>(i)) % 2) == 1;
    s.relayed_force_n[i] = V(seq, 60 + i);
    s.relayed_rate_n_s[i] = V(seq, 70 + i);
  }
  return s;
}

template <>
inline hexa_msg_ValveCommand Make(uint64_t seq) {
  hexa_msg_ValveCommand s{};
  s.leg_id = static_cast<uint8_t>(1 + seq % 6);
  Header(s.header, seq);
  s.valve_v = V(seq, 1);
  s.controller = static_cast<hexa_msg_ControllerKind>(seq % 3);
  s.status = static_cast<hexa_msg_LegCtrlStatus>(seq % 5);
  s.standby = (seq % 2) == 1;
  s.setpoint_tick = seq * 7 + (uint64_t{1} << 40);
  s.desired_length_m = V(seq, 2);
  s.sliding_surface_m_s = V(seq, 3);
  s.compute_time_s = V(seq, 4);
  s.friction_scale = V(seq, 5);
  s.feedback_valid = (seq % 2) == 0;
  s.feedback_force_n = V(seq, 6);
  s.feedback_rate_n_s = V(seq, 7);
  s.coupled = (seq % 3) == 1;
  return s;
}

template <>
inline hexa_msg_ImuSample Make(uint64_t seq) {
  hexa_msg_ImuSample s{};
  Header(s.header, seq);
  for (int i = 0; i < 4; ++i) s.orientation_wxyz[i] = V(seq, 10 + i);
  for (int i = 0; i < 3; ++i) s.angular_rate_rad_s[i] = V(seq, 20 + i);
  return s;
}

template <>
inline hexa_msg_LegSetpoint Make(uint64_t seq) {
  hexa_msg_LegSetpoint s{};
  s.leg_id = static_cast<uint8_t>(1 + seq % 6);
  Header(s.header, seq);
  s.length_m = V(seq, 1);
  s.velocity_m_s = V(seq, 2);
  s.acceleration_m_s2 = V(seq, 3);
  s.correction_m = V(seq, 4);
  s.hold = (seq % 2) == 0;
  return s;
}

template <>
inline hexa_msg_PoseReport Make(uint64_t seq) {
  hexa_msg_PoseReport s{};
  Header(s.header, seq);
  s.state = static_cast<hexa_msg_SupervisorState>(seq % 5);
  s.trajectory_time_s = V(seq, 1);
  for (int i = 0; i < 6; ++i) {
    s.desired_pose[i] = V(seq, 10 + i);
    s.estimated_pose[i] = V(seq, 20 + i);
    s.error_pose[i] = V(seq, 30 + i);
  }
  s.estimator_status = static_cast<uint8_t>(200 + seq % 50);
  s.excluded_leg = static_cast<int8_t>(static_cast<int>(seq % 7) - 1);
  return s;
}

template <>
inline hexa_msg_GroundTruth Make(uint64_t seq) {
  hexa_msg_GroundTruth s{};
  Header(s.header, seq);
  for (int i = 0; i < 3; ++i) {
    s.position_m[i] = V(seq, 10 + i);
    s.linear_velocity_m_s[i] = V(seq, 20 + i);
    s.angular_velocity_rad_s[i] = V(seq, 30 + i);
  }
  for (int i = 0; i < 4; ++i) s.orientation_wxyz[i] = V(seq, 40 + i);
  for (int i = 0; i < 6; ++i) {
    s.leg_length_m[i] = V(seq, 50 + i);
    s.piston_velocity_m_s[i] = V(seq, 60 + i);
    s.cap_pressure_pa[i] = V(seq, 70 + i);
    s.rod_pressure_pa[i] = V(seq, 80 + i);
    s.spool_position_m[i] = V(seq, 90 + i);
    s.applied_valve_v[i] = V(seq, 100 + i);
  }
  return s;
}

template <>
inline hexa_msg_TrackerPose Make(uint64_t seq) {
  hexa_msg_TrackerPose s{};
  Header(s.header, seq);
  for (int i = 0; i < 3; ++i) s.position_m[i] = V(seq, 10 + i);
  for (int i = 0; i < 4; ++i) s.orientation_wxyz[i] = V(seq, 20 + i);
  return s;
}

template <>
inline hexa_msg_OperatorCommand Make(uint64_t seq) {
  hexa_msg_OperatorCommand s{};
  s.sequence = static_cast<uint32_t>(seq + 3000000000u);
  s.kind = static_cast<hexa_msg_OperatorCommandKind>(seq % 5);
  CopyString(s.trajectory, sizeof s.trajectory, Text("traj", seq, 64));   // full bound
  CopyString(s.csv_path, sizeof s.csv_path, Text("/csv/path", seq, 256));  // full bound
  s.source_time_ns = 0;
  return s;
}

template <>
inline hexa_msg_NodeStatus Make(uint64_t seq) {
  hexa_msg_NodeStatus s{};
  CopyString(s.node_name, sizeof s.node_name, Text("node", seq % 4, 32));
  Header(s.header, seq);
  s.state = static_cast<hexa_msg_NodeState>(seq % 5);
  s.deadline_missed_total = static_cast<uint32_t>(seq * 3 + 4000000000u);
  s.liveliness_changes_total = static_cast<uint32_t>(seq * 5 + 7);
  s.cycles_total = seq * 11 + (uint64_t{1} << 50);
  s.cycle_time_median_s = V(seq, 1);
  s.cycle_time_max_s = V(seq, 2);
  CopyString(s.detail, sizeof s.detail, Text("detail", seq, 160));
  return s;
}

template <>
inline hexa_msg_FaultEvent Make(uint64_t seq) {
  hexa_msg_FaultEvent s{};
  CopyString(s.source_node, sizeof s.source_node, Text("src", seq, 31));
  s.leg_id = static_cast<uint8_t>(seq % 7);
  s.tick = seq + (uint64_t{1} << 45);
  s.reason = static_cast<hexa_msg_FaultReason>(seq % 12);
  CopyString(s.detail, sizeof s.detail, Text("fault", seq, 150));
  s.source_time_ns = 0;
  return s;
}

// Sequence number a received sample was made from (inverse of Make).
inline uint64_t SeqOf(const hexa_msg_SampleHeader& h) { return h.tick - (uint64_t{1} << 33); }
inline uint64_t SeqOf(const hexa_msg_LegSensors& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_ValveCommand& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_ImuSample& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_LegSetpoint& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_PoseReport& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_GroundTruth& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_TrackerPose& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_NodeStatus& s) { return SeqOf(s.header); }
inline uint64_t SeqOf(const hexa_msg_OperatorCommand& s) { return s.sequence - 3000000000u; }
inline uint64_t SeqOf(const hexa_msg_FaultEvent& s) { return s.tick - (uint64_t{1} << 45); }

inline int64_t SourceTimeOf(const hexa_msg_OperatorCommand& s) { return s.source_time_ns; }
inline int64_t SourceTimeOf(const hexa_msg_FaultEvent& s) { return s.source_time_ns; }
template <typename T>
int64_t SourceTimeOf(const T& s) { return s.header.source_time_ns; }

// Field-by-field comparison; `diff` names the first differing field. Ignores source times.
class Comparer {
 public:
  std::string diff;
  template <typename A>
  void Field(const char* name, const A& got, const A& want) {
    if (diff.empty() && !(got == want)) diff = name;
  }
  void Str(const char* name, const char* got, const char* want, std::size_t size) {
    if (diff.empty() && std::strncmp(got, want, size) != 0) diff = name;
  }
  void Header(const hexa_msg_SampleHeader& g, const hexa_msg_SampleHeader& w) {
    Field("header.tick", g.tick, w.tick);
    Field("header.sim_time_s", g.sim_time_s, w.sim_time_s);
  }
  template <typename A, std::size_t N>
  void Array(const char* name, const A (&g)[N], const A (&w)[N]) {
    for (std::size_t i = 0; i < N; ++i) Field(name, g[i], w[i]);
  }
};

inline std::string Diff(const hexa_msg_LegSensors& g, const hexa_msg_LegSensors& w) {
  Comparer c;
  c.Field("leg_id", g.leg_id, w.leg_id);
  c.Header(g.header, w.header);
  c.Field("length_m", g.length_m, w.length_m);
  c.Field("cap_pressure_pa", g.cap_pressure_pa, w.cap_pressure_pa);
  c.Field("rod_pressure_pa", g.rod_pressure_pa, w.rod_pressure_pa);
  c.Field("supply_pressure_pa", g.supply_pressure_pa, w.supply_pressure_pa);
  c.Field("relayed_present", g.relayed_present, w.relayed_present);
  c.Field("relayed_tick", g.relayed_tick, w.relayed_tick);
  c.Array("relayed_valid", g.relayed_valid, w.relayed_valid);
  c.Array("relayed_force_n", g.relayed_force_n, w.relayed_force_n);
  c.Array("relayed_rate_n_s", g.relayed_rate_n_s, w.relayed_rate_n_s);
  return c.diff;
}
inline std::string Diff(const hexa_msg_ValveCommand& g, const hexa_msg_ValveCommand& w) {
  Comparer c;
  c.Field("leg_id", g.leg_id, w.leg_id);
  c.Header(g.header, w.header);
  c.Field("valve_v", g.valve_v, w.valve_v);
  c.Field("controller", g.controller, w.controller);
  c.Field("status", g.status, w.status);
  c.Field("standby", g.standby, w.standby);
  c.Field("setpoint_tick", g.setpoint_tick, w.setpoint_tick);
  c.Field("desired_length_m", g.desired_length_m, w.desired_length_m);
  c.Field("sliding_surface_m_s", g.sliding_surface_m_s, w.sliding_surface_m_s);
  c.Field("compute_time_s", g.compute_time_s, w.compute_time_s);
  c.Field("friction_scale", g.friction_scale, w.friction_scale);
  c.Field("feedback_valid", g.feedback_valid, w.feedback_valid);
  c.Field("feedback_force_n", g.feedback_force_n, w.feedback_force_n);
  c.Field("feedback_rate_n_s", g.feedback_rate_n_s, w.feedback_rate_n_s);
  c.Field("coupled", g.coupled, w.coupled);
  return c.diff;
}
inline std::string Diff(const hexa_msg_ImuSample& g, const hexa_msg_ImuSample& w) {
  Comparer c;
  c.Header(g.header, w.header);
  c.Array("orientation_wxyz", g.orientation_wxyz, w.orientation_wxyz);
  c.Array("angular_rate_rad_s", g.angular_rate_rad_s, w.angular_rate_rad_s);
  return c.diff;
}
inline std::string Diff(const hexa_msg_LegSetpoint& g, const hexa_msg_LegSetpoint& w) {
  Comparer c;
  c.Field("leg_id", g.leg_id, w.leg_id);
  c.Header(g.header, w.header);
  c.Field("length_m", g.length_m, w.length_m);
  c.Field("velocity_m_s", g.velocity_m_s, w.velocity_m_s);
  c.Field("acceleration_m_s2", g.acceleration_m_s2, w.acceleration_m_s2);
  c.Field("correction_m", g.correction_m, w.correction_m);
  c.Field("hold", g.hold, w.hold);
  return c.diff;
}
inline std::string Diff(const hexa_msg_PoseReport& g, const hexa_msg_PoseReport& w) {
  Comparer c;
  c.Header(g.header, w.header);
  c.Field("state", g.state, w.state);
  c.Field("trajectory_time_s", g.trajectory_time_s, w.trajectory_time_s);
  c.Array("desired_pose", g.desired_pose, w.desired_pose);
  c.Array("estimated_pose", g.estimated_pose, w.estimated_pose);
  c.Array("error_pose", g.error_pose, w.error_pose);
  c.Field("estimator_status", g.estimator_status, w.estimator_status);
  c.Field("excluded_leg", g.excluded_leg, w.excluded_leg);
  return c.diff;
}
inline std::string Diff(const hexa_msg_GroundTruth& g, const hexa_msg_GroundTruth& w) {
  Comparer c;
  c.Header(g.header, w.header);
  c.Array("position_m", g.position_m, w.position_m);
  c.Array("orientation_wxyz", g.orientation_wxyz, w.orientation_wxyz);
  c.Array("linear_velocity_m_s", g.linear_velocity_m_s, w.linear_velocity_m_s);
  c.Array("angular_velocity_rad_s", g.angular_velocity_rad_s, w.angular_velocity_rad_s);
  c.Array("leg_length_m", g.leg_length_m, w.leg_length_m);
  c.Array("piston_velocity_m_s", g.piston_velocity_m_s, w.piston_velocity_m_s);
  c.Array("cap_pressure_pa", g.cap_pressure_pa, w.cap_pressure_pa);
  c.Array("rod_pressure_pa", g.rod_pressure_pa, w.rod_pressure_pa);
  c.Array("spool_position_m", g.spool_position_m, w.spool_position_m);
  c.Array("applied_valve_v", g.applied_valve_v, w.applied_valve_v);
  return c.diff;
}
inline std::string Diff(const hexa_msg_TrackerPose& g, const hexa_msg_TrackerPose& w) {
  Comparer c;
  c.Header(g.header, w.header);
  c.Array("position_m", g.position_m, w.position_m);
  c.Array("orientation_wxyz", g.orientation_wxyz, w.orientation_wxyz);
  return c.diff;
}
inline std::string Diff(const hexa_msg_OperatorCommand& g, const hexa_msg_OperatorCommand& w) {
  Comparer c;
  c.Field("sequence", g.sequence, w.sequence);
  c.Field("kind", g.kind, w.kind);
  c.Str("trajectory", g.trajectory, w.trajectory, sizeof g.trajectory);
  c.Str("csv_path", g.csv_path, w.csv_path, sizeof g.csv_path);
  return c.diff;
}
inline std::string Diff(const hexa_msg_NodeStatus& g, const hexa_msg_NodeStatus& w) {
  Comparer c;
  c.Str("node_name", g.node_name, w.node_name, sizeof g.node_name);
  c.Header(g.header, w.header);
  c.Field("state", g.state, w.state);
  c.Field("deadline_missed_total", g.deadline_missed_total, w.deadline_missed_total);
  c.Field("liveliness_changes_total", g.liveliness_changes_total, w.liveliness_changes_total);
  c.Field("cycles_total", g.cycles_total, w.cycles_total);
  c.Field("cycle_time_median_s", g.cycle_time_median_s, w.cycle_time_median_s);
  c.Field("cycle_time_max_s", g.cycle_time_max_s, w.cycle_time_max_s);
  c.Str("detail", g.detail, w.detail, sizeof g.detail);
  return c.diff;
}
inline std::string Diff(const hexa_msg_FaultEvent& g, const hexa_msg_FaultEvent& w) {
  Comparer c;
  c.Str("source_node", g.source_node, w.source_node, sizeof g.source_node);
  c.Field("leg_id", g.leg_id, w.leg_id);
  c.Field("tick", g.tick, w.tick);
  c.Field("reason", g.reason, w.reason);
  c.Str("detail", g.detail, w.detail, sizeof g.detail);
  return c.diff;
}

}  // namespace hexa::comm::test
