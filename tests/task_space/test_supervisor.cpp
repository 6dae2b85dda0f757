// Supervisor state machine: nominal run through every state, operator stop and home, and
// HOLD on each fault cause with frozen setpoints, refused commands and reset-only exit.
// The "plant" is a perfect kinematic one: each leg reaches its setpoint (length +
// correction) by the next tick and the IMU reads the commanded orientation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <vector>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/supervisor.hpp"

namespace hexa {
namespace {

std::array<double, 4> Quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.w(), q.x(), q.y(), q.z()};
}

class Bench {
 public:
  explicit Bench(const Vector6d& initial_pose = Vector6d::Zero(),
                 SupervisorParams params = SupervisorParams{})
      : rig_(MakeReferenceRig()), sup_(rig_, params) {
    const Vector6d q = initial_pose.isZero() ? sup_.home_xyz_rpy() : initial_pose;
    const Pose pose = PoseFromVector(q);
    InverseKinematics(rig_.geometry, pose, in.length_m);
    in.orientation_wxyz = Quat(pose.R_BP);
  }

  // One 5 ms tick; the perfect plant then follows the setpoints.
  void Tick(OperatorCommandKind cmd = OperatorCommandKind::kNone,
            const StartRequest* start = nullptr) {
    in.time_s = time_s_;
    in.command = cmd;
    in.start = start;
    sup_.Update(in, out);
    time_s_ += 0.005;
    if (follow_) {
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        in.length_m[i] = out.setpoint[i].length_m + out.setpoint[i].correction_m;
      }
      in.orientation_wxyz = Quat(out.desired.pose.R_BP);
    }
  }
  void RunFor(double duration_s) {
    const int n = static_cast<int>(std::lround(duration_s / 0.005));
    for (int k = 0; k < n; ++k) Tick();
  }

  Supervisor& sup() { return sup_; }
  bool follow_ = true;
  SupervisorInput in;
  SupervisorOutput out;

 private:
  RigParams rig_;
  Supervisor sup_;
  double time_s_ = 0.0;
};

// Start a one-period x trajectory and run into the tracking window.
void StartAndTrack(Bench& bench, StartRequest& request) {
  bench.Tick();
  ASSERT_TRUE(bench.sup().initialized());
  request = bench.sup().PreparePaperStart(PaperMotion::kX, 1);
  ASSERT_TRUE(request.feasibility.feasible) << request.feasibility.message;
  bench.Tick(OperatorCommandKind::kStart, &request);
  ASSERT_EQ(bench.out.command_result, CommandResult::kAccepted);
  bench.RunFor(3.0);
  ASSERT_EQ(bench.out.state, SupervisorState::kTracking);
}

TEST(Supervisor, NominalRunVisitsEveryStateInOrderWithContinuousSetpoints) {
  Bench bench;
  bench.Tick();
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
  const StartRequest request = bench.sup().PreparePaperStart(PaperMotion::kCombined, 2);
  ASSERT_TRUE(request.feasibility.feasible) << request.feasibility.message;
  bench.Tick(OperatorCommandKind::kStart, &request);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  std::vector<SupervisorState> states{SupervisorState::kIdle};
  LegArray<SupervisorLegSetpoint> prev = bench.out.setpoint;
  const SupervisorParams params;
  double max_error = 0.0;
  for (int k = 0; k < 1200; ++k) {
    bench.Tick();
    if (bench.out.state != states.back()) states.push_back(bench.out.state);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const auto& sp = bench.out.setpoint[i];
      EXPECT_FALSE(sp.hold);
      // No steps: per 5 ms the length moves at most v_max dt, the velocity a_max dt.
      EXPECT_LE(std::abs(sp.length_m - prev[i].length_m), params.max_leg_speed_m_s * 0.005);
      EXPECT_LE(std::abs(sp.velocity_m_s - prev[i].velocity_m_s),
                params.max_leg_acceleration_m_s2 * 0.005);
    }
    max_error = std::max(max_error, bench.out.outer_loop.error.norm());
    prev = bench.out.setpoint;
  }
  const std::vector<SupervisorState> expected{SupervisorState::kIdle, SupervisorState::kBlending,
                                              SupervisorState::kTracking,
                                              SupervisorState::kStopping, SupervisorState::kIdle};
  EXPECT_EQ(states, expected);
  EXPECT_EQ(bench.out.fault, FaultReason::kNone);
  EXPECT_LT((bench.out.desired_xyz_rpy - bench.sup().home_xyz_rpy()).cwiseAbs().maxCoeff(), 1e-9);
  // Perfect plant with the nominal geometry: the estimate lags the desired pose by one tick.
  EXPECT_LT(max_error, 0.01);
}

TEST(Supervisor, FeedforwardIsTheInverseDynamicsOfTheDesiredMotionWithAConsistentRate) {
  SupervisorParams params;
  params.setpoint_lead_s = 0.0;  // the desired motion of now (the lead: test below)
  Bench bench(Vector6d::Zero(), params);
  bench.Tick();
  const StartRequest request = bench.sup().PreparePaperStart(PaperMotion::kCombined, 2);
  ASSERT_TRUE(request.feasibility.feasible) << request.feasibility.message;
  bench.Tick(OperatorCommandKind::kStart, &request);
  const RigParams rig = MakeReferenceRig();
  const PlatformInertialParams inertial = PlatformInertialParams::FromRig(rig);
  LegArray<SupervisorLegSetpoint> prev = bench.out.setpoint;
  double max_force = 0.0, worst_rate_mismatch = 0.0;
  for (int k = 0; k < 1200; ++k) {
    bench.Tick();
    LegForceResult expected;
    const PlatformMotion m{bench.out.desired.pose, bench.out.desired.twist_B,
                           bench.out.desired.twist_rate_B};
    ASSERT_EQ(LegForcesForMotion(rig.geometry, inertial, m, expected), KinStatus::kOk);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const auto& sp = bench.out.setpoint[i];
      ASSERT_TRUE(sp.feedforward_valid);
      EXPECT_NEAR(sp.feedforward_force_n, expected.force_n[i], 1e-9);
      max_force = std::max(max_force, std::abs(sp.feedforward_force_n));
      // The previous setpoint's force + rate * 5 ms is this setpoint's force (first-order
      // hold over the period, evaluated on the same trajectory).
      worst_rate_mismatch =
          std::max(worst_rate_mismatch, std::abs(prev[i].feedforward_force_n +
                                                 prev[i].feedforward_force_rate_n_s * 0.005 -
                                                 sp.feedforward_force_n));
    }
    prev = bench.out.setpoint;
  }
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
  EXPECT_LT(worst_rate_mismatch, 1e-6);
  EXPECT_GT(max_force, 20.0);  // the combined motion is far from the static ~13 N
  // At rest again: the static load, no rate.
  for (const auto& sp : bench.out.setpoint) EXPECT_EQ(sp.feedforward_force_rate_n_s, 0.0);
}

// Setpoint lead: with a lead of one supervisor period the legs get, at every tick,
// exactly the lengths, rates and feed-forward that the supervisor without lead sends one tick
// later; the desired pose reported (outer loop, metrics) stays the one of now.
TEST(Supervisor, SetpointLeadSendsTheMotionOfOnePeriodAhead) {
  SupervisorParams lead_params, now_params;
  lead_params.setpoint_lead_s = 0.005;
  now_params.setpoint_lead_s = 0.0;
  Bench lead(Vector6d::Zero(), lead_params), now(Vector6d::Zero(), now_params);
  lead.Tick();
  now.Tick();
  const StartRequest request = lead.sup().PreparePaperStart(PaperMotion::kCombined, 2);
  ASSERT_TRUE(request.feasibility.feasible) << request.feasibility.message;
  lead.Tick(OperatorCommandKind::kStart, &request);
  now.Tick(OperatorCommandKind::kStart, &request);
  now.Tick();
  int moving = 0;
  for (int k = 0; k < 1000; ++k) {
    const LegArray<SupervisorLegSetpoint> ahead = lead.out.setpoint;
    const Vector6d desired_lead = lead.out.desired_xyz_rpy;
    const Vector6d desired_now = now.out.desired_xyz_rpy;  // one tick later than lead's
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      EXPECT_NEAR(ahead[i].length_m, now.out.setpoint[i].length_m, 1e-12) << "tick " << k;
      EXPECT_NEAR(ahead[i].velocity_m_s, now.out.setpoint[i].velocity_m_s, 1e-12);
      EXPECT_NEAR(ahead[i].acceleration_m_s2, now.out.setpoint[i].acceleration_m_s2, 1e-9);
      EXPECT_NEAR(ahead[i].feedforward_force_n, now.out.setpoint[i].feedforward_force_n, 1e-9);
      EXPECT_NEAR(ahead[i].feedforward_force_rate_n_s, now.out.setpoint[i].feedforward_force_rate_n_s,
                  1e-6);
    }
    if ((desired_now - desired_lead).norm() > 1e-6) ++moving;
    lead.Tick();
    now.Tick();
    if (now.out.state == SupervisorState::kIdle) break;
  }
  EXPECT_GT(moving, 500);  // the lead's reported desired pose is the one of now, not ahead
}

TEST(Supervisor, FeedforwardDisabledIsNotSent) {
  SupervisorParams params;
  params.feedforward_enabled = false;
  Bench bench(Vector6d::Zero(), params);
  bench.Tick();
  const StartRequest request = bench.sup().PreparePaperStart(PaperMotion::kCombined, 1);
  bench.Tick(OperatorCommandKind::kStart, &request);
  bench.RunFor(3.0);
  ASSERT_EQ(bench.out.state, SupervisorState::kTracking);
  for (const auto& sp : bench.out.setpoint) {
    EXPECT_FALSE(sp.feedforward_valid);
    EXPECT_EQ(sp.feedforward_force_n, 0.0);
  }
}

TEST(Supervisor, OperatorStopDuringTrackingStopsSmoothlyAtHome) {
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  bench.Tick(OperatorCommandKind::kStop);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  EXPECT_EQ(bench.out.state, SupervisorState::kStopping);
  LegArray<SupervisorLegSetpoint> prev = bench.out.setpoint;
  for (int k = 0; k < 210; ++k) {
    bench.Tick();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      EXPECT_LE(std::abs(bench.out.setpoint[i].velocity_m_s - prev[i].velocity_m_s), 0.04);
    }
    prev = bench.out.setpoint;
  }
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
  EXPECT_LT((bench.out.desired_xyz_rpy - bench.sup().home_xyz_rpy()).cwiseAbs().maxCoeff(), 1e-9);
  for (const auto& sp : bench.out.setpoint) EXPECT_EQ(sp.velocity_m_s, 0.0);
}

TEST(Supervisor, HomeCommandBringsAnOffHomeRestPoseHome) {
  Vector6d start = HomePoseVector(MakeReferenceRig().geometry.home_position_m);
  start += (Vector6d() << 0.02, 0.01, -0.03, 0.05, 0.0, -0.1).finished();
  Bench bench(start);
  bench.Tick();
  EXPECT_LT((bench.sup().rest_xyz_rpy() - start).cwiseAbs().maxCoeff(), 1e-9)
      << "the rest pose is latched from the first estimate";
  bench.Tick(OperatorCommandKind::kHome);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  EXPECT_EQ(bench.out.state, SupervisorState::kBlending);
  bench.Tick(OperatorCommandKind::kStart);  // refused while moving
  EXPECT_EQ(bench.out.command_result, CommandResult::kRefused);
  bench.RunFor(2.1);
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
  EXPECT_LT((bench.out.desired_xyz_rpy - bench.sup().home_xyz_rpy()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((bench.out.estimate.xyz_rpy - bench.sup().home_xyz_rpy()).cwiseAbs().maxCoeff(), 1e-6);
}

// Fault causes: how to inject one into the input, and how to clear it.
struct FaultCase {
  const char* name;
  FaultReason reason;
  int leg;  // expected fault_leg
  std::function<void(SupervisorInput&)> inject;
  std::function<void(SupervisorInput&)> clear;
};

std::vector<FaultCase> FaultCases() {
  const RigParams rig = MakeReferenceRig();
  Vector6d far = HomePoseVector(rig.geometry.home_position_m);
  far[0] += 0.16;  // beyond workspace_radius_m = 0.15
  LegArray<double> far_lengths{};
  InverseKinematics(rig.geometry, PoseFromVector(far), far_lengths);
  Vector6d tilted = HomePoseVector(rig.geometry.home_position_m);
  tilted[4] = 0.55;  // beyond workspace_max_rotation_rad = 0.5236
  const Pose tilted_pose = PoseFromVector(tilted);
  LegArray<double> tilted_lengths{};
  InverseKinematics(rig.geometry, tilted_pose, tilted_lengths);
  return {
      {"LegFault", FaultReason::kCommandStale, 4,
       [](SupervisorInput& in) { in.leg_fault[3] = FaultReason::kCommandStale; },
       [](SupervisorInput& in) { in.leg_fault[3] = FaultReason::kNone; }},
      {"LegCommandNotFinite", FaultReason::kCommandNotFinite, 1,
       [](SupervisorInput& in) { in.leg_fault[0] = FaultReason::kCommandNotFinite; },
       [](SupervisorInput& in) { in.leg_fault[0] = FaultReason::kNone; }},
      {"LivelinessLost", FaultReason::kLivelinessLost, 2,
       [](SupervisorInput& in) { in.leg_alive[1] = false; },
       [](SupervisorInput& in) { in.leg_alive[1] = true; }},
      {"DeadlineMissesExceeded", FaultReason::kDeadlineMissesExceeded, 5,
       [](SupervisorInput& in) { in.deadline_misses_consecutive[4] = 6; },
       [](SupervisorInput& in) { in.deadline_misses_consecutive[4] = 0; }},
      {"ImuDeadlineMissesExceeded", FaultReason::kDeadlineMissesExceeded, 0,
       [](SupervisorInput& in) { in.imu_deadline_misses_consecutive = 6; },
       [](SupervisorInput& in) { in.imu_deadline_misses_consecutive = 0; }},
      {"LengthNotFinite", FaultReason::kSensorInvalid, 6,
       [](SupervisorInput& in) { in.length_m[5] = NAN; },
       [](SupervisorInput& in) { in.length_m[5] = 0.5034; }},
      {"ImuQuaternionInvalid", FaultReason::kSensorInvalid, 0,
       [](SupervisorInput& in) { in.orientation_wxyz = {0.3, 0.0, 0.0, 0.0}; },
       [](SupervisorInput& in) { in.orientation_wxyz = {1.0, 0.0, 0.0, 0.0}; }},
      {"EstimateOutsideWorkspaceRadius", FaultReason::kEstimateOutsideWorkspace, 0,
       [far_lengths](SupervisorInput& in) {
         in.length_m = far_lengths;
         in.orientation_wxyz = {1.0, 0.0, 0.0, 0.0};
       },
       [](SupervisorInput&) {}},
      {"EstimateOutsideWorkspaceRotation", FaultReason::kEstimateOutsideWorkspace, 0,
       [tilted_lengths, tilted_pose](SupervisorInput& in) {
         in.length_m = tilted_lengths;
         in.orientation_wxyz = Quat(tilted_pose.R_BP);
       },
       [](SupervisorInput&) {}},
  };
}

class SupervisorFault : public ::testing::TestWithParam<FaultCase> {};

TEST_P(SupervisorFault, HoldsWithFrozenSetpointsRefusesCommandsAndLeavesOnlyOnReset) {
  const FaultCase& c = GetParam();
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  const LegArray<SupervisorLegSetpoint> before = bench.out.setpoint;

  bench.follow_ = false;  // the plant holds still; the fault input stays as injected
  c.inject(bench.in);
  bench.Tick();
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);
  EXPECT_EQ(bench.out.fault, c.reason) << ToString(bench.out.fault);
  EXPECT_EQ(bench.out.fault_leg, c.leg);
  EXPECT_TRUE(bench.out.fault_raised);
  EXPECT_GT(std::strlen(bench.out.fault_detail.data()), 0u);
  // Frozen: the last lengths and corrections, at rest, hold flag set.
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_EQ(bench.out.setpoint[i].length_m, before[i].length_m);
    EXPECT_EQ(bench.out.setpoint[i].correction_m, before[i].correction_m);
    EXPECT_EQ(bench.out.setpoint[i].velocity_m_s, 0.0);
    EXPECT_EQ(bench.out.setpoint[i].acceleration_m_s2, 0.0);
    EXPECT_TRUE(bench.out.setpoint[i].hold);
  }
  // The desired pose held is the one whose leg lengths are held (with the setpoint lead
  // that is the led pose, not the desired pose of the tick before the fault).
  const Vector6d desired_before = bench.out.desired_xyz_rpy;
  LegArray<double> held_lengths{};
  InverseKinematics(MakeReferenceRig().geometry, PoseFromVector(desired_before), held_lengths);
  for (std::size_t i = 0; i < kNumLegs; ++i) EXPECT_NEAR(held_lengths[i], before[i].length_m, 1e-9);

  // Every command but reset is refused; the hold and the fault persist, setpoints stay.
  const StartRequest again = request;
  for (OperatorCommandKind cmd : {OperatorCommandKind::kStart, OperatorCommandKind::kStop,
                                  OperatorCommandKind::kHome}) {
    bench.Tick(cmd, &again);
    EXPECT_EQ(bench.out.command_result, CommandResult::kRefused) << ToString(cmd);
    EXPECT_EQ(bench.out.state, SupervisorState::kHold);
    EXPECT_EQ(bench.out.fault, c.reason);
    EXPECT_FALSE(bench.out.fault_raised);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      EXPECT_EQ(bench.out.setpoint[i].length_m, before[i].length_m);
      EXPECT_TRUE(bench.out.setpoint[i].hold);
    }
  }
  bench.RunFor(1.0);  // time alone does not leave HOLD
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);

  // Reset while the cause persists: accepted, but the fault is raised again at once.
  bench.Tick(OperatorCommandKind::kReset);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);
  EXPECT_EQ(bench.out.fault, c.reason);

  // Clear the cause (the platform is where the setpoints held it), then reset -> IDLE.
  c.clear(bench.in);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    bench.in.length_m[i] = before[i].length_m + before[i].correction_m;
  }
  bench.in.orientation_wxyz = Quat(PoseFromVector(desired_before).R_BP);
  bench.follow_ = true;
  bench.Tick();
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);
  bench.Tick(OperatorCommandKind::kReset);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
  EXPECT_EQ(bench.out.fault, FaultReason::kNone);
  // No jump: the legs are told the lengths they have (the rest pose is the measured one, the
  // outer loop's correction restarts from zero).
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_FALSE(bench.out.setpoint[i].hold);
    EXPECT_NEAR(bench.out.setpoint[i].length_m + bench.out.setpoint[i].correction_m,
                before[i].length_m + before[i].correction_m, 1e-5);  // the outer loop's first tick
  }
  // And a new trajectory can start from where it rests.
  const StartRequest next = bench.sup().PreparePaperStart(PaperMotion::kZ, 1);
  ASSERT_TRUE(next.feasibility.feasible) << next.feasibility.message;
  bench.Tick(OperatorCommandKind::kStart, &next);
  EXPECT_EQ(bench.out.command_result, CommandResult::kAccepted);
  EXPECT_EQ(bench.out.state, SupervisorState::kBlending);
}

// An e-stop mid-trajectory: the valves are blocked and the platform coasts off the frozen
// setpoints (measured on the rig's simulation: up to 16 mm in 100 ms; here 12 mm in x and
// 15 mrad in yaw). After the reset the legs are told the lengths they have, and the motion
// started next blends from there: the largest step of a leg's commanded length (setpoint +
// correction) in the first second after the reset, counted from its measured length at the
// reset, is within one tick at the leg speed limit.
TEST(Supervisor, ResetAfterAnEstopRampsFromTheMeasuredPoseNotTheStaleSetpoint) {
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  bench.follow_ = false;
  bench.in.system_fault = FaultReason::kEstop;
  bench.Tick();
  ASSERT_EQ(bench.out.state, SupervisorState::kHold);
  const Vector6d held = bench.out.desired_xyz_rpy;
  Vector6d coasted = held;
  coasted[0] += 0.012;
  coasted[5] += 0.015;
  const Pose coasted_pose = PoseFromVector(coasted);
  InverseKinematics(MakeReferenceRig().geometry, coasted_pose, bench.in.length_m);
  bench.in.orientation_wxyz = Quat(coasted_pose.R_BP);
  bench.RunFor(0.5);
  bench.in.system_fault = FaultReason::kNone;  // the loop closed again
  const LegArray<double> measured = bench.in.length_m;
  double stale_m = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i)
    stale_m = std::max(stale_m, std::abs(bench.out.setpoint[i].length_m + bench.out.setpoint[i].correction_m -
                                         measured[i]));
  ASSERT_GT(stale_m, 0.005) << "the frozen setpoint is where the platform was, not where it is";

  bench.follow_ = true;
  bench.Tick(OperatorCommandKind::kReset);
  ASSERT_EQ(bench.out.command_result, CommandResult::kAccepted);
  ASSERT_EQ(bench.out.state, SupervisorState::kIdle);
  const SupervisorParams params;
  LegArray<double> previous = measured;
  double largest_step_m = 0.0;
  auto record = [&] {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double commanded = bench.out.setpoint[i].length_m + bench.out.setpoint[i].correction_m;
      largest_step_m = std::max(largest_step_m, std::abs(commanded - previous[i]));
      previous[i] = commanded;
    }
  };
  record();
  EXPECT_LT(largest_step_m, 1e-6) << "the reset tick commands the lengths the legs have";
  const StartRequest next = bench.sup().PreparePaperStart(PaperMotion::kX, 1);
  ASSERT_TRUE(next.feasibility.feasible) << next.feasibility.message;
  bench.Tick(OperatorCommandKind::kStart, &next);
  ASSERT_EQ(bench.out.command_result, CommandResult::kAccepted);
  record();
  for (int k = 0; k < 198; ++k) {  // the rest of the first second after the reset
    bench.Tick();
    record();
  }
  std::printf("largest step of a commanded leg length in the first second after the reset: %.3f mm "
              "(frozen setpoint %.3f mm off the measured length; limit %.3f mm per tick)\n",
              largest_step_m * 1e3, stale_m * 1e3, params.max_leg_speed_m_s * params.period_s * 1e3);
  EXPECT_LE(largest_step_m, params.max_leg_speed_m_s * params.period_s);
}

INSTANTIATE_TEST_SUITE_P(EachCause, SupervisorFault, ::testing::ValuesIn(FaultCases()),
                         [](const ::testing::TestParamInfo<FaultCase>& info) {
                           return std::string(info.param.name);
                         });

// A length reading that stops following the leg (stuck potentiometer): the six lengths and
// the IMU no longer agree; the leg whose reading disagrees with the other five beyond the
// limit for length_consistency_ticks in a row is named (docs/faults.md).
TEST(Supervisor, StuckLengthReadingIsNamedAsInconsistent) {
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  // Perfect plant: consistent (the fit's residual is micrometres against the 8 mm limit).
  EXPECT_LT(bench.sup().max_consistency_residual_m(), 1e-4);
  const SupervisorParams params;
  // The legs keep following their setpoints; leg 3 reports the length it had.
  const double stuck = bench.in.length_m[2];
  double followed = stuck;  // where leg 3 really is
  int ticks = 0;
  while (bench.out.state != SupervisorState::kHold && ticks < 400) {
    bench.Tick();
    followed = bench.in.length_m[2];
    bench.in.length_m[2] = stuck;
    ++ticks;
  }
  ASSERT_EQ(bench.out.state, SupervisorState::kHold) << "never detected";
  EXPECT_EQ(bench.out.fault, FaultReason::kSensorInconsistent) << bench.out.fault_detail.data();
  EXPECT_EQ(bench.out.fault_leg, 3);
  // Detected once the error exceeds the limit, after the persistence, not before.
  EXPECT_GT(std::abs(followed - stuck), params.length_consistency_limit_m);
  EXPECT_GE(ticks, params.length_consistency_ticks);
}

TEST(Supervisor, DeadlineMissesUpToTheLimitAreTolerated) {
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  bench.in.deadline_misses_consecutive[2] = SupervisorParams{}.max_consecutive_deadline_misses;
  bench.in.imu_deadline_misses_consecutive = SupervisorParams{}.max_consecutive_deadline_misses;
  bench.RunFor(0.5);
  EXPECT_EQ(bench.out.state, SupervisorState::kTracking);
  EXPECT_EQ(bench.out.fault, FaultReason::kNone);
}

TEST(Supervisor, RejectedTrajectoryHoldsWithTheFeasibilityMessage) {
  Bench bench;
  bench.Tick();
  const StartRequest request = bench.sup().PreparePaperStart(PaperMotion::kRoll, 1, 3.0);
  ASSERT_FALSE(request.feasibility.feasible);
  const LegArray<SupervisorLegSetpoint> before = bench.out.setpoint;
  bench.Tick(OperatorCommandKind::kStart, &request);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRejected);
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);
  EXPECT_EQ(bench.out.fault, FaultReason::kTrajectoryRejected);
  EXPECT_EQ(bench.out.fault_leg, request.feasibility.leg);
  EXPECT_EQ(std::string(bench.out.fault_detail.data()), request.feasibility.message);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_EQ(bench.out.setpoint[i].length_m, before[i].length_m);
    EXPECT_TRUE(bench.out.setpoint[i].hold);
  }
  bench.Tick(OperatorCommandKind::kHome);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRefused);
  bench.Tick(OperatorCommandKind::kReset);
  EXPECT_EQ(bench.out.state, SupervisorState::kIdle);
}

TEST(Supervisor, StartRejectedBeforeATrajectoryExistedHoldsWithItsMessage) {
  Bench bench;
  bench.Tick();
  // What the service passes on when a CSV file does not parse (config/csv_trajectory.hpp).
  const std::string message = "traj.csv:3: column 5 (roll_rad): \"nan\" is not finite";
  const StartRequest request = Supervisor::RejectedStart(message);
  ASSERT_FALSE(request.feasibility.feasible);
  bench.Tick(OperatorCommandKind::kStart, &request);
  EXPECT_EQ(bench.out.state, SupervisorState::kHold);
  EXPECT_EQ(bench.out.fault, FaultReason::kTrajectoryRejected);
  EXPECT_EQ(std::string(bench.out.fault_detail.data()), message);
}

TEST(Supervisor, TrajectoryNotStartingAtTheRestPoseIsRejected) {
  Bench bench;
  bench.Tick();
  Vector6d elsewhere = bench.sup().rest_xyz_rpy();
  elsewhere[0] += 0.01;
  const StartRequest request = bench.sup().PrepareStart(MakePaperTrajectory(
      PaperMotion::kZ, elsewhere, bench.sup().home_xyz_rpy(), bench.sup().timing(), 1));
  ASSERT_TRUE(request.feasibility.feasible);
  bench.Tick(OperatorCommandKind::kStart, &request);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRejected);
  EXPECT_EQ(bench.out.fault, FaultReason::kTrajectoryRejected);
}

TEST(Supervisor, ResetOutsideHoldAndStartWhileMovingAreRefused) {
  Bench bench;
  StartRequest request;
  StartAndTrack(bench, request);
  bench.Tick(OperatorCommandKind::kReset);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRefused);
  bench.Tick(OperatorCommandKind::kStart, &request);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRefused);
  bench.Tick(OperatorCommandKind::kHome);
  EXPECT_EQ(bench.out.command_result, CommandResult::kRefused);
  EXPECT_EQ(bench.out.state, SupervisorState::kTracking);
}

}  // namespace
}  // namespace hexa
