// The units chained as the supervisor runs them: jog (or stream) -> pivot and frames -> soft
// limits. A jog held towards each of three limits (box x, the stroke, box roll about a pivot)
// stops at it, never beyond; with the stopping-distance look-ahead it slows down instead of
// being cut (peak setpoint acceleration with and without it). A stream that crosses a limit is
// clamped and the limit reported.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/motion_profile.hpp"
#include "hexa/core/motion_stream.hpp"
#include "hexa/core/soft_limits.hpp"
#include "hexa/core/user_frames.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::HomePose;

constexpr double kPeriod_s = 0.005;

struct HeldJog {
  double worst_excess = -1.0;  // largest normalised violation of any static limit (<= 0 inside)
  double final_excess = 0.0;   // how far inside the limit the jog ended (normalised, <= 0)
  double peak_acceleration = 0.0;  // of the pivot point, m/s^2, second differences
  double peak_angular_acceleration = 0.0;  // rad/s^2, differences of the rotation per tick
  int hard_clamps = 0;
  PoseLimitCheck nearest;  // the limit at the end, evaluated slightly beyond
};

// Holds `twist_jog` (work frame) for 6 s through jog -> frames -> soft limits.
HeldJog HoldJog(const SoftLimits& limits, const UserFramesConfig& frames, const Vector6d& twist_jog,
                bool look_ahead) {
  JogProfile jog(JogProfileConfig{});
  Pose setpoint = HomePose(MakeReferenceRig());
  Eigen::Vector3d p1 = PivotPose(setpoint, frames.p_PC_P_m).p_BP_B_m, p2 = p1;
  Pose previous = setpoint;
  Eigen::Vector3d w1 = Eigen::Vector3d::Zero();
  HeldJog r;
  for (int k = 0; k < 6.0 / kPeriod_s; ++k) {
    JogInput in;
    in.time_s = k * kPeriod_s;
    in.dt_s = kPeriod_s;
    in.command_received = true;
    in.twist_jog = twist_jog;
    in.R_B_jog = JogAxes(JogFrame::kWork, setpoint, frames);
    if (look_ahead) {
      const Pose stop = IntegratePivotTwist(setpoint, frames.p_PC_P_m, jog.StoppingDisplacement(), 1.0);
      in.brake = limits.CheckPose(stop).kind != SoftLimitKind::kNone;
    }
    JogOutput out;
    jog.Update(in, out);
    SoftLimitsOutput held;
    limits.Update({setpoint, IntegratePivotTwist(setpoint, frames.p_PC_P_m, out.twist_C_B, kPeriod_s),
                   kPeriod_s},
                  held);
    setpoint = held.setpoint;
    if (held.result == SoftLimitsResult::kClamped) ++r.hard_clamps;
    r.worst_excess = std::max(r.worst_excess, limits.CheckPose(setpoint).excess);
    const Eigen::Vector3d p = PivotPose(setpoint, frames.p_PC_P_m).p_BP_B_m;
    if (k >= 2) r.peak_acceleration = std::max(r.peak_acceleration, (p - 2 * p1 + p2).norm() / (kPeriod_s * kPeriod_s));
    p2 = p1;
    p1 = p;
    const Eigen::Vector3d w = PoseError(setpoint, previous).tail<3>() / kPeriod_s;
    r.peak_angular_acceleration = std::max(r.peak_angular_acceleration, (w - w1).norm() / kPeriod_s);
    w1 = w;
    previous = setpoint;
  }
  // How close to the limit: the pose one more millimetre / milliradian along the jog.
  Vector6d probe = twist_jog.normalized() * 1e-3;
  r.nearest = limits.CheckPose(IntegratePivotTwist(setpoint, frames.p_PC_P_m, probe, 1.0));
  return r;
}

TEST(OperateChain, AJogHeldTowardsEachOfThreeLimitsStopsAtIt) {
  const RigParams rig = MakeReferenceRig();
  SoftLimitsConfig box = MakeSoftLimitsConfig(rig, SupervisorParams{});
  SoftLimitsConfig wide = box;
  wide.box_max[2] = 1.0;
  const SoftLimits box_limits(rig, box), wide_limits(rig, wide);
  UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(0, 0, 0.2);
  struct Case {
    const char* name;
    const SoftLimits* limits;
    Vector6d twist;
    SoftLimitKind kind;
  };
  Vector6d x = Vector6d::Zero(), z = Vector6d::Zero(), roll = Vector6d::Zero();
  x[0] = 0.05;
  z[2] = 0.05;
  roll[3] = 0.2;
  const Case cases[] = {{"box x", &box_limits, x, SoftLimitKind::kPoseBox},
                        {"stroke", &wide_limits, z, SoftLimitKind::kStroke},
                        {"box roll about the pivot", &box_limits, roll, SoftLimitKind::kPoseBox}};
  for (const Case& c : cases) {
    for (bool look_ahead : {false, true}) {
      const HeldJog r = HoldJog(*c.limits, frames, c.twist, look_ahead);
      std::printf("%-24s look-ahead %d: largest excess %.3g, limit within 1 mm/mrad: %s (%s), "
                  "hard clamps %d, peak pivot acceleration %.2f m/s2, angular %.2f rad/s2\n",
                  c.name, look_ahead, r.worst_excess, r.nearest.kind != SoftLimitKind::kNone ? "yes" : "no",
                  ToString(r.nearest.kind), r.hard_clamps, r.peak_acceleration,
                  r.peak_angular_acceleration);
      EXPECT_LE(r.worst_excess, 0.0) << c.name;  // never beyond
      EXPECT_EQ(r.nearest.kind, c.kind) << c.name;  // stopped at that limit
      // With the look-ahead, the jog's own limits (0.25 m/s2, 1 rad/s2); without it, the cut at
      // the limit is a velocity step of one period.
      const bool rotation = c.twist[3] != 0.0;
      const double peak = rotation ? r.peak_angular_acceleration : r.peak_acceleration;
      const double jog_limit = rotation ? 1.0 : 0.25;
      if (look_ahead) {
        EXPECT_LE(peak, jog_limit * 1.01) << c.name;
      } else {
        EXPECT_GT(peak, 4.0 * jog_limit) << c.name;
      }
    }
  }
}

// A pose stream of x = 15 cm sin(pi t) through frames and soft limits: the box's 10 cm clamps
// it and the limit is reported; the setpoint never leaves the box.
TEST(OperateChain, AStreamThatCrossesALimitIsClampedAndReported) {
  const RigParams rig = MakeReferenceRig();
  const SoftLimits limits(rig, MakeSoftLimitsConfig(rig, SupervisorParams{}));
  MotionStreamConfig config;
  config.decode.max_abs_position_m = 0.5;
  MotionStream stream(config);
  const UserFramesConfig frames;
  Pose setpoint = HomePose(rig);
  int clamped = 0;
  double largest_x = 0.0;
  SoftLimitKind reported = SoftLimitKind::kNone;
  for (int k = 0; k < 800; ++k) {
    const double t = k * kPeriod_s;
    StreamPacket p;
    p.sequence = k;
    p.time_s = t;
    p.values[0] = 0.15 * std::sin(3.14159265358979 * t);
    MotionStreamOutput out;
    stream.Update({t, &p, 1}, out);
    SoftLimitsOutput held;
    limits.Update({setpoint, PlatformPoseFromDisplacement(HomePose(rig), out.displacement, frames),
                   kPeriod_s},
                  held);
    setpoint = held.setpoint;
    if (held.result == SoftLimitsResult::kClamped) {
      ++clamped;
      reported = held.active;
    }
    largest_x = std::max(largest_x, setpoint.p_BP_B_m.x());
  }
  std::printf("stream of 15 cm: clamped on %d of 800 ticks, largest x %.6f m (box 0.1)\n", clamped,
              largest_x);
  EXPECT_GT(clamped, 50);
  EXPECT_EQ(reported, SoftLimitKind::kPoseBox);
  EXPECT_LE(largest_x, 0.1);
  EXPECT_GT(largest_x, 0.1 - 1e-6);
}

}  // namespace
}  // namespace hexa
