// DDS C structs (hexa.h) <-> recording protobuf messages, field by field, both directions, for
// every wire type; plus the cases FromProto must refuse.
#include <gtest/gtest.h>

#include <cstring>

#include "hexa/recording/convert.hpp"

namespace hexa::recorder {
namespace {

hexa_msg_SampleHeader Header(uint64_t tick) {
  return hexa_msg_SampleHeader{tick, 0.001 * static_cast<double>(tick),
                               1'700'000'000'123'456'789LL + static_cast<int64_t>(tick)};
}
void ExpectHeader(const rec::SampleHeader& p, const hexa_msg_SampleHeader& d) {
  EXPECT_EQ(p.tick(), d.tick);
  EXPECT_EQ(p.sim_time_s(), d.sim_time_s);
  EXPECT_EQ(p.source_time_ns(), d.source_time_ns);
}
void ExpectHeader(const hexa_msg_SampleHeader& a, const hexa_msg_SampleHeader& b) {
  EXPECT_EQ(a.tick, b.tick);
  EXPECT_EQ(a.sim_time_s, b.sim_time_s);
  EXPECT_EQ(a.source_time_ns, b.source_time_ns);
}
template <typename T>
T Zeroed() {
  T t;
  std::memset(&t, 0, sizeof t);
  return t;
}

TEST(Convert, LegSensorsBothWays) {
  hexa_msg_LegSensors d{};
  d.leg_id = 4;
  d.header = Header(77);
  d.length_m = 0.51;
  d.cap_pressure_pa = 4.1e5;
  d.rod_pressure_pa = 3.2e5;
  d.supply_pressure_pa = 7.05e5;
  rec::LegSensors p;
  ToProto(d, p);
  EXPECT_EQ(p.leg_id(), 4u);
  ExpectHeader(p.header(), d.header);
  EXPECT_EQ(p.length_m(), 0.51);
  EXPECT_EQ(p.cap_pressure_pa(), 4.1e5);
  EXPECT_EQ(p.rod_pressure_pa(), 3.2e5);
  EXPECT_EQ(p.supply_pressure_pa(), 7.05e5);
  auto b = Zeroed<hexa_msg_LegSensors>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.leg_id, 4);
  ExpectHeader(b.header, d.header);
  EXPECT_EQ(b.length_m, 0.51);
  EXPECT_EQ(b.cap_pressure_pa, 4.1e5);
  EXPECT_EQ(b.rod_pressure_pa, 3.2e5);
  EXPECT_EQ(b.supply_pressure_pa, 7.05e5);
  p.set_leg_id(256);  // does not fit an IDL octet
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, ValveCommandBothWays) {
  hexa_msg_ValveCommand d{};
  d.leg_id = 2;
  d.header = Header(12);
  d.valve_v = 6.25;
  d.controller = hexa_msg_CONTROLLER_PI;
  d.status = hexa_msg_LEGCTRL_HOLD_STALE_SETPOINT;
  d.standby = true;
  d.setpoint_tick = 10;
  d.desired_length_m = 0.49;
  d.sliding_surface_m_s = -0.02;
  d.compute_time_s = 3.5e-5;
  d.friction_scale = 1.2375;
  rec::ValveCommand p;
  ToProto(d, p);
  EXPECT_EQ(p.leg_id(), 2u);
  ExpectHeader(p.header(), d.header);
  EXPECT_EQ(p.valve_v(), 6.25);
  EXPECT_EQ(p.controller(), rec::CONTROLLER_PI);
  EXPECT_EQ(p.status(), rec::LEGCTRL_HOLD_STALE_SETPOINT);
  EXPECT_TRUE(p.standby());
  EXPECT_EQ(p.setpoint_tick(), 10u);
  EXPECT_EQ(p.desired_length_m(), 0.49);
  EXPECT_EQ(p.sliding_surface_m_s(), -0.02);
  EXPECT_EQ(p.compute_time_s(), 3.5e-5);
  ASSERT_TRUE(p.has_friction_scale());
  EXPECT_EQ(p.friction_scale(), 1.2375);
  auto b = Zeroed<hexa_msg_ValveCommand>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.leg_id, 2);
  ExpectHeader(b.header, d.header);
  EXPECT_EQ(b.valve_v, 6.25);
  EXPECT_EQ(b.controller, hexa_msg_CONTROLLER_PI);
  EXPECT_EQ(b.status, hexa_msg_LEGCTRL_HOLD_STALE_SETPOINT);
  EXPECT_TRUE(b.standby);
  EXPECT_EQ(b.setpoint_tick, 10u);
  EXPECT_EQ(b.desired_length_m, 0.49);
  EXPECT_EQ(b.sliding_surface_m_s, -0.02);
  EXPECT_EQ(b.compute_time_s, 3.5e-5);
  EXPECT_EQ(b.friction_scale, 1.2375);
  // A recording from before the field: theta reads as eq 14's nominal 1, not 0.
  p.clear_friction_scale();
  b.friction_scale = 0.75;
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.friction_scale, 1.0);
  // An explicit 0 is carried (presence, not value, tells an old recording apart).
  d.friction_scale = 0.0;
  ToProto(d, p);
  EXPECT_TRUE(p.has_friction_scale());
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.friction_scale, 0.0);
  p.set_status(static_cast<rec::LegCtrlStatus>(99));  // unknown enum value from a newer file
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, ImuSampleBothWays) {
  hexa_msg_ImuSample d{};
  d.header = Header(5);
  const double q[4] = {0.9, 0.1, -0.2, 0.3}, w[3] = {0.01, -0.02, 0.03};
  std::memcpy(d.orientation_wxyz, q, sizeof q);
  std::memcpy(d.angular_rate_rad_s, w, sizeof w);
  rec::ImuSample p;
  ToProto(d, p);
  ExpectHeader(p.header(), d.header);
  ASSERT_EQ(p.orientation_wxyz_size(), 4);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(p.orientation_wxyz(i), q[i]);
  ASSERT_EQ(p.angular_rate_rad_s_size(), 3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(p.angular_rate_rad_s(i), w[i]);
  auto b = Zeroed<hexa_msg_ImuSample>();
  ASSERT_TRUE(FromProto(p, b));
  ExpectHeader(b.header, d.header);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.orientation_wxyz[i], q[i]);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(b.angular_rate_rad_s[i], w[i]);
  p.add_orientation_wxyz(1.0);  // 5 values for a 4-array
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, LegSetpointBothWays) {
  hexa_msg_LegSetpoint d{};
  d.leg_id = 6;
  d.header = Header(100);
  d.length_m = 0.55;
  d.velocity_m_s = 0.3;
  d.acceleration_m_s2 = -1.5;
  d.correction_m = 2e-4;
  d.hold = true;
  d.feedforward_valid = true;
  d.feedforward_force_n = 23.5;
  d.feedforward_force_rate_n_s = -310.25;
  rec::LegSetpoint p;
  ToProto(d, p);
  EXPECT_EQ(p.leg_id(), 6u);
  ExpectHeader(p.header(), d.header);
  EXPECT_EQ(p.length_m(), 0.55);
  EXPECT_EQ(p.velocity_m_s(), 0.3);
  EXPECT_EQ(p.acceleration_m_s2(), -1.5);
  EXPECT_EQ(p.correction_m(), 2e-4);
  EXPECT_TRUE(p.hold());
  EXPECT_TRUE(p.feedforward_valid());
  EXPECT_EQ(p.feedforward_force_n(), 23.5);
  EXPECT_EQ(p.feedforward_force_rate_n_s(), -310.25);
  auto b = Zeroed<hexa_msg_LegSetpoint>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.leg_id, 6);
  ExpectHeader(b.header, d.header);
  EXPECT_EQ(b.length_m, 0.55);
  EXPECT_EQ(b.velocity_m_s, 0.3);
  EXPECT_EQ(b.acceleration_m_s2, -1.5);
  EXPECT_EQ(b.correction_m, 2e-4);
  EXPECT_TRUE(b.hold);
  EXPECT_TRUE(b.feedforward_valid);
  EXPECT_EQ(b.feedforward_force_n, 23.5);
  EXPECT_EQ(b.feedforward_force_rate_n_s, -310.25);
}

TEST(Convert, PoseReportBothWays) {
  hexa_msg_PoseReport d{};
  d.header = Header(200);
  d.state = hexa_msg_SUPERVISOR_HOLD;
  d.trajectory_time_s = 1.25;
  for (int i = 0; i < 6; ++i) {
    d.desired_pose[i] = 0.1 * (i + 1);
    d.estimated_pose[i] = -0.1 * (i + 1);
    d.error_pose[i] = 0.01 * (i + 1);
  }
  d.estimator_status = 3;
  d.excluded_leg = -1;
  rec::PoseReport p;
  ToProto(d, p);
  ExpectHeader(p.header(), d.header);
  EXPECT_EQ(p.state(), rec::SUPERVISOR_HOLD);
  EXPECT_EQ(p.trajectory_time_s(), 1.25);
  ASSERT_EQ(p.desired_pose_size(), 6);
  ASSERT_EQ(p.estimated_pose_size(), 6);
  ASSERT_EQ(p.error_pose_size(), 6);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(p.desired_pose(i), d.desired_pose[i]);
    EXPECT_EQ(p.estimated_pose(i), d.estimated_pose[i]);
    EXPECT_EQ(p.error_pose(i), d.error_pose[i]);
  }
  EXPECT_EQ(p.estimator_status(), 3u);
  EXPECT_EQ(p.excluded_leg(), -1);
  auto b = Zeroed<hexa_msg_PoseReport>();
  ASSERT_TRUE(FromProto(p, b));
  ExpectHeader(b.header, d.header);
  EXPECT_EQ(b.state, hexa_msg_SUPERVISOR_HOLD);
  EXPECT_EQ(b.trajectory_time_s, 1.25);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(b.desired_pose[i], d.desired_pose[i]);
    EXPECT_EQ(b.estimated_pose[i], d.estimated_pose[i]);
    EXPECT_EQ(b.error_pose[i], d.error_pose[i]);
  }
  EXPECT_EQ(b.estimator_status, 3);
  EXPECT_EQ(b.excluded_leg, -1);
  p.set_excluded_leg(200);  // outside int8
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, GroundTruthBothWays) {
  hexa_msg_GroundTruth d{};
  d.header = Header(300);
  double v = 0.0;
  auto fill = [&v](double* a, int n) {
    for (int i = 0; i < n; ++i) a[i] = (v += 0.5);
  };
  fill(d.position_m, 3);
  fill(d.orientation_wxyz, 4);
  fill(d.linear_velocity_m_s, 3);
  fill(d.angular_velocity_rad_s, 3);
  fill(d.leg_length_m, 6);
  fill(d.piston_velocity_m_s, 6);
  fill(d.cap_pressure_pa, 6);
  fill(d.rod_pressure_pa, 6);
  fill(d.spool_position_m, 6);
  fill(d.applied_valve_v, 6);
  rec::GroundTruth p;
  ToProto(d, p);
  ExpectHeader(p.header(), d.header);
  auto expect_array = [](const google::protobuf::RepeatedField<double>& r, const double* a, int n) {
    ASSERT_EQ(r.size(), n);
    for (int i = 0; i < n; ++i) EXPECT_EQ(r.Get(i), a[i]);
  };
  expect_array(p.position_m(), d.position_m, 3);
  expect_array(p.orientation_wxyz(), d.orientation_wxyz, 4);
  expect_array(p.linear_velocity_m_s(), d.linear_velocity_m_s, 3);
  expect_array(p.angular_velocity_rad_s(), d.angular_velocity_rad_s, 3);
  expect_array(p.leg_length_m(), d.leg_length_m, 6);
  expect_array(p.piston_velocity_m_s(), d.piston_velocity_m_s, 6);
  expect_array(p.cap_pressure_pa(), d.cap_pressure_pa, 6);
  expect_array(p.rod_pressure_pa(), d.rod_pressure_pa, 6);
  expect_array(p.spool_position_m(), d.spool_position_m, 6);
  expect_array(p.applied_valve_v(), d.applied_valve_v, 6);
  auto b = Zeroed<hexa_msg_GroundTruth>();
  ASSERT_TRUE(FromProto(p, b));
  // Every field is a double array after the header: the structs must be bit-identical.
  EXPECT_EQ(std::memcmp(&b, &d, sizeof d), 0);
  p.mutable_spool_position_m()->RemoveLast();
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, OperatorCommandBothWays) {
  auto d = Zeroed<hexa_msg_OperatorCommand>();
  d.sequence = 9;
  d.kind = hexa_msg_OPERATOR_HOME;
  std::strcpy(d.trajectory, "csv");
  std::strcpy(d.csv_path, "/data/traj.csv");
  d.source_time_ns = -5;
  for (int k = 0; k < 3; ++k) {
    d.pivot_m[k] = 0.1 * (k + 1);
    d.tool_position_m[k] = -0.01 * (k + 1);
    d.work_position_m[k] = 0.2 + k;
  }
  for (int k = 0; k < 4; ++k) {
    d.tool_orientation_wxyz[k] = 0.5;
    d.work_orientation_wxyz[k] = k == 0 ? 1.0 : 0.0;
  }
  rec::OperatorCommand p;
  ToProto(d, p);
  EXPECT_EQ(p.sequence(), 9u);
  ASSERT_EQ(p.pivot_m_size(), 3);
  EXPECT_EQ(p.pivot_m(2), 0.1 * 3);
  ASSERT_EQ(p.work_orientation_wxyz_size(), 4);
  EXPECT_EQ(p.tool_orientation_wxyz(1), 0.5);
  EXPECT_EQ(p.kind(), rec::OPERATOR_HOME);
  EXPECT_EQ(p.trajectory(), "csv");
  EXPECT_EQ(p.csv_path(), "/data/traj.csv");
  EXPECT_EQ(p.source_time_ns(), -5);
  auto b = Zeroed<hexa_msg_OperatorCommand>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(std::memcmp(&b, &d, sizeof d), 0);
  p.set_trajectory(std::string(65, 'x'));  // string<64>
  EXPECT_FALSE(FromProto(p, b));
  p.set_trajectory(std::string(64, 'x'));
  EXPECT_TRUE(FromProto(p, b));
  // A command recorded before the frames' fields existed: they read as zero.
  p.clear_pivot_m();
  p.clear_tool_position_m();
  p.clear_tool_orientation_wxyz();
  p.clear_work_position_m();
  p.clear_work_orientation_wxyz();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(b.pivot_m[2], 0.0);
  EXPECT_EQ(b.work_orientation_wxyz[0], 0.0);
  p.add_pivot_m(1.0);  // one value where three belong
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, NodeStatusBothWays) {
  auto d = Zeroed<hexa_msg_NodeStatus>();
  std::strcpy(d.node_name, "leg_ctrl_3");
  d.header = Header(400);
  d.state = hexa_msg_NODE_FAULT;
  d.deadline_missed_total = 17;
  d.liveliness_changes_total = 2;
  d.cycles_total = 123456789;
  d.cycle_time_median_s = 2.5e-5;
  d.cycle_time_max_s = 4e-4;
  std::strcpy(d.detail, "setpoint stale");
  rec::NodeStatus p;
  ToProto(d, p);
  EXPECT_EQ(p.node_name(), "leg_ctrl_3");
  ExpectHeader(p.header(), d.header);
  EXPECT_EQ(p.state(), rec::NODE_FAULT);
  EXPECT_EQ(p.deadline_missed_total(), 17u);
  EXPECT_EQ(p.liveliness_changes_total(), 2u);
  EXPECT_EQ(p.cycles_total(), 123456789u);
  EXPECT_EQ(p.cycle_time_median_s(), 2.5e-5);
  EXPECT_EQ(p.cycle_time_max_s(), 4e-4);
  EXPECT_EQ(p.detail(), "setpoint stale");
  auto b = Zeroed<hexa_msg_NodeStatus>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_STREQ(b.node_name, "leg_ctrl_3");
  ExpectHeader(b.header, d.header);
  EXPECT_EQ(b.state, hexa_msg_NODE_FAULT);
  EXPECT_EQ(b.deadline_missed_total, 17u);
  EXPECT_EQ(b.liveliness_changes_total, 2u);
  EXPECT_EQ(b.cycles_total, 123456789u);
  EXPECT_EQ(b.cycle_time_median_s, 2.5e-5);
  EXPECT_EQ(b.cycle_time_max_s, 4e-4);
  EXPECT_STREQ(b.detail, "setpoint stale");
  p.set_node_name(std::string(33, 'n'));  // string<32>
  EXPECT_FALSE(FromProto(p, b));
}

TEST(Convert, FaultEventBothWays) {
  auto d = Zeroed<hexa_msg_FaultEvent>();
  std::strcpy(d.source_node, "plant_sim");
  d.leg_id = 5;
  d.tick = 4242;
  d.reason = hexa_msg_FAULT_TRAJECTORY_REJECTED;
  std::strcpy(d.detail, "leg 5 exceeds stroke by 3 mm at t=1.2 s");
  d.source_time_ns = 99;
  rec::FaultEvent p;
  ToProto(d, p);
  EXPECT_EQ(p.source_node(), "plant_sim");
  EXPECT_EQ(p.leg_id(), 5u);
  EXPECT_EQ(p.tick(), 4242u);
  EXPECT_EQ(p.reason(), rec::FAULT_TRAJECTORY_REJECTED);
  EXPECT_EQ(p.detail(), "leg 5 exceeds stroke by 3 mm at t=1.2 s");
  EXPECT_EQ(p.source_time_ns(), 99);
  auto b = Zeroed<hexa_msg_FaultEvent>();
  ASSERT_TRUE(FromProto(p, b));
  EXPECT_EQ(std::memcmp(&b, &d, sizeof d), 0);
  p.set_reason(static_cast<rec::FaultReason>(99));  // no such reason
  EXPECT_FALSE(FromProto(p, b));
}

// Any process may publish bytes that are not UTF-8 in a string field (a CSV of random
// bytes ended up in FaultEvent.detail). The recorded protobuf must still parse: proto3 parsers
// reject invalid UTF-8, so ToProto sanitises. Clean text is kept exactly (FaultEventBothWays).
TEST(Convert, StringsThatAreNotUtf8AreRecordedReadably) {
  auto f = Zeroed<hexa_msg_FaultEvent>();
  std::strcpy(f.source_node, "supervisor\xff");
  std::strcpy(f.detail, "trajectory.csv:1: bad header \"\xc0\xaf\x80\xfe\x1b[2J\"");
  rec::FaultEvent p;
  ToProto(f, p);
  rec::FaultEvent back;
  ASSERT_TRUE(back.ParseFromString(p.SerializeAsString()));
  EXPECT_EQ(back.detail().rfind("trajectory.csv:1: bad header \"", 0), 0u) << back.detail();
  EXPECT_EQ(back.detail().find('\x1b'), std::string::npos);
  auto n = Zeroed<hexa_msg_NodeStatus>();
  std::memset(n.detail, '\xe2', sizeof n.detail - 1);  // 160 bytes of truncated sequences
  rec::NodeStatus np;
  ToProto(n, np);
  rec::NodeStatus nback;
  ASSERT_TRUE(nback.ParseFromString(np.SerializeAsString()));
  EXPECT_LE(nback.detail().size(), 160u);
  auto c = Zeroed<hexa_msg_OperatorCommand>();
  std::strcpy(c.csv_path, "/tmp/\xff.csv");
  rec::OperatorCommand cp;
  ToProto(c, cp);
  rec::OperatorCommand cback;
  ASSERT_TRUE(cback.ParseFromString(cp.SerializeAsString()));
}

TEST(Convert, RegistryCoversEveryPublishedTypeAndDispatchesToTheTypedFunctions) {
  const auto& types = WireTypes();
  ASSERT_EQ(types.size(), 10u);  // every IDL struct but SampleHeader
  for (const auto& t : types) {
    EXPECT_EQ(FindWireType(t.name), &t);
    EXPECT_EQ(FindWireType(t.prototype->GetDescriptor()->full_name()), &t);
    EXPECT_EQ(std::string(t.dds_descriptor->m_typename), "hexa::msg::" + std::string(t.name));
    EXPECT_EQ(t.prototype->GetDescriptor()->name(), t.name);
  }
  EXPECT_EQ(FindWireType("NoSuchType"), nullptr);
  hexa_msg_LegSensors d{};
  d.leg_id = 3;
  d.header = Header(8);
  d.length_m = 0.4;
  const WireType* t = FindWireType("LegSensors");
  std::unique_ptr<google::protobuf::Message> m(t->prototype->New());
  t->to_proto(&d, *m);
  EXPECT_EQ(static_cast<const rec::LegSensors&>(*m).length_m(), 0.4);
  hexa_msg_LegSensors back{};
  ASSERT_TRUE(t->from_proto(*m, &back));
  EXPECT_EQ(back.leg_id, 3);
  // A message of another type is refused, not reinterpreted.
  rec::ValveCommand other;
  EXPECT_FALSE(t->from_proto(other, &back));
}

}  // namespace
}  // namespace hexa::recorder
