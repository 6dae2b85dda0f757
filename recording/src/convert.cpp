// The one mapping between DDS samples and recording protobuf messages (see convert.hpp).
// Field order follows idl/hexa.idl; every IDL field appears once in each direction.
#include "hexa/recording/convert.hpp"

#include <cstring>
#include <limits>
#include <string>

#include "hexa/recording/topic_types.hpp"
#include "hexa/services/text.hpp"

namespace hexa::recorder {
namespace {

template <typename V, size_t N>
void ArrayToProto(const V (&in)[N], google::protobuf::RepeatedField<V>* out) {
  out->Clear();
  out->Reserve(static_cast<int>(N));
  for (V v : in) out->Add(v);
}

template <typename V, size_t N>
bool ArrayFromProto(const google::protobuf::RepeatedField<V>& in, V (&out)[N]) {
  if (in.size() != static_cast<int>(N)) return false;
  for (size_t i = 0; i < N; ++i) out[i] = in.Get(static_cast<int>(i));
  return true;
}

// A field added to the wire type after recordings existed: absent (empty) in an older
// recording, where every element is `absent`.
template <typename V, size_t N>
bool OptionalArrayFromProto(const google::protobuf::RepeatedField<V>& in, V (&out)[N], V absent) {
  if (in.empty()) {
    for (V& v : out) v = absent;
    return true;
  }
  return ArrayFromProto(in, out);
}

// IDL bounded strings are NUL-terminated char arrays of bound + 1. Any process on the domain
// may have written them: a proto3 string must be valid UTF-8 or the recorded message cannot be
// parsed again, so the text is sanitised here (docs/robustness.md). Clean text is unchanged.
template <size_t N>
std::string StringToProto(const char (&in)[N]) {
  const std::string_view raw(in, strnlen(in, N));
  return text::Sanitize(raw, N - 1);
}

template <size_t N>
bool StringFromProto(const std::string& in, char (&out)[N]) {
  if (in.size() >= N || in.find('\0') != std::string::npos) return false;
  std::memset(out, 0, N);
  std::memcpy(out, in.data(), in.size());
  return true;
}

bool OctetFromProto(uint32_t in, uint8_t& out) {
  if (in > 255u) return false;
  out = static_cast<uint8_t>(in);
  return true;
}

template <typename DdsMsg, typename ProtoMsg>
WireType MakeWireType(std::string_view name, const dds_topic_descriptor_t* desc) {
  return WireType{
      name, desc, sizeof(DdsMsg), &ProtoMsg::default_instance(),
      [](const void* sample, google::protobuf::Message& out) {
        ToProto(*static_cast<const DdsMsg*>(sample), static_cast<ProtoMsg&>(out));
      },
      [](const google::protobuf::Message& in, void* sample) {
        if (in.GetDescriptor() != ProtoMsg::descriptor()) return false;
        return FromProto(static_cast<const ProtoMsg&>(in), *static_cast<DdsMsg*>(sample));
      }};
}

}  // namespace

// ---------------------------------------------------------------- DDS -> protobuf
void ToProto(const hexa_msg_SampleHeader& in, rec::SampleHeader& out) {
  out.set_tick(in.tick);
  out.set_sim_time_s(in.sim_time_s);
  out.set_source_time_ns(in.source_time_ns);
}

void ToProto(const hexa_msg_LegSensors& in, rec::LegSensors& out) {
  out.set_leg_id(in.leg_id);
  ToProto(in.header, *out.mutable_header());
  out.set_length_m(in.length_m);
  out.set_cap_pressure_pa(in.cap_pressure_pa);
  out.set_rod_pressure_pa(in.rod_pressure_pa);
  out.set_supply_pressure_pa(in.supply_pressure_pa);
}

void ToProto(const hexa_msg_ValveCommand& in, rec::ValveCommand& out) {
  out.set_leg_id(in.leg_id);
  ToProto(in.header, *out.mutable_header());
  out.set_valve_v(in.valve_v);
  out.set_controller(static_cast<rec::ControllerKind>(in.controller));
  out.set_status(static_cast<rec::LegCtrlStatus>(in.status));
  out.set_standby(in.standby);
  out.set_setpoint_tick(in.setpoint_tick);
  out.set_desired_length_m(in.desired_length_m);
  out.set_sliding_surface_m_s(in.sliding_surface_m_s);
  out.set_friction_scale(in.friction_scale);
  out.set_coupled(in.coupled);
  out.set_compute_time_s(in.compute_time_s);
}

void ToProto(const hexa_msg_ImuSample& in, rec::ImuSample& out) {
  ToProto(in.header, *out.mutable_header());
  ArrayToProto(in.orientation_wxyz, out.mutable_orientation_wxyz());
  ArrayToProto(in.angular_rate_rad_s, out.mutable_angular_rate_rad_s());
}

void ToProto(const hexa_msg_LegSetpoint& in, rec::LegSetpoint& out) {
  out.set_leg_id(in.leg_id);
  ToProto(in.header, *out.mutable_header());
  out.set_length_m(in.length_m);
  out.set_velocity_m_s(in.velocity_m_s);
  out.set_acceleration_m_s2(in.acceleration_m_s2);
  out.set_correction_m(in.correction_m);
  out.set_hold(in.hold);
  out.set_feedforward_valid(in.feedforward_valid);
  out.set_feedforward_force_n(in.feedforward_force_n);
  out.set_feedforward_force_rate_n_s(in.feedforward_force_rate_n_s);
}

void ToProto(const hexa_msg_PoseReport& in, rec::PoseReport& out) {
  ToProto(in.header, *out.mutable_header());
  out.set_state(static_cast<rec::SupervisorState>(in.state));
  out.set_trajectory_time_s(in.trajectory_time_s);
  ArrayToProto(in.desired_pose, out.mutable_desired_pose());
  ArrayToProto(in.estimated_pose, out.mutable_estimated_pose());
  ArrayToProto(in.error_pose, out.mutable_error_pose());
  out.set_estimator_status(in.estimator_status);
  out.set_excluded_leg(in.excluded_leg);
}

void ToProto(const hexa_msg_GroundTruth& in, rec::GroundTruth& out) {
  ToProto(in.header, *out.mutable_header());
  ArrayToProto(in.position_m, out.mutable_position_m());
  ArrayToProto(in.orientation_wxyz, out.mutable_orientation_wxyz());
  ArrayToProto(in.linear_velocity_m_s, out.mutable_linear_velocity_m_s());
  ArrayToProto(in.angular_velocity_rad_s, out.mutable_angular_velocity_rad_s());
  ArrayToProto(in.leg_length_m, out.mutable_leg_length_m());
  ArrayToProto(in.piston_velocity_m_s, out.mutable_piston_velocity_m_s());
  ArrayToProto(in.cap_pressure_pa, out.mutable_cap_pressure_pa());
  ArrayToProto(in.rod_pressure_pa, out.mutable_rod_pressure_pa());
  ArrayToProto(in.spool_position_m, out.mutable_spool_position_m());
  ArrayToProto(in.applied_valve_v, out.mutable_applied_valve_v());
  ArrayToProto(in.command_age_ticks, out.mutable_command_age_ticks());
}

void ToProto(const hexa_msg_TrackerPose& in, rec::TrackerPose& out) {
  ToProto(in.header, *out.mutable_header());
  ArrayToProto(in.position_m, out.mutable_position_m());
  ArrayToProto(in.orientation_wxyz, out.mutable_orientation_wxyz());
}

void ToProto(const hexa_msg_OperatorCommand& in, rec::OperatorCommand& out) {
  out.set_sequence(in.sequence);
  out.set_kind(static_cast<rec::OperatorCommandKind>(in.kind));
  out.set_trajectory(StringToProto(in.trajectory));
  out.set_csv_path(StringToProto(in.csv_path));
  out.set_source_time_ns(in.source_time_ns);
  out.set_jog_frame(static_cast<rec::JogFrame>(in.jog_frame));
  ArrayToProto(in.jog_velocity_m_s, out.mutable_jog_velocity_m_s());
  ArrayToProto(in.jog_angular_velocity_rad_s, out.mutable_jog_angular_velocity_rad_s());
  ArrayToProto(in.goal_position_m, out.mutable_goal_position_m());
  ArrayToProto(in.goal_orientation_wxyz, out.mutable_goal_orientation_wxyz());
  ArrayToProto(in.pivot_m, out.mutable_pivot_m());
  ArrayToProto(in.tool_position_m, out.mutable_tool_position_m());
  ArrayToProto(in.tool_orientation_wxyz, out.mutable_tool_orientation_wxyz());
  ArrayToProto(in.work_position_m, out.mutable_work_position_m());
  ArrayToProto(in.work_orientation_wxyz, out.mutable_work_orientation_wxyz());
}

void ToProto(const hexa_msg_NodeStatus& in, rec::NodeStatus& out) {
  out.set_node_name(StringToProto(in.node_name));
  ToProto(in.header, *out.mutable_header());
  out.set_state(static_cast<rec::NodeState>(in.state));
  out.set_deadline_missed_total(in.deadline_missed_total);
  out.set_liveliness_changes_total(in.liveliness_changes_total);
  out.set_cycles_total(in.cycles_total);
  out.set_cycle_time_median_s(in.cycle_time_median_s);
  out.set_cycle_time_max_s(in.cycle_time_max_s);
  out.set_detail(StringToProto(in.detail));
}

void ToProto(const hexa_msg_FaultEvent& in, rec::FaultEvent& out) {
  out.set_source_node(StringToProto(in.source_node));
  out.set_leg_id(in.leg_id);
  out.set_tick(in.tick);
  out.set_reason(static_cast<rec::FaultReason>(in.reason));
  out.set_detail(StringToProto(in.detail));
  out.set_source_time_ns(in.source_time_ns);
}

// ---------------------------------------------------------------- protobuf -> DDS
bool FromProto(const rec::SampleHeader& in, hexa_msg_SampleHeader& out) {
  out.tick = in.tick();
  out.sim_time_s = in.sim_time_s();
  out.source_time_ns = in.source_time_ns();
  return true;
}

bool FromProto(const rec::LegSensors& in, hexa_msg_LegSensors& out) {
  out.length_m = in.length_m();
  out.cap_pressure_pa = in.cap_pressure_pa();
  out.rod_pressure_pa = in.rod_pressure_pa();
  out.supply_pressure_pa = in.supply_pressure_pa();
  return OctetFromProto(in.leg_id(), out.leg_id) && FromProto(in.header(), out.header);
}

bool FromProto(const rec::ValveCommand& in, hexa_msg_ValveCommand& out) {
  if (!rec::ControllerKind_IsValid(in.controller()) || !rec::LegCtrlStatus_IsValid(in.status()))
    return false;
  out.valve_v = in.valve_v();
  out.controller = static_cast<hexa_msg_ControllerKind>(in.controller());
  out.status = static_cast<hexa_msg_LegCtrlStatus>(in.status());
  out.standby = in.standby();
  out.setpoint_tick = in.setpoint_tick();
  out.desired_length_m = in.desired_length_m();
  out.sliding_surface_m_s = in.sliding_surface_m_s();
  // A recording from before the field: theta unknown, read as eq 14's nominal 1.
  out.friction_scale = in.has_friction_scale() ? in.friction_scale() : 1.0;
  out.compute_time_s = in.compute_time_s();
  out.coupled = in.coupled();
  return OctetFromProto(in.leg_id(), out.leg_id) && FromProto(in.header(), out.header);
}

bool FromProto(const rec::ImuSample& in, hexa_msg_ImuSample& out) {
  return FromProto(in.header(), out.header) &&
         ArrayFromProto(in.orientation_wxyz(), out.orientation_wxyz) &&
         ArrayFromProto(in.angular_rate_rad_s(), out.angular_rate_rad_s);
}

bool FromProto(const rec::LegSetpoint& in, hexa_msg_LegSetpoint& out) {
  out.length_m = in.length_m();
  out.velocity_m_s = in.velocity_m_s();
  out.acceleration_m_s2 = in.acceleration_m_s2();
  out.correction_m = in.correction_m();
  out.hold = in.hold();
  out.feedforward_valid = in.feedforward_valid();
  out.feedforward_force_n = in.feedforward_force_n();
  out.feedforward_force_rate_n_s = in.feedforward_force_rate_n_s();
  return OctetFromProto(in.leg_id(), out.leg_id) && FromProto(in.header(), out.header);
}

bool FromProto(const rec::PoseReport& in, hexa_msg_PoseReport& out) {
  if (!rec::SupervisorState_IsValid(in.state())) return false;
  if (in.excluded_leg() < std::numeric_limits<int8_t>::min() ||
      in.excluded_leg() > std::numeric_limits<int8_t>::max())
    return false;
  out.state = static_cast<hexa_msg_SupervisorState>(in.state());
  out.trajectory_time_s = in.trajectory_time_s();
  out.excluded_leg = static_cast<int8_t>(in.excluded_leg());
  return FromProto(in.header(), out.header) &&
         ArrayFromProto(in.desired_pose(), out.desired_pose) &&
         ArrayFromProto(in.estimated_pose(), out.estimated_pose) &&
         ArrayFromProto(in.error_pose(), out.error_pose) &&
         OctetFromProto(in.estimator_status(), out.estimator_status);
}

bool FromProto(const rec::TrackerPose& in, hexa_msg_TrackerPose& out) {
  return FromProto(in.header(), out.header) && ArrayFromProto(in.position_m(), out.position_m) &&
         ArrayFromProto(in.orientation_wxyz(), out.orientation_wxyz);
}

bool FromProto(const rec::GroundTruth& in, hexa_msg_GroundTruth& out) {
  return FromProto(in.header(), out.header) && ArrayFromProto(in.position_m(), out.position_m) &&
         ArrayFromProto(in.orientation_wxyz(), out.orientation_wxyz) &&
         ArrayFromProto(in.linear_velocity_m_s(), out.linear_velocity_m_s) &&
         ArrayFromProto(in.angular_velocity_rad_s(), out.angular_velocity_rad_s) &&
         ArrayFromProto(in.leg_length_m(), out.leg_length_m) &&
         ArrayFromProto(in.piston_velocity_m_s(), out.piston_velocity_m_s) &&
         ArrayFromProto(in.cap_pressure_pa(), out.cap_pressure_pa) &&
         ArrayFromProto(in.rod_pressure_pa(), out.rod_pressure_pa) &&
         ArrayFromProto(in.spool_position_m(), out.spool_position_m) &&
         ArrayFromProto(in.applied_valve_v(), out.applied_valve_v) &&
         OptionalArrayFromProto(in.command_age_ticks(), out.command_age_ticks, -1);
}

bool FromProto(const rec::OperatorCommand& in, hexa_msg_OperatorCommand& out) {
  if (!rec::OperatorCommandKind_IsValid(in.kind())) return false;
  out.sequence = in.sequence();
  out.kind = static_cast<hexa_msg_OperatorCommandKind>(in.kind());
  out.source_time_ns = in.source_time_ns();
  // Jog, goal and frames fields: absent (zero) in commands recorded before they existed.
  if (!rec::JogFrame_IsValid(in.jog_frame())) return false;
  out.jog_frame = static_cast<hexa_msg_JogFrame>(in.jog_frame());
  return StringFromProto(in.trajectory(), out.trajectory) &&
         StringFromProto(in.csv_path(), out.csv_path) &&
         OptionalArrayFromProto(in.jog_velocity_m_s(), out.jog_velocity_m_s, 0.0) &&
         OptionalArrayFromProto(in.jog_angular_velocity_rad_s(), out.jog_angular_velocity_rad_s, 0.0) &&
         OptionalArrayFromProto(in.goal_position_m(), out.goal_position_m, 0.0) &&
         OptionalArrayFromProto(in.goal_orientation_wxyz(), out.goal_orientation_wxyz, 0.0) &&
         OptionalArrayFromProto(in.pivot_m(), out.pivot_m, 0.0) &&
         OptionalArrayFromProto(in.tool_position_m(), out.tool_position_m, 0.0) &&
         OptionalArrayFromProto(in.tool_orientation_wxyz(), out.tool_orientation_wxyz, 0.0) &&
         OptionalArrayFromProto(in.work_position_m(), out.work_position_m, 0.0) &&
         OptionalArrayFromProto(in.work_orientation_wxyz(), out.work_orientation_wxyz, 0.0);
}

bool FromProto(const rec::NodeStatus& in, hexa_msg_NodeStatus& out) {
  if (!rec::NodeState_IsValid(in.state())) return false;
  out.state = static_cast<hexa_msg_NodeState>(in.state());
  out.deadline_missed_total = in.deadline_missed_total();
  out.liveliness_changes_total = in.liveliness_changes_total();
  out.cycles_total = in.cycles_total();
  out.cycle_time_median_s = in.cycle_time_median_s();
  out.cycle_time_max_s = in.cycle_time_max_s();
  return StringFromProto(in.node_name(), out.node_name) && FromProto(in.header(), out.header) &&
         StringFromProto(in.detail(), out.detail);
}

bool FromProto(const rec::FaultEvent& in, hexa_msg_FaultEvent& out) {
  if (!rec::FaultReason_IsValid(in.reason())) return false;
  out.tick = in.tick();
  out.reason = static_cast<hexa_msg_FaultReason>(in.reason());
  out.source_time_ns = in.source_time_ns();
  return StringFromProto(in.source_node(), out.source_node) &&
         OctetFromProto(in.leg_id(), out.leg_id) && StringFromProto(in.detail(), out.detail);
}

// ---------------------------------------------------------------- registry
const std::vector<WireType>& WireTypes() {
  static const std::vector<WireType> types = [] {
    std::vector<WireType> all;
    ForEachTopicType([&all](auto type) {
      using Type = decltype(type);
      all.push_back(MakeWireType<typename Type::Dds, typename Type::Proto>(
          Type::Proto::descriptor()->name(), Type::descriptor()));
    });
    return all;
  }();
  return types;
}

const WireType* FindWireType(std::string_view name) {
  for (const auto& t : WireTypes()) {
    if (name == t.name || name == t.prototype->GetDescriptor()->full_name()) return &t;
  }
  return nullptr;
}

}  // namespace hexa::recorder
