// Task-space supervisor (docs/design.md "Safety", paper Sec. 4.1): a pure state machine run every
// 5 ms with the measured leg lengths and IMU orientation. It owns the trajectory, the pose
// estimator (eq 47 / six-leg least squares), the Jacobian outer loop (eq 48) and the safety
// logic, and produces the six leg setpoints. No clock, no DDS: time is SupervisorInput.time_s.
//
//            start (feasible)        blend done         tracking done       stop done
//   IDLE ------------------> BLENDING ---------> TRACKING ---------> STOPPING ---------> IDLE
//    |  home (blend to home) ^   |  stop               | stop                               ^
//    +-----------------------+   +---------------------+---> STOPPING                       |
//   any state --fault / rejected trajectory--> HOLD --reset (only command accepted)--------+
//
//            jog                  let go (dead-man) or stop, at rest
//   IDLE ------------> JOGGING ------------------------------------> IDLE
//            goal (inside the soft limits)    reached or stop, at rest
//   IDLE ------------> GOAL    ------------------------------------> IDLE
//            stream (operator)        stop: back to the neutral pose, at rest
//   IDLE ------------> STREAMING ---------------------------------------> IDLE
//   (a stream gap longer than its timeout: back to neutral, still STREAMING; packets resume it)
//   frames (pivot, tool, work): taken in IDLE or in JOGGING at rest; the platform does not move
//   (operator_motion.hpp: every jog, goal and stream setpoint is held inside the soft limits;
//   a goal outside them is refused with the reason, the state unchanged)
//
// Faults (checked every tick outside HOLD): a leg fault reported by a leg / the plant, lost
// liveliness of a leg controller, more consecutive deadline misses than configured, invalid
// sensors or estimate, estimate outside the workspace; a rejected trajectory on start.
// In HOLD every setpoint is frozen (last length and correction, zero velocity and
// acceleration, hold flag set) and the fault is reported until an operator reset.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "hexa/core/control_params.hpp"
#include "hexa/core/csv_trajectory.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/operator_motion.hpp"
#include "hexa/core/outer_loop.hpp"
#include "hexa/core/platform_dynamics.hpp"
#include "hexa/core/pose_estimator.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {

// Same enumerators, in the same order, as idl/hexa.idl SupervisorState (static_cast maps).
enum class SupervisorState {
  kIdle, kBlending, kTracking, kStopping, kHold, kJogging, kGoal, kStreaming
};
const char* ToString(SupervisorState state);  // "SUPERVISOR_IDLE", ...

// Same enumerators, in the same order, as idl/hexa.idl FaultReason (static_cast maps).
enum class FaultReason {
  kNone,
  kCommandDeadlineMissed,
  kCommandStale,
  kCommandNotFinite,
  kCommandOutOfRange,
  kSetpointStale,
  kLivelinessLost,
  kDeadlineMissesExceeded,
  kStateNotFinite,
  kEstimateOutsideWorkspace,
  kSensorInvalid,
  kTrajectoryRejected,
  kHostOverload,        // real time: every leg's command late at once: the host, not a leg
  kComputeOverrun,      // a leg controller's cycle exceeded its compute budget
  kWriterGone,          // a leg controller's writer (or its process) disappeared
  kSupplyPressureLow,   // supply pressure below what the legs need
  kSensorInconsistent,  // a leg length disagrees with the other legs and the IMU
  kImuLost,             // the IMU stopped delivering samples
  kCommandRefused,      // a command from a writer not of this session was refused
  kEstop,               // the e-stop latched (the board's loop input, or the operator)
  kBoardLink,           // the I/O board stopped answering
};
const char* ToString(FaultReason reason);  // "FAULT_NONE", ...

enum class OperatorCommandKind { kNone, kStart, kStop, kReset, kHome, kJog, kGoal, kStream, kFrames };
const char* ToString(OperatorCommandKind kind);

enum class CommandResult {
  kNone,      // no command this tick
  kAccepted,
  kRefused,   // not allowed in the current state (e.g. anything but reset in HOLD)
  kRejected,  // start with an infeasible trajectory: the supervisor went to HOLD
};
const char* ToString(CommandResult result);

// A start command prepared outside the 5 ms cycle (feasibility takes milliseconds).
struct StartRequest {
  Trajectory trajectory;
  FeasibilityReport feasibility;
};

struct SupervisorInput {
  double time_s = 0.0;                                   // simulated time of this tick
  LegArray<double> length_m{};                           // measured leg lengths
  std::array<double, 4> orientation_wxyz{1.0, 0.0, 0.0, 0.0};  // IMU R_BP
  LegArray<FaultReason> leg_fault{};                     // reported per leg, kNone = healthy
  FaultReason system_fault = FaultReason::kNone;         // reported for no leg (host, plant)
  LegArray<bool> leg_alive{true, true, true, true, true, true};  // leg controller liveliness
  LegArray<int> deadline_misses_consecutive{};           // per leg input topic
  int imu_deadline_misses_consecutive = 0;
  OperatorCommandKind command = OperatorCommandKind::kNone;
  const StartRequest* start = nullptr;                   // for kStart; copied, not kept
  JogRequest jog;                                        // for kJog: the newest jog message
  Pose goal_X_BP;                                        // for kGoal: the platform's goal pose
  // For kFrames: the pivot point, tool and work frames from now on (user_frames.hpp); taken in
  // IDLE or while a jog is at rest, validated with the configured bounds.
  UserFramesConfig frames;
  // The external motion stream's packets decoded since the previous tick (arrival order; the
  // service's receiver owns them). Applied in STREAMING only, ignored otherwise.
  const StreamPacket* stream_packets = nullptr;
  std::size_t stream_packet_count = 0;
};

struct SupervisorLegSetpoint {
  double length_m = 0.0;           // IK (eq 46) of the desired pose, without correction
  double velocity_m_s = 0.0;
  double acceleration_m_s2 = 0.0;
  double correction_m = 0.0;       // outer loop (Sec. 4.1); the leg tracks length + correction
  bool hold = false;
  // Inverse-dynamics feed-forward (core/platform_dynamics.hpp): the leg's axial force for the
  // desired motion at this setpoint's time and its rate over the next supervisor period (the
  // leg interpolates force + rate * dt). Not valid: the leg uses its lumped load model.
  bool feedforward_valid = false;
  double feedforward_force_n = 0.0;
  double feedforward_force_rate_n_s = 0.0;
};

struct SupervisorOutput {
  SupervisorState state = SupervisorState::kIdle;
  double trajectory_time_s = 0.0;
  LegArray<SupervisorLegSetpoint> setpoint{};
  TrajectorySample desired;            // desired pose, twist and rate (frozen in HOLD)
  Vector6d desired_xyz_rpy = Vector6d::Zero();
  PoseEstimatorOutput estimate;
  OuterLoopOutput outer_loop;          // error = desired - estimated, corrections
  FaultReason fault = FaultReason::kNone;  // active fault (kept while in HOLD)
  int fault_leg = 0;                   // 1-based, 0 when no leg is concerned
  std::array<char, 160> fault_detail{};  // NUL-terminated, as idl FaultEvent.detail
  bool fault_raised = false;           // the fault was raised at this tick (publish an event)
  CommandResult command_result = CommandResult::kNone;
  std::array<char, 160> command_detail{};  // why a command was refused (a goal: which limit)
  OperatorMotionStatus operator_motion;    // in JOGGING / GOAL / STREAMING: the mode's status
};

// The operator modes' defaults for this rig: the soft limits from its geometry and `params`
// (stroke margin), the stream at the supervisor's period. Throws for invalid `params`.
OperatorMotionConfig MakeOperatorMotionConfig(const RigParams& rig, const SupervisorParams& params);

class Supervisor {
 public:
  // Throws std::invalid_argument for inconsistent parameters (values named). `potentiometer`:
  // the calibration of each leg's potentiometer (rig overlay, kinematic
  // calibration); every measured length is corrected with it before use. Identity by default.
  Supervisor(const RigParams& rig, const SupervisorParams& params,
             const LegArray<PotentiometerCalibrationParams>& potentiometer = {});
  // With the operator modes' limits, frames and soft limits given (validated, throws). The
  // stream runs at the supervisor's period: operator_motion.stream.period_s (and its washout's)
  // are set to params.period_s.
  Supervisor(const RigParams& rig, const SupervisorParams& params,
             const LegArray<PotentiometerCalibrationParams>& potentiometer,
             const OperatorMotionConfig& operator_motion);

  // One 5 ms tick. Neither throws nor allocates.
  void Update(const SupervisorInput& input, SupervisorOutput& output) noexcept;

  SupervisorState state() const { return state_; }
  bool initialized() const { return initialized_; }
  // Where the platform rests when idle: the start pose of the next trajectory.
  const Vector6d& rest_xyz_rpy() const { return rest_; }
  const Vector6d& home_xyz_rpy() const { return home_; }
  TrajectoryTiming timing() const { return TimingFrom(params_); }
  const RigParams& rig() const { return rig_; }
  const SupervisorParams& params() const { return params_; }
  const OperatorMotion& operator_motion() const { return operator_motion_; }
  // Largest residual of a leg length against the least-squares fit of all six seen so far
  // (fault-free: calibration errors and noise; docs/faults.md measures it).
  double max_consistency_residual_m() const { return max_consistency_residual_m_; }

  // Outside the cycle: build a start request from the current rest pose and check it.
  StartRequest PrepareStart(Trajectory trajectory) const;
  StartRequest PreparePaperStart(PaperMotion motion, int periods = 0,
                                 double amplitude_scale = 1.0) const;
  // A user trajectory of rows (read from a CSV file by config/): blends in from the rest pose
  // and returns to home at its end.
  StartRequest PrepareRowsStart(std::shared_ptr<const CsvMotion> rows) const;
  // A request rejected before a trajectory existed (e.g. a CSV file that does not parse):
  // started with kStart it puts the supervisor in HOLD with `message` as the fault detail.
  static StartRequest RejectedStart(std::string message);

 private:
  void EnterHold(FaultReason reason, int leg, const char* detail, SupervisorOutput& output);
  FaultReason CheckFaults(const SupervisorInput& input, const PoseEstimatorOutput& estimate,
                          int& leg, std::array<char, 160>& detail) const;
  void HandleCommand(const SupervisorInput& input, SupervisorOutput& output);
  void StartTrajectory(const Trajectory& trajectory, double time_s);
  // kJog / kGoal / kStream (HandleCommand's part for the operator modes).
  void HandleMotionCommand(const SupervisorInput& input, SupervisorOutput& output);
  bool following_trajectory() const {
    return state_ == SupervisorState::kBlending || state_ == SupervisorState::kTracking ||
           state_ == SupervisorState::kStopping;
  }
  // Feed-forward of the desired sample (and of the next period's sample while moving).
  void FillFeedforward(const TrajectorySample& desired, double sample_time_s, bool moving,
                       LegArray<SupervisorLegSetpoint>& setpoint) const;

  RigParams rig_;
  SupervisorParams params_;
  PoseEstimator estimator_;
  OuterLoop outer_loop_;
  LegEnvelope envelope_;
  PlatformInertialParams inertial_;  // nominal masses for the feed-forward
  LegArray<PotentiometerCalibrationParams> potentiometer_{};
  bool potentiometer_calibrated_ = false;
  LegArray<double> sensed_length_m_{};  // this tick's lengths, potentiometers calibrated
  Vector6d home_;
  std::shared_ptr<const ConstantMotion> home_motion_;  // preallocated for the home command
  OperatorMotion operator_motion_;  // jog, goal, stream (JOGGING, GOAL, STREAMING)
  bool in_operator_mode() const {
    return state_ == SupervisorState::kJogging || state_ == SupervisorState::kGoal ||
           state_ == SupervisorState::kStreaming;
  }

  SupervisorState state_ = SupervisorState::kIdle;
  bool initialized_ = false;
  Vector6d rest_ = Vector6d::Zero();
  Trajectory trajectory_;
  double trajectory_start_time_s_ = 0.0;
  double stop_at_s_ = 0.0;  // trajectory time at which the stop law starts
  double trajectory_time_s_ = 0.0;

  // Length consistency (UpdateConsistency): the leg currently disagreeing, for how many
  // ticks in a row, by how much.
  void UpdateConsistency(const SupervisorInput& input);
  int inconsistent_leg_ = -1;
  int inconsistent_ticks_ = 0;
  double inconsistent_residual_m_ = 0.0;
  double max_consistency_residual_m_ = 0.0;

  FaultReason fault_ = FaultReason::kNone;
  int fault_leg_ = 0;
  std::array<char, 160> fault_detail_{};
  LegArray<SupervisorLegSetpoint> last_setpoint_{};
  TrajectorySample last_desired_;
};

}  // namespace hexa
