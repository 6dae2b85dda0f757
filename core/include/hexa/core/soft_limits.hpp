// Soft limits on a task-space setpoint (docs/operate.md "Soft limits"): every setpoint, from
// any source (trajectory, jog, pose goal, stream), is held inside
//   - the legs' strokes with a margin:  l_i in [mid - L/2 + margin, mid + L/2 - margin] (eq 46),
//   - the joints' deflections: the angle of leg i from its direction at home, at the base joint
//     (s_i against s_i,home, in B) and at the platform joint (R^T s_i against s_i,home, in P),
//   - a pose box: each of [x y z roll pitch yaw] within [box_min, box_max],
//   - speed limits between two setpoints one period apart: |dp| / T, |rotation| / T, and each
//     leg's |dl_i| / T.
// A candidate outside is clamped ALONG THE MOTION: the setpoint becomes
// X(s) = (p0 + s (p1 - p0), Exp(s theta) R0), theta = rotation vector of R1 R0^T, with the
// largest s in [0, 1] that satisfies every limit (bisection to 1e-6 of the step). A jog
// held into a limit therefore stops at it; the limit that stopped it is reported. A goal is
// checked as a whole path (CheckGoal) and refused with a message when any point leaves the
// static limits. Update() neither throws nor allocates.
#pragma once

#include <array>

#include "hexa/core/control_params.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

enum class SoftLimitKind {
  kNone,
  kStroke,
  kBaseJointAngle,
  kPlatformJointAngle,
  kPoseBox,
  kLinearSpeed,
  kAngularSpeed,
  kLegSpeed,
  kNotFinite,
};
const char* ToString(SoftLimitKind kind);  // "stroke", "base joint angle", ...

struct SoftLimitsConfig {
  double stroke_margin_m = 0.01;  // = SupervisorParams.stroke_margin_m: what feasibility allows
  // Joint deflections: the reference rig's joints are not specified (docs/design.md); 0.8 rad
  // (45.8 deg) is above the largest the default box reaches inside the stroke (24.7 deg base,
  // 44.9 deg platform, test SoftLimits.DefaultJointLimitsHoldTheDefaultBox), so by default it
  // does not bind. Set it from the joints' datasheet.
  double max_base_joint_angle_rad = 0.8;
  double max_platform_joint_angle_rad = 0.8;
  // Pose box [x y z roll pitch yaw] (m, rad): home +-10 cm, +-0.3 rad (17 deg): holds the
  // paper's motions (8 cm, 15 deg) and stays inside the supervisor's workspace (15 cm, 30 deg).
  Vector6d box_min = (Vector6d() << -0.10, -0.10, 0.35, -0.30, -0.30, -0.30).finished();
  Vector6d box_max = (Vector6d() << 0.10, 0.10, 0.55, 0.30, 0.30, 0.30).finished();
  double max_linear_speed_m_s = 0.8;    // |v| of the platform origin (eq 49 peaks at 0.71)
  double max_angular_speed_rad_s = 1.0;
  double max_leg_speed_m_s = 0.8;       // = SupervisorParams.max_leg_speed_m_s
  // Throws std::invalid_argument naming field, value and limit (non-finite, non-positive,
  // box_min >= box_max, margin >= half the stroke given with the rig in SoftLimits()).
  void Validate() const;
};

// The rig file's soft limits: SupervisorParams::soft_limits (joints, the box about home,
// speeds), the stroke margin and the leg speed limit of SupervisorParams.
SoftLimitsConfig MakeSoftLimitsConfig(const RigParams& rig, const SupervisorParams& params);

struct SoftLimitsInput {
  Pose previous;           // the setpoint sent last period (inside the limits)
  Pose candidate;          // the setpoint the source asks for now
  double period_s = 0.005; // time between the two
};

enum class SoftLimitsResult {
  kInside,    // candidate inside every limit: passed unchanged
  kClamped,   // stopped at a limit along the motion (fraction < 1)
  kRecovering,  // previous outside (limits tightened): a step that violates no more, within
                //   the speed limits (possibly a fraction of the candidate's)
  kHeld,      // previous outside and no step allowed, or a non-finite candidate: previous kept
};
const char* ToString(SoftLimitsResult result);

struct SoftLimitsOutput {
  Pose setpoint;                 // what may be sent
  double fraction = 1.0;         // s of the header: share of the requested step taken
  SoftLimitsResult result = SoftLimitsResult::kInside;
  SoftLimitKind active = SoftLimitKind::kNone;  // the limit that stopped the motion
  int index = 0;                 // 1-based leg (stroke, joints, leg speed) or box axis 1..6
  double value = 0.0;            // the limited quantity just beyond the held setpoint
  double limit = 0.0;            // its limit
};

// A static check of one pose: the first limit violated, most violated first.
struct PoseLimitCheck {
  SoftLimitKind kind = SoftLimitKind::kNone;
  int index = 0;
  double value = 0.0;
  double limit = 0.0;
  double excess = 0.0;  // violation normalised by the limit's scale (<= 0 inside)
};

struct GoalCheck {
  bool accepted = true;
  double path_fraction = 0.0;  // where along the path the first violation is (0 = goal itself)
  PoseLimitCheck violation;
  std::array<char, 160> message{};  // NUL-terminated reason when refused
};

class SoftLimits {
 public:
  // Throws std::invalid_argument (config.Validate(), margin against the rig's stroke).
  SoftLimits(const RigParams& rig, const SoftLimitsConfig& config);

  void Update(const SoftLimitsInput& input, SoftLimitsOutput& output) const noexcept;
  // Static limits of one pose (stroke, joints, box); kind kNone when inside.
  PoseLimitCheck CheckPose(const Pose& pose) const noexcept;
  // A pose goal reached on the path of the header from `from`, taken by the pivot frame
  // (pivot p_PC_P, user_frames.hpp; PoseGoalProfile's path): the static limits are checked at
  // the goal and at `samples` - 1 points between; the goal is refused with the first
  // violation's reason.
  GoalCheck CheckGoal(const Pose& from, const Pose& goal,
                      const Eigen::Vector3d& p_PC_P_m = Eigen::Vector3d::Zero(),
                      int samples = 64) const noexcept;

  const SoftLimitsConfig& config() const { return config_; }
  double min_length_m() const { return min_length_m_; }
  double max_length_m() const { return max_length_m_; }
  // Deflections of each leg's joints at a pose (base, platform), rad.
  void JointAngles(const Pose& pose, LegArray<double>& base_rad,
                   LegArray<double>& platform_rad) const noexcept;

 private:
  // Speed limits of the step previous -> pose.
  PoseLimitCheck CheckSpeed(const Pose& previous, const LegArray<double>& previous_length_m,
                            const Pose& pose, double period_s) const noexcept;

  GeometryParams geometry_;
  SoftLimitsConfig config_;
  double min_length_m_ = 0.0;
  double max_length_m_ = 0.0;
  LegArray<Eigen::Vector3d> home_direction_{};  // s_i at home (B = P axes at home)
};

// The point s of the clamping path (header): X(s) between X0 and X1.
Pose InterpolatePose(const Pose& from, const Pose& to, double s) noexcept;

}  // namespace hexa
