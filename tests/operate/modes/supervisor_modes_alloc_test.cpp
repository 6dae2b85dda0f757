// Supervisor::Update in the operator modes allocates nothing: a jog (messages, dead-man stop),
// a pose goal, a refused goal, a stopped goal and a stream (packets, duplicates, a timeout, a
// stop), on a kinematic plant (the measured lengths are
// the setpoints' lengths, the IMU the desired orientation). The allocations made while Update
// runs are counted (allocation_counter.hpp).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <gtest/gtest.h>

#include "allocation_counter.hpp"

#include "hexa/core/supervisor.hpp"

namespace {
using hexa::testing::t_allocations;
using hexa::testing::t_counting;
}  // namespace

namespace hexa {
namespace {

TEST(SupervisorModesAllocation, UpdateAllocatesNothingInJogGoalAndStream) {
  {  // the counter sees an allocation (the test can fail)
    t_counting = true;
    int* probe = new int(1);
    t_counting = false;
    EXPECT_EQ(t_allocations, 1u);
    delete probe;
    t_allocations = 0;
  }
  const RigParams rig = MakeReferenceRig();
  Supervisor sup(rig, SupervisorParams{});
  SupervisorInput in;
  SupervisorOutput out;
  Pose pose;
  pose.p_BP_B_m = rig.geometry.home_position_m;
  std::uint64_t updates = 0;
  const auto tick = [&](OperatorCommandKind cmd) {
    for (std::size_t i = 0; i < kNumLegs; ++i)
      in.length_m[i] = (pose.p_BP_B_m + pose.R_BP * rig.geometry.p_PB_P[i] - rig.geometry.p_BA_B[i]).norm();
    const Eigen::Quaterniond q(pose.R_BP);
    in.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    in.command = cmd;
    t_counting = true;
    sup.Update(in, out);
    t_counting = false;
    ++updates;
    in.time_s += 0.005;
    pose = out.desired.pose;  // a kinematic plant: it is where it was told to be
  };
  tick(OperatorCommandKind::kNone);  // the rest pose
  ASSERT_TRUE(sup.initialized());
  const std::uint64_t before = t_allocations;
  in.jog.twist << 0.03, 0, 0, 0, 0, 0.1;
  for (int k = 0; k < 200; ++k) tick(k % 4 == 0 ? OperatorCommandKind::kJog : OperatorCommandKind::kNone);
  ASSERT_EQ(out.state, SupervisorState::kJogging);
  for (int k = 0; k < 300 && out.state != SupervisorState::kIdle; ++k) tick(OperatorCommandKind::kNone);
  ASSERT_EQ(out.state, SupervisorState::kIdle);  // the dead-man stopped it
  in.goal_X_BP = pose;
  in.goal_X_BP.p_BP_B_m.y() += 0.3;  // outside: refused
  tick(OperatorCommandKind::kGoal);
  EXPECT_EQ(out.command_result, CommandResult::kRefused);
  in.goal_X_BP.p_BP_B_m.y() -= 0.28;
  tick(OperatorCommandKind::kGoal);
  EXPECT_EQ(out.command_result, CommandResult::kAccepted);
  for (int k = 0; k < 1000 && out.state != SupervisorState::kIdle; ++k) tick(OperatorCommandKind::kNone);
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  in.goal_X_BP.p_BP_B_m.y() -= 0.05;
  tick(OperatorCommandKind::kGoal);
  for (int k = 0; k < 40; ++k) tick(OperatorCommandKind::kNone);
  tick(OperatorCommandKind::kStop);
  for (int k = 0; k < 400 && out.state != SupervisorState::kIdle; ++k) tick(OperatorCommandKind::kNone);
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  // A stream: packets of a sine, a duplicate, a gap past the timeout, then a stop.
  std::array<StreamPacket, 2> packets{};
  std::uint64_t sequence = 10;
  tick(OperatorCommandKind::kStream);
  EXPECT_EQ(out.state, SupervisorState::kStreaming);
  for (int k = 0; k < 200; ++k) {
    packets[0].sequence = ++sequence;
    packets[0].time_s = k * 0.005;
    packets[0].values[0] = 0.02 * std::sin(k * 0.02);
    packets[1] = packets[0];  // a duplicate
    in.stream_packets = k < 120 ? packets.data() : nullptr;  // then a gap: the timeout
    in.stream_packet_count = k < 120 ? packets.size() : 0;
    tick(OperatorCommandKind::kNone);
  }
  tick(OperatorCommandKind::kStop);
  for (int k = 0; k < 400 && out.state != SupervisorState::kIdle; ++k) tick(OperatorCommandKind::kNone);
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  EXPECT_EQ(sup.operator_motion().stream().counters().timeouts, 1u);
  EXPECT_EQ(t_allocations - before, 0u) << "over " << updates << " updates";
}

}  // namespace
}  // namespace hexa
