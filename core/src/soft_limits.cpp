// Soft limits on a task-space setpoint (see soft_limits.hpp, docs/operate.md).
#include "hexa/core/soft_limits.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/trajectory.hpp"
#include "hexa/core/user_frames.hpp"

namespace hexa {
namespace {

constexpr int kBisectionSteps = 20;  // 2^-20 < 1e-6 of the step
const char* const kAxisNames[6] = {"x", "y", "z", "roll", "pitch", "yaw"};

double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Keeps the larger (normalised) violation.
void Consider(PoseLimitCheck& worst, SoftLimitKind kind, int index, double value, double limit,
              double excess) {
  if (excess > 0.0 && (worst.kind == SoftLimitKind::kNone || excess > worst.excess)) {
    worst = PoseLimitCheck{kind, index, value, limit, excess};
  }
}

}  // namespace

const char* ToString(SoftLimitKind kind) {
  switch (kind) {
    case SoftLimitKind::kNone: return "none";
    case SoftLimitKind::kStroke: return "stroke";
    case SoftLimitKind::kBaseJointAngle: return "base joint angle";
    case SoftLimitKind::kPlatformJointAngle: return "platform joint angle";
    case SoftLimitKind::kPoseBox: return "pose box";
    case SoftLimitKind::kLinearSpeed: return "linear speed";
    case SoftLimitKind::kAngularSpeed: return "angular speed";
    case SoftLimitKind::kLegSpeed: return "leg speed";
    case SoftLimitKind::kNotFinite: return "not finite";
  }
  return "unknown";
}

const char* ToString(SoftLimitsResult result) {
  switch (result) {
    case SoftLimitsResult::kInside: return "inside";
    case SoftLimitsResult::kClamped: return "clamped";
    case SoftLimitsResult::kRecovering: return "recovering";
    case SoftLimitsResult::kHeld: return "held";
  }
  return "unknown";
}

void SoftLimitsConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.NonNegative("soft_limits.stroke_margin_m", stroke_margin_m, "stroke margin");
  c.InClosed("soft_limits.max_base_joint_angle_rad", max_base_joint_angle_rad, 1e-3, 1.5,
             "base joint angle limit");
  c.InClosed("soft_limits.max_platform_joint_angle_rad", max_platform_joint_angle_rad, 1e-3, 1.5,
             "platform joint angle limit");
  for (int i = 0; i < 6; ++i) {
    const std::string lo = std::string("soft_limits.box_min.") + kAxisNames[i];
    const std::string hi = std::string("soft_limits.box_max.") + kAxisNames[i];
    if (c.Finite(lo, box_min[i]) && c.Finite(hi, box_max[i]) && !(box_min[i] < box_max[i])) {
      c.Fail(hi, "box maximum must exceed its minimum", FormatParam(box_max[i]),
             "> " + FormatParam(box_min[i]));
    }
  }
  for (int i = 3; i < 6; ++i) {
    c.InClosed(std::string("soft_limits.box_min.") + kAxisNames[i], box_min[i], -1.5, 1.5,
               "box angle (roll/pitch/yaw singular at 90 deg)");
    c.InClosed(std::string("soft_limits.box_max.") + kAxisNames[i], box_max[i], -1.5, 1.5,
               "box angle (roll/pitch/yaw singular at 90 deg)");
  }
  c.Positive("soft_limits.max_linear_speed_m_s", max_linear_speed_m_s, "linear speed limit");
  c.Positive("soft_limits.max_angular_speed_rad_s", max_angular_speed_rad_s, "angular speed limit");
  c.Positive("soft_limits.max_leg_speed_m_s", max_leg_speed_m_s, "leg speed limit");
  ThrowIfIssues(issues, "soft limits");
}

SoftLimitsConfig MakeSoftLimitsConfig(const RigParams& rig, const SupervisorParams& params) {
  SoftLimitsConfig config;
  const SoftLimitParams& s = params.soft_limits;
  config.stroke_margin_m = params.stroke_margin_m;
  config.max_leg_speed_m_s = params.max_leg_speed_m_s;
  config.max_base_joint_angle_rad = s.max_base_joint_angle_rad;
  config.max_platform_joint_angle_rad = s.max_platform_joint_angle_rad;
  config.max_linear_speed_m_s = s.max_linear_speed_m_s;
  config.max_angular_speed_rad_s = s.max_angular_speed_rad_s;
  // The box about home (home has no rotation: the angles' bounds are the angles').
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  for (int k = 0; k < 3; ++k) {
    const auto i = static_cast<std::size_t>(k);
    config.box_min[k] = home[k] + s.position_min_from_home_m[i];
    config.box_max[k] = home[k] + s.position_max_from_home_m[i];
    config.box_min[3 + k] = home[3 + k] + s.rotation_min_rad[i];
    config.box_max[3 + k] = home[3 + k] + s.rotation_max_rad[i];
  }
  return config;
}

SoftLimits::SoftLimits(const RigParams& rig, const SoftLimitsConfig& config)
    : geometry_(rig.geometry), config_(config) {
  config_.Validate();
  if (!(config.stroke_margin_m < 0.5 * rig.cylinder.stroke_m)) {
    std::vector<ParamIssue> issues{{"soft_limits.stroke_margin_m",
                                    "margin leaves no stroke", FormatParam(config.stroke_margin_m),
                                    "< " + FormatParam(0.5 * rig.cylinder.stroke_m)}};
    ThrowIfIssues(issues, "soft limits");
  }
  min_length_m_ = rig.cylinder.mid_stroke_length_m - 0.5 * rig.cylinder.stroke_m +
                  config.stroke_margin_m;
  max_length_m_ = rig.cylinder.mid_stroke_length_m + 0.5 * rig.cylinder.stroke_m -
                  config.stroke_margin_m;
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  LegArray<double> length_m{};
  InverseKinematics(geometry_, home, length_m, &home_direction_);
}

void SoftLimits::JointAngles(const Pose& pose, LegArray<double>& base_rad,
                             LegArray<double>& platform_rad) const noexcept {
  LegArray<double> length_m{};
  LegArray<Eigen::Vector3d> unit_B{};
  InverseKinematics(geometry_, pose, length_m, &unit_B);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    base_rad[i] = AngleBetween(unit_B[i], home_direction_[i]);
    platform_rad[i] = AngleBetween(pose.R_BP.transpose() * unit_B[i], home_direction_[i]);
  }
}

PoseLimitCheck SoftLimits::CheckPose(const Pose& pose) const noexcept {
  PoseLimitCheck worst;
  if (!pose.p_BP_B_m.allFinite() || !pose.R_BP.allFinite()) {
    worst.kind = SoftLimitKind::kNotFinite;
    worst.excess = 1.0;
    return worst;
  }
  LegArray<double> length_m{};
  LegArray<Eigen::Vector3d> unit_B{};
  InverseKinematics(geometry_, pose, length_m, &unit_B);
  const double half_stroke_m = 0.5 * (max_length_m_ - min_length_m_);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int leg = static_cast<int>(i) + 1;
    if (length_m[i] > max_length_m_) {
      Consider(worst, SoftLimitKind::kStroke, leg, length_m[i], max_length_m_,
               (length_m[i] - max_length_m_) / half_stroke_m);
    } else if (length_m[i] < min_length_m_) {
      Consider(worst, SoftLimitKind::kStroke, leg, length_m[i], min_length_m_,
               (min_length_m_ - length_m[i]) / half_stroke_m);
    }
    const double base = AngleBetween(unit_B[i], home_direction_[i]);
    Consider(worst, SoftLimitKind::kBaseJointAngle, leg, base, config_.max_base_joint_angle_rad,
             base / config_.max_base_joint_angle_rad - 1.0);
    const double platform = AngleBetween(pose.R_BP.transpose() * unit_B[i], home_direction_[i]);
    Consider(worst, SoftLimitKind::kPlatformJointAngle, leg, platform,
             config_.max_platform_joint_angle_rad,
             platform / config_.max_platform_joint_angle_rad - 1.0);
  }
  const Vector6d q = VectorFromPose(pose);
  for (int k = 0; k < 6; ++k) {
    const double half = 0.5 * (config_.box_max[k] - config_.box_min[k]);
    if (q[k] > config_.box_max[k]) {
      Consider(worst, SoftLimitKind::kPoseBox, k + 1, q[k], config_.box_max[k],
               (q[k] - config_.box_max[k]) / half);
    } else if (q[k] < config_.box_min[k]) {
      Consider(worst, SoftLimitKind::kPoseBox, k + 1, q[k], config_.box_min[k],
               (config_.box_min[k] - q[k]) / half);
    }
  }
  return worst;
}

PoseLimitCheck SoftLimits::CheckSpeed(const Pose& previous,
                                      const LegArray<double>& previous_length_m, const Pose& pose,
                                      double period_s) const noexcept {
  PoseLimitCheck worst;
  const double linear = (pose.p_BP_B_m - previous.p_BP_B_m).norm() / period_s;
  Consider(worst, SoftLimitKind::kLinearSpeed, 0, linear, config_.max_linear_speed_m_s,
           linear / config_.max_linear_speed_m_s - 1.0);
  const double angular = PoseError(pose, previous).tail<3>().norm() / period_s;
  Consider(worst, SoftLimitKind::kAngularSpeed, 0, angular, config_.max_angular_speed_rad_s,
           angular / config_.max_angular_speed_rad_s - 1.0);
  LegArray<double> length_m{};
  InverseKinematics(geometry_, pose, length_m);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double speed = std::abs(length_m[i] - previous_length_m[i]) / period_s;
    Consider(worst, SoftLimitKind::kLegSpeed, static_cast<int>(i) + 1, speed,
             config_.max_leg_speed_m_s, speed / config_.max_leg_speed_m_s - 1.0);
  }
  return worst;
}

Pose InterpolatePose(const Pose& from, const Pose& to, double s) noexcept {
  Pose pose;
  pose.p_BP_B_m = from.p_BP_B_m + s * (to.p_BP_B_m - from.p_BP_B_m);
  const Eigen::Vector3d theta = PoseError(to, from).tail<3>();
  pose.R_BP = RotationFromVector(s * theta) * from.R_BP;
  return pose;
}

void SoftLimits::Update(const SoftLimitsInput& input, SoftLimitsOutput& output) const noexcept {
  output = SoftLimitsOutput{};
  output.setpoint = input.previous;
  const bool finite = input.candidate.p_BP_B_m.allFinite() && input.candidate.R_BP.allFinite() &&
                      std::isfinite(input.period_s) && input.period_s > 0.0;
  if (!finite) {
    output.fraction = 0.0;
    output.result = SoftLimitsResult::kHeld;
    output.active = SoftLimitKind::kNotFinite;
    return;
  }
  LegArray<double> previous_length_m{};
  InverseKinematics(geometry_, input.previous, previous_length_m);
  // Previous setpoint outside (limits tightened at run time, or the first setpoint): a step is
  // allowed if it keeps the speed limits and does not make the static violation worse, so the
  // operator can move back in.
  const PoseLimitCheck at_previous = CheckPose(input.previous);
  const bool recovering = at_previous.kind != SoftLimitKind::kNone;
  // The first limit a pose X breaks on the step previous -> X (kNone: X may be sent).
  const auto broken = [&](const Pose& X) {
    const PoseLimitCheck speed = CheckSpeed(input.previous, previous_length_m, X, input.period_s);
    if (speed.kind != SoftLimitKind::kNone) return speed;
    PoseLimitCheck statics = CheckPose(X);
    if (recovering && statics.excess <= at_previous.excess) statics.kind = SoftLimitKind::kNone;
    return statics;
  };
  PoseLimitCheck outside = broken(input.candidate);
  if (outside.kind == SoftLimitKind::kNone) {
    output.setpoint = input.candidate;
    output.result = recovering ? SoftLimitsResult::kRecovering : SoftLimitsResult::kInside;
    if (recovering) {
      output.active = at_previous.kind;
      output.index = at_previous.index;
      output.value = at_previous.value;
      output.limit = at_previous.limit;
    }
    return;
  }
  // Largest s with X(s) allowed: bisection between an allowed s_lo and a refused s_hi.
  double s_lo = 0.0, s_hi = 1.0;
  for (int step = 0; step < kBisectionSteps; ++step) {
    const double s = 0.5 * (s_lo + s_hi);
    const PoseLimitCheck check = broken(InterpolatePose(input.previous, input.candidate, s));
    if (check.kind == SoftLimitKind::kNone) {
      s_lo = s;
    } else {
      s_hi = s;
      outside = check;
    }
  }
  output.setpoint = InterpolatePose(input.previous, input.candidate, s_lo);
  output.fraction = s_lo;
  output.result = recovering ? (s_lo > 0.0 ? SoftLimitsResult::kRecovering : SoftLimitsResult::kHeld)
                             : SoftLimitsResult::kClamped;
  output.active = outside.kind;
  output.index = outside.index;
  output.value = outside.value;
  output.limit = outside.limit;
}

GoalCheck SoftLimits::CheckGoal(const Pose& from, const Pose& goal,
                                const Eigen::Vector3d& p_PC_P_m, int samples) const noexcept {
  GoalCheck result;
  if (samples < 1) samples = 1;
  const Pose from_C = PivotPose(from, p_PC_P_m), goal_C = PivotPose(goal, p_PC_P_m);
  // The goal itself first: its reason is the one an operator can act on.
  PoseLimitCheck check = CheckPose(goal);
  double fraction = 0.0;
  for (int k = 1; k < samples && check.kind == SoftLimitKind::kNone; ++k) {
    fraction = static_cast<double>(k) / samples;
    check = CheckPose(PlatformFromPivot(InterpolatePose(from_C, goal_C, fraction), p_PC_P_m));
  }
  if (check.kind == SoftLimitKind::kNone) return result;
  result.accepted = false;
  result.path_fraction = fraction;
  result.violation = check;
  const char* unit = check.kind == SoftLimitKind::kStroke ? "m" : "rad";
  char where[48];
  if (fraction == 0.0) {
    std::snprintf(where, sizeof(where), "the goal");
  } else {
    std::snprintf(where, sizeof(where), "the path at %.0f %%", 100.0 * fraction);
  }
  if (check.kind == SoftLimitKind::kNotFinite) {
    std::snprintf(result.message.data(), result.message.size(), "goal refused: not finite");
  } else if (check.kind == SoftLimitKind::kPoseBox) {
    const int axis = check.index - 1;
    std::snprintf(result.message.data(), result.message.size(),
                  "goal refused: %s leaves the pose box: %s %.4f %s beyond the limit %.4f",
                  where, kAxisNames[axis], check.value, axis < 3 ? "m" : "rad", check.limit);
  } else {
    std::snprintf(result.message.data(), result.message.size(),
                  "goal refused: %s breaks the %s limit of leg %d: %.4f %s, limit %.4f", where,
                  ToString(check.kind), check.index, check.value, unit, check.limit);
  }
  return result;
}

}  // namespace hexa
