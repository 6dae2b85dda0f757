// The supervisor's operator modes (docs/operate.md "Jog and goals in the supervisor"): a jog
// or a pose goal turned into one desired sample per supervisor tick, every sample held inside
// the soft limits. The chain each tick:
//
//   jog:  JogProfile (dead-man, V/A/J per axis, look-ahead brake) -> IntegratePivotTwist ->
//         SoftLimits::Update (clamp along the motion)
//   goal: PoseGoalProfile (double-S along the path, refused up front by SoftLimits::CheckGoal
//         if the goal or its path leaves the limits) -> SoftLimits::Update
//   stream: MotionStream (sequence checks, timeout -> back to neutral, washout for vehicle
//         packets, V/A/J per axis) -> PlatformPoseFromDisplacement (from the neutral pose the
//         stream began at) -> SoftLimits::Update (a stream that crosses a limit is clamped)
//   stop: a goal hands its twist and acceleration to the jog profile, which brings it to rest
//         at the jerk limit; a jog's target becomes zero and later jog messages are ignored.
//
// Pure: time is an argument; Begin*/Update neither throw nor allocate.
#pragma once

#include <array>

#include "hexa/core/motion_profile.hpp"
#include "hexa/core/motion_stream.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/soft_limits.hpp"
#include "hexa/core/trajectory.hpp"
#include "hexa/core/user_frames.hpp"

namespace hexa {

struct OperatorMotionConfig {
  JogProfileConfig jog;
  // A goal's path limits: the pivot's speed, acceleration and jerk along its straight line,
  // and the rotation angle's about its axis.
  AxisLimits goal_linear{0.05, 0.25, 2.5};
  AxisLimits goal_angular{0.2, 1.0, 10.0};
  SoftLimitsConfig limits;
  UserFramesConfig frames;
  // The external motion stream (STREAMING); its period_s is the supervisor's.
  MotionStreamConfig stream;
  void Validate() const;  // throws std::invalid_argument naming the field, value and limit
};

// One jog message: a twist of the pivot frame in the axes of `frame` (work: fixed to the base;
// tool: turning with the platform).
struct JogRequest {
  JogFrame frame = JogFrame::kWork;
  Vector6d twist = Vector6d::Zero();  // [v m/s; w rad/s]
};

enum class OperatorMode { kNone, kJog, kGoal, kStream };
const char* ToString(OperatorMode mode);  // "none", "jog", "goal", "stream"

struct OperatorMotionStatus {
  OperatorMode mode = OperatorMode::kNone;
  bool done = false;        // the mode ended: at rest (a jog let go or stopped, a goal reached)
  bool stopping = false;    // an operator stop is bringing the motion to rest
  JogStatus jog = JogStatus::kStill;
  double goal_time_s = 0.0; // time since the goal started
  MotionStreamOutput stream;  // kStream: the follower's displacement, state, timeout
  SoftLimitsOutput limits;  // the soft limits' verdict on this tick's setpoint
};

class OperatorMotion {
 public:
  // Throws std::invalid_argument for an invalid configuration (values named).
  OperatorMotion(const RigParams& rig, const OperatorMotionConfig& config);

  // A jog from rest at X_BP (the supervisor's rest pose).
  void BeginJog(const Pose& X_BP) noexcept;
  // A goal for the platform frame from rest at X_BP. Refused (accepted false, the message says
  // why) when the goal or the path to it leaves the soft limits; then nothing changes.
  GoalCheck BeginGoal(const Pose& X_BP, const Pose& X_BP_goal, double time_s) noexcept;
  // A stream from rest at X_BP, which becomes its neutral pose (the displacements' origin).
  void BeginStream(const Pose& X_BP) noexcept;
  // The pivot, tool and work frames for the commands from now on (user_frames.hpp); the
  // platform does not move. Taken only while the setpoint is still: no mode, or a jog at rest
  // (a changed pivot under a moving jog, goal or stream would change the motion under way).
  // Refused, nothing changed, with `message` naming the rule, the field, the value and the
  // limit (CheckFramesRequest with the configured bounds; a pivot 10 m away is refused).
  bool SetFrames(const UserFramesConfig& frames, std::array<char, 160>& message) noexcept;
  // Brings the current mode to rest: a jog or a goal at the jog profile's limits, a stream
  // back to its neutral pose at the stream's limits.
  void RequestStop() noexcept;
  // One tick at `time_s` (dt_s after the previous one). `jog`: the newest jog message since the
  // previous tick, or null. `stream_packets`: the stream packets decoded since the previous
  // tick, in arrival order (used in kStream only). Fills `desired` (pose, twist, rate; phase
  // kTracking).
  void Update(double time_s, double dt_s, const JogRequest* jog, TrajectorySample& desired,
              OperatorMotionStatus& status, const StreamPacket* stream_packets = nullptr,
              std::size_t stream_packet_count = 0) noexcept;

  OperatorMode mode() const { return mode_; }
  const Pose& setpoint() const { return setpoint_; }
  const SoftLimits& limits() const { return limits_; }
  const OperatorMotionConfig& config() const { return config_; }
  double goal_duration_s() const { return goal_.duration_s(); }
  const MotionStream& stream() const { return stream_; }

 private:
  void StepJog(double time_s, double dt_s, const JogRequest* jog, Vector6d& twist_C_B,
               Vector6d& acceleration_C_B, OperatorMotionStatus& status) noexcept;
  Pose StepStream(double time_s, const StreamPacket* packets, std::size_t count,
                  Vector6d& twist_C_B, Vector6d& acceleration_C_B,
                  OperatorMotionStatus& status) noexcept;

  OperatorMotionConfig config_;
  SoftLimits limits_;
  JogProfile jog_;
  PoseGoalProfile goal_;
  MotionStream stream_;
  Pose stream_neutral_;  // X_BP where the stream began
  OperatorMode mode_ = OperatorMode::kNone;
  bool stopping_ = false;
  double goal_start_s_ = 0.0;
  Pose setpoint_;  // the last setpoint sent (inside the limits)
};

}  // namespace hexa
