// Soft limits written in the rig file, and the pivot point set at run time, in the in-process
// lockstep simulation (six leg controllers, the plant, the supervisor; realistic profile, seed 7),
// checked against the plant's ground truth:
//   - a jog held towards each of three limits of a rig file (the pose box, the platform joints'
//     deflection, the legs' stroke less its margin) stops at that limit: the setpoint never
//     beyond it, the platform's largest overshoot measured and bounded;
//   - a goal outside them is refused with its reason;
//   - a pivot changed at run time: a rotation about it keeps that point still (ground truth);
//     a pivot 10 m away, a non-finite one, a rotation that is not one, and a change while a
//     goal moves are refused with a message.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/soft_limits.hpp"
#include "hexa/core/supervisor.hpp"
#include "hexa/core/user_frames.hpp"
#include "modes_session.hpp"

namespace hexa {
namespace {

using modes_test::Jog;
using modes_test::ModesSession;

std::string ReadText(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  std::string text;
  if (f == nullptr) return text;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), f)) > 0) text.append(buffer, n);
  std::fclose(f);
  return text;
}

// The reference rig file with its soft limits tightened as a user would write them, so that
// each is reached after a second or two of jogging: the box's +x at home + 30 mm, the platform
// joints at 0.12 rad (reached by a yaw of about 0.18 rad, inside the box's 0.3 rad), the
// stroke margin at 50 mm (longest leg 0.5784 m, reached by +z before the box's +100 mm).
config::SystemConfig TightRig(bool box_only = false) {
  std::string text = ReadText(config::DefaultRigFile());
  const auto set = [&](const std::string& pattern, const std::string& replacement) {
    const std::string before = text;
    text = std::regex_replace(text, std::regex(pattern), replacement);
    EXPECT_NE(text, before) << pattern;
  };
  set("position_max_from_home_m \\{[^}]*\\}", "position_max_from_home_m { x: 0.03 y: 0.1 z: 0.1 }");
  if (!box_only) {
    set("max_platform_joint_angle_rad: 0.8", "max_platform_joint_angle_rad: 0.12");
    set("stroke_margin_m: 0.01", "stroke_margin_m: 0.05");
  }
  const config::ConfigResult r = config::ParseSystemConfig(text, "tight_soft_limits");
  EXPECT_TRUE(r.ok) << r.error;
  return r.config;
}

LockstepConfig FromRig(const config::SystemConfig& c) {
  LockstepConfig l = modes_test::Config();
  l.rig = c.rig;
  l.leg_controller = c.leg_controller;
  l.supervisor = c.supervisor;
  return l;
}

double MaxOf(const LegArray<double>& v) { return *std::max_element(v.begin(), v.end()); }

// One limit and how it is measured on a pose (the setpoint) and on the plant's ground truth.
struct LimitCase {
  const char* name;
  JogRequest jog;
  SoftLimitKind kind;
  double limit;                                  // the rig file's, in the measure's unit
  double (*of_setpoint)(const Supervisor&, const Pose&);
  double (*of_truth)(const Supervisor&, const PlatformTrueState&);
  double truth_bound;                            // the platform's overshoot allowed
};

struct HeldJogResult {
  double setpoint_peak = -1e9;
  double truth_peak = -1e9;
  double setpoint_at_end = 0.0;
  int clamped_ticks = 0;      // supervisor ticks whose setpoint the soft limits cut
  SoftLimitKind binding = SoftLimitKind::kNone;  // what a further 50 ms of the jog would break
  SupervisorState state_at_end = SupervisorState::kIdle;
};

// Holds the jog (started already) for `duration_s`, a message every supervisor tick, and
// records, every plant tick, the measure of the setpoint and of the ground truth.
HeldJogResult HoldJog(ModesSession& s, const LimitCase& c, double duration_s) {
  HeldJogResult r;
  const Supervisor& sup = s.sim().supervisor();
  const int ticks = static_cast<int>(std::lround(duration_s / modes_test::kTick_s));
  for (int k = 0; k < ticks; ++k) {
    s.Run(modes_test::kTick_s, &c.jog, 0.005);
    r.setpoint_peak = std::max(r.setpoint_peak, c.of_setpoint(sup, s.setpoint()));
    r.truth_peak = std::max(r.truth_peak, c.of_truth(sup, s.sim().plant().truth()));
    const bool supervisor_tick = s.sim().supervisor_ran();
    if (supervisor_tick && s.sim().supervisor_output().operator_motion.limits.result != SoftLimitsResult::kInside) {
      ++r.clamped_ticks;
    }
  }
  r.setpoint_at_end = c.of_setpoint(sup, s.setpoint());
  // The work frame is the base frame and the pivot the platform origin here.
  const Pose further = IntegratePivotTwist(s.setpoint(), Eigen::Vector3d::Zero(), c.jog.twist, 0.05);
  r.binding = sup.operator_motion().limits().CheckPose(further).kind;
  r.state_at_end = s.sim().supervisor_output().state;
  return r;
}

double PlatformJointPeak(const Supervisor& sup, const Pose& pose) {
  LegArray<double> base{}, platform{};
  sup.operator_motion().limits().JointAngles(pose, base, platform);
  return MaxOf(platform);
}

double LongestLeg(const Supervisor& sup, const Pose& pose) {
  LegArray<double> length_m{};
  InverseKinematics(sup.rig().geometry, pose, length_m);  // eq 46
  return MaxOf(length_m);
}

TEST(SupervisorLimits, JogHeldTowardsEachOfThreeRigFileLimitsStopsAtIt) {
  const config::SystemConfig rig = TightRig();
  const Eigen::Vector3d home = rig.rig.geometry.home_position_m;
  const double max_length_m =
      rig.rig.cylinder.mid_stroke_length_m + 0.5 * rig.rig.cylinder.stroke_m - rig.supervisor.stroke_margin_m;
  const LimitCase cases[] = {
      // 3 mm: the platform's lag behind a 5 cm/s jog (2.5 mm in JogHeldIntoTheSoftLimitStopsAtIt).
      {"pose box +x (home + 30 mm)", Jog(JogFrame::kWork, 0.05, 0, 0), SoftLimitKind::kPoseBox,
       home.x() + 0.03, [](const Supervisor&, const Pose& p) { return p.p_BP_B_m.x(); },
       [](const Supervisor&, const PlatformTrueState& t) { return t.pose.p_BP_B_m.x(); }, 0.003},
      // 0.01 rad: the platform's yaw lag at 0.2 rad/s; the truth's deflection is computed on the
      // supervisor's (nominal) joints.
      {"platform joint deflection 0.12 rad (yaw at 0.2 rad/s)", Jog(JogFrame::kWork, 0, 0, 0, 0, 0, 0.2),
       SoftLimitKind::kPlatformJointAngle, 0.12, PlatformJointPeak,
       [](const Supervisor& sup, const PlatformTrueState& t) { return PlatformJointPeak(sup, t.pose); }, 0.01},
      // 5 mm: the lag (3 mm) plus the realistic profile's calibration errors the legs cannot see
      // (potentiometer offsets up to 1 mm; the true leg lengths are on the plant's true joints).
      {"stroke less a 50 mm margin (+z)", Jog(JogFrame::kWork, 0, 0, 0.05), SoftLimitKind::kStroke,
       max_length_m, LongestLeg,
       [](const Supervisor&, const PlatformTrueState& t) { return MaxOf(t.length_m); }, 0.005},
  };
  double largest_truth_overshoot_share = 0.0;
  for (const LimitCase& c : cases) {
    ModesSession s(FromRig(rig));
    const double at_rest = c.of_setpoint(s.sim().supervisor(), s.setpoint());
    s.SetJog(c.jog);
    ASSERT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kAccepted);
    const HeldJogResult r = HoldJog(s, c, 3.5);
    std::printf("jog held towards the %s: limit %.6f, from %.6f; setpoint peak %.9f (overshoot "
                "%.2e), at the end %.6f; ground truth peak %.6f (overshoot %.6f, bound %.4f); "
                "binding: %s; %d ticks clamped\n",
                c.name, c.limit, at_rest, r.setpoint_peak, r.setpoint_peak - c.limit,
                r.setpoint_at_end, r.truth_peak, r.truth_peak - c.limit, c.truth_bound,
                ToString(r.binding), r.clamped_ticks);
    EXPECT_EQ(r.binding, c.kind) << c.name;
    EXPECT_LE(r.setpoint_peak, c.limit + 1e-6) << c.name;
    // It got there: held at the limit, not short of it (the look-ahead slows it down onto it):
    // within 5 % of the way from rest.
    EXPECT_GT(r.setpoint_at_end, c.limit - 0.05 * std::abs(c.limit - at_rest)) << c.name;
    EXPECT_LE(r.truth_peak - c.limit, c.truth_bound) << c.name;
    EXPECT_EQ(r.state_at_end, SupervisorState::kJogging) << c.name;  // held, not faulted
    largest_truth_overshoot_share =
        std::max(largest_truth_overshoot_share, (r.truth_peak - c.limit) / c.truth_bound);
  }
  std::printf("largest ground-truth overshoot: %.2f of its bound\n", largest_truth_overshoot_share);
}

TEST(SupervisorLimits, GoalOutsideTheRigFileLimitsIsRefusedWithItsReason) {
  ModesSession s(FromRig(TightRig()));
  Pose goal = s.setpoint();
  goal.p_BP_B_m.x() += 0.05;  // the rig file's box ends 30 mm from home
  const SupervisorOutput& out = s.Command(OperatorCommandKind::kGoal, &goal);
  EXPECT_EQ(out.command_result, CommandResult::kRefused);
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  const std::string why = out.command_detail.data();
  std::printf("goal 50 mm along x: %s\n", why.c_str());
  EXPECT_NE(why.find("pose box"), std::string::npos) << why;
  EXPECT_NE(why.find("beyond the limit 0.0300"), std::string::npos) << why;
  // Inside the box but beyond the stroke less the file's 50 mm margin.
  Pose up = s.setpoint();
  up.p_BP_B_m.z() += 0.09;
  const SupervisorOutput& out_up = s.Command(OperatorCommandKind::kGoal, &up);
  EXPECT_EQ(out_up.command_result, CommandResult::kRefused);
  const std::string why_up = out_up.command_detail.data();
  std::printf("goal 90 mm up: %s\n", why_up.c_str());
  EXPECT_NE(why_up.find("stroke limit"), std::string::npos) << why_up;
  EXPECT_NE(why_up.find("limit 0.5784"), std::string::npos) << why_up;
  // And one inside is taken.
  Pose inside = s.setpoint();
  inside.p_BP_B_m.x() += 0.02;
  EXPECT_EQ(s.Command(OperatorCommandKind::kGoal, &inside).command_result, CommandResult::kAccepted);
}

// A trajectory is held to the same limits before it starts: the paper's x motion (8 cm) passes
// the default box and is refused by a rig file's 30 mm one (the box alone tightened), naming
// it; started anyway, the supervisor refuses it and holds with that reason, as for the stroke.
TEST(SupervisorLimits, TrajectoryCrossingTheRigFileBoxIsRefusedBeforeItStarts) {
  const config::SystemConfig tight = TightRig(/*box_only=*/true);
  ModesSession s(FromRig(tight));
  const StartRequest request = s.sim().supervisor().PreparePaperStart(PaperMotion::kX, 1);
  std::printf("paper x motion against the rig file's box: %s\n", request.feasibility.message.c_str());
  ASSERT_FALSE(request.feasibility.feasible);
  EXPECT_EQ(request.feasibility.violation, FeasibilityViolation::kSoftLimit);
  EXPECT_NE(request.feasibility.message.find("pose box: x 0.0800 m beyond the limit 0.0300"),
            std::string::npos) << request.feasibility.message;
  const SupervisorOutput& out = s.Start(request);
  EXPECT_EQ(out.command_result, CommandResult::kRejected);
  EXPECT_EQ(out.state, SupervisorState::kHold);
  EXPECT_EQ(out.fault, FaultReason::kTrajectoryRejected);
  EXPECT_NE(std::string(out.fault_detail.data()).find("pose box: x"), std::string::npos)
      << out.fault_detail.data();
  ModesSession reference;
  EXPECT_TRUE(reference.sim().supervisor().PreparePaperStart(PaperMotion::kX, 1).feasibility.feasible);
  EXPECT_TRUE(reference.sim().supervisor().PreparePaperStart(PaperMotion::kCombined, 1).feasibility.feasible);
}

// The pivot point (in P) of a platform pose, in B.
Eigen::Vector3d PivotOf(const Pose& X_BP, const Eigen::Vector3d& p_PC_P) {
  return X_BP.p_BP_B_m + X_BP.R_BP * p_PC_P;
}

TEST(SupervisorLimits, RotationAboutAPivotSetAtRunTimeKeepsThatPointStill) {
  ModesSession s;
  s.Run(0.3, nullptr);
  UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(0.0, 0.05, 0.20);  // 20 cm above the platform, 5 cm aside
  const SupervisorOutput& out = s.Frames(frames);
  ASSERT_EQ(out.command_result, CommandResult::kAccepted) << out.command_detail.data();
  EXPECT_EQ(out.state, SupervisorState::kIdle);
  const Pose start_truth = s.truth(), start_setpoint = s.setpoint();
  const Eigen::Vector3d pivot_truth0 = PivotOf(start_truth, frames.p_PC_P_m);
  const Eigen::Vector3d pivot_setpoint0 = PivotOf(start_setpoint, frames.p_PC_P_m);
  // Roll at 0.15 rad/s for 1.2 s, let go, until at rest.
  const JogRequest roll = Jog(JogFrame::kWork, 0, 0, 0, 0.15, 0, 0);
  s.SetJog(roll);
  ASSERT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kAccepted);
  double pivot_truth_moved = 0.0, pivot_setpoint_moved = 0.0, origin_truth_moved = 0.0;
  const auto measure = [&] {
    pivot_truth_moved = std::max(pivot_truth_moved, (PivotOf(s.truth(), frames.p_PC_P_m) - pivot_truth0).norm());
    pivot_setpoint_moved =
        std::max(pivot_setpoint_moved, (PivotOf(s.setpoint(), frames.p_PC_P_m) - pivot_setpoint0).norm());
    origin_truth_moved = std::max(origin_truth_moved, (s.truth().p_BP_B_m - start_truth.p_BP_B_m).norm());
  };
  for (int k = 0; k < 1200; ++k) {
    s.Run(modes_test::kTick_s, &roll, 0.02);
    measure();
  }
  for (int k = 0; k < 1500; ++k) {
    s.Run(modes_test::kTick_s, nullptr);
    measure();
  }
  ASSERT_EQ(s.sim().supervisor_output().state, SupervisorState::kIdle);
  const double roll_rad = RollPitchYawFromRotation(s.truth().R_BP).x() -
                          RollPitchYawFromRotation(start_truth.R_BP).x();
  std::printf("roll of %.4f rad (ground truth) about a pivot set at run time 0.206 m from the "
              "platform origin: the pivot point moved at most %.5f m (truth), %.2e m (setpoint); "
              "the platform origin moved %.5f m\n",
              roll_rad, pivot_truth_moved, pivot_setpoint_moved, origin_truth_moved);
  EXPECT_GT(roll_rad, 0.15);
  EXPECT_LT(pivot_setpoint_moved, 1e-9);
  // 5 mm: the platform's tracking error of a jog (<= 3 mm, JogMovesAlongTheAskedAxis...) plus
  // its roll error (< 8 mrad) over the 0.2 m lever.
  EXPECT_LT(pivot_truth_moved, 0.005);
  // About the old pivot (the platform origin) the new one would have moved 0.206 m x the angle.
  EXPECT_GT(origin_truth_moved, 0.5 * frames.p_PC_P_m.norm() * roll_rad);
}

TEST(SupervisorLimits, FramesAreRefusedWithAMessageWhenInvalidOrWhileMoving) {
  ModesSession s;
  const auto refused = [&](const UserFramesConfig& frames, const char* expected) {
    const SupervisorOutput& out = s.Frames(frames);
    const std::string why = out.command_detail.data();
    std::printf("refused: %s\n", why.c_str());
    EXPECT_EQ(out.command_result, CommandResult::kRefused) << expected;
    EXPECT_NE(why.find(expected), std::string::npos) << why;
  };
  UserFramesConfig far;
  far.p_PC_P_m = Eigen::Vector3d(10.0, 0.0, 0.0);
  refused(far, "pivot point (from the platform origin) is too far away (value 10 m, limit <= 0.5 m)");
  UserFramesConfig nan;
  nan.p_PC_P_m.y() = std::nan("");
  refused(nan, "must be finite");
  UserFramesConfig skewed;
  skewed.X_PT.R_BP(0, 1) = 0.3;
  refused(skewed, "frames.tool.R_PT: rotation must be orthonormal");
  UserFramesConfig far_work;
  far_work.X_BW.p_BP_B_m = Eigen::Vector3d(0.0, 0.0, 3.0);
  refused(far_work, "work origin (from the base origin) is too far away");
  // While a goal moves: refused with the state; the goal goes on to its end.
  Pose goal = s.setpoint();
  goal.p_BP_B_m.y() += 0.03;
  ASSERT_EQ(s.Command(OperatorCommandKind::kGoal, &goal).command_result, CommandResult::kAccepted);
  s.Run(0.2, nullptr);
  UserFramesConfig fine;
  fine.p_PC_P_m = Eigen::Vector3d(0.0, 0.0, 0.1);
  refused(fine, "frames only from SUPERVISOR_IDLE or SUPERVISOR_JOGGING at rest (state SUPERVISOR_GOAL)");
  s.RunUntilIdle(5.0);
  EXPECT_LT((s.setpoint().p_BP_B_m - goal.p_BP_B_m).norm(), 1e-9);
  // The pivot in use is still the platform origin; at rest the change is taken.
  const UserFramesConfig& in_use = s.sim().supervisor().operator_motion().config().frames;
  EXPECT_TRUE(in_use.p_PC_P_m.isZero(0.0));
  EXPECT_EQ(s.Frames(fine).command_result, CommandResult::kAccepted);
  EXPECT_EQ((in_use.p_PC_P_m - fine.p_PC_P_m).norm(), 0.0);
  EXPECT_DOUBLE_EQ(in_use.max_pivot_distance_m, 0.5);
  // In JOGGING: taken while the jog is at rest, refused while it moves.
  s.SetJog(Jog(JogFrame::kWork, 0, 0, 0));
  ASSERT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kAccepted);
  EXPECT_EQ(s.sim().supervisor_output().state, SupervisorState::kJogging);
  UserFramesConfig other;
  other.p_PC_P_m = Eigen::Vector3d(0.0, 0.0, 0.15);
  EXPECT_EQ(s.Frames(other).command_result, CommandResult::kAccepted);
  const JogRequest moving = Jog(JogFrame::kWork, 0.03, 0, 0);
  s.Run(0.3, &moving, 0.02);
  EXPECT_EQ(s.sim().supervisor_output().state, SupervisorState::kJogging);
  refused(fine, "frames refused: the jog motion is not at rest");
  EXPECT_EQ((in_use.p_PC_P_m - other.p_PC_P_m).norm(), 0.0);
}

}  // namespace
}  // namespace hexa
