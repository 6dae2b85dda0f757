// The supervisor service: every 5 ms (on the IMU sample of tick n, with the six legs'
// sensor samples), estimate the pose (IMU + GQFK), run the outer loop and the safety state
// machine of the core Supervisor, and publish the six leg setpoints and the pose report.
// Operator commands arrive on their topic; faults reported by other nodes put it in HOLD.
//
// Threads: the 5 ms cycle runs on Cyclone's receive thread, in the IMU and leg-sensor
// readers' data callbacks (docs/performance.md). The main thread takes operator commands and
// fault events, counts missing IMU samples in real time, and leaves when the cycle says so.
// One mutex guards the state shared by the two.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "command_answer.hpp"
#include "hexa/comm/comm.hpp"
#include "hexa/core/supervisor.hpp"
#include "hexa/services/command_refusal.hpp"
#include "hexa/services/control_cycle.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/runtime.hpp"
#include "hexa/services/udp_stream.hpp"

namespace hexa::task_space {

// SCHED_FIFO priority in real time unless --rt-priority says otherwise (below the legs').
inline constexpr int kRealtimePriority = 75;

struct SupervisorNodeOptions {
  node::CommonOptions common;
  std::string trajectory = "combined";  // paper motion name or CSV path (for --autostart)
  int periods = 0;
  bool autostart = false;
  bool exit_when_done = false;
  bool outer_loop = true;
  bool least_squares = false;
  bool feedforward = true;  // false: no inverse-dynamics feed-forward (whatever the rig file says)
  double startup_timeout_s = 30.0;
  // --exit-when-done: simulated time to wait in HOLD for an operator reset before leaving with
  // exit_code::kSupervisorHeld. A reset within it resumes: the platform leaves HOLD and, with autostart, the
  // trajectory starts again from where it was held.
  double hold_timeout_s = 30.0;
  // When not empty: one line naming the fault and its cause is written here (atomically) when
  // the platform is held, and the file is removed when a reset leaves HOLD (the launcher shows
  // it on its console).
  std::string hold_report_path;
  // --exit-when-done: when not empty, one line saying how the session's motion ended (the
  // trajectory finished; stopped or shut down by the operator, and when; held) is written here
  // as the service leaves (the launcher's console and report.md say it).
  std::string end_report_path;
  int pose_readers = 0;  // matched PoseReport readers required before RUNNING (the recorder)
  // The external motion stream (docs/operate.md): off unless asked; loopback by default.
  bool stream = false;
  udp::StreamEndpoint stream_endpoint;
  StreamKind stream_kind = StreamKind::kPose;
  std::string washout_path;  // kVehicle: the washout parameter file ("" = the built-in defaults)
  // Fault injection (docs/faults.md): kill this process with SIGKILL at this simulated time
  // (< 0: never).
  double crash_at_s = -1.0;
  // --activation operator: the plant's hardware is activated by the operator's start or home
  // (docs/faults.md, "Hardware lifecycle"); motion waits for the plant's answer.
  bool operator_activation = false;
  double activation_answer_wait_s = 2.0;  // wall time for the plant's answer
};

// hexa_task_space's command line into `options`: -1 to go on, else the exit code (0 --help,
// exit_code::kUsage with the message on stderr).
int ParseOptions(int argc, char** argv, SupervisorNodeOptions& options);

class SupervisorNode {
 public:
  SupervisorNode(const SupervisorNodeOptions& options, const config::SystemConfig& config,
                 std::shared_ptr<spdlog::logger> log);
  int Run();

 private:
  // Start-up: the plant's sensor and IMU writers, every leg's primary setpoint reader and the
  // pose readers asked for, matched.
  bool PeersMatched(std::string& missing);
  void TakeSensors();
  // Takes the IMU samples; true if a newer one came. `repeated`: the newest tick came again
  // (a lockstep re-ask from the plant).
  bool TakeImu(bool& repeated);
  void TakeOperatorCommands();
  // JOG / GOAL: checked (any writer's sample; refused with the reason) and made pending; false
  // when nothing more is to be done with the message (refused, or a jog joining a pending one).
  bool TakeMotionCommand(const hexa_msg_OperatorCommand& c, dds_instance_handle_t writer);
  // JOGGING / GOAL / STREAMING back to IDLE: where the platform rests, and for a jog when it
  // was let go; for a stream its counters.
  void LogModeEnd(SupervisorState before, double time_s);
  // STREAMING: packets arriving again, a timeout (the return to neutral), clamps.
  void LogStreamEvents(SupervisorState before, double time_s);
  void LogStreamCounters(const char* when);
  void TakeFaults();
  // --activation operator: whether the pending command may reach the core at this tick. A
  // start or home waits for the plant's answer to the activation it asked for (refused with
  // the plant's reason); jog, goal and stream are refused while the hardware is inactive.
  bool ActivationAllows();
  void RunCycle();
  // One wake-up of the main thread (operator commands, faults, IMU misses in real time), with
  // the control lock held.
  void MainThreadLook();
  // One supervisor tick: read (faults, samples) -> core Supervisor::Update -> write
  // (setpoints, pose report) -> the service's reaction to the output.
  void RunTick(std::uint64_t tick, double time_s);
  void FillInput(double time_s);
  // Hold (FaultEvent, NodeStatus HOLD, the hold report), the --exit-when-done decisions, the
  // pose estimate's arrival, autostart, the periodic NodeStatus.
  void ReactToOutput(std::uint64_t tick, double time_s);
  void Publish(std::uint64_t tick, double time_s);
  // Lockstep re-ask of tick last_run_tick_: its setpoints again (a leg may have lost them).
  void RepublishSetpoints();
  bool PrepareStart(const std::string& trajectory, int periods);
  // Publishes the answer to an operator command in the NodeStatus detail (command_answer.hpp).
  void AnswerCommand(std::uint32_t sequence, const char* kind, CommandAnswer answer, const char* why);
  // After the core ran a pending operator command: answer it, and the session's part of it
  // (a stop that ends the motion, a reset that resumes).
  void FinishCommand(SupervisorState before, std::uint64_t tick, double time_s);
  void LogFrames(double time_s);  // the frames in use, after a frames command was taken
  // The one-line description of the hold (fault, leg, who reported it and why) to the log and,
  // with --hold-report, to that file.
  void ReportHold(double time_s);
  // --exit-when-done (session_end.cpp): which motions ran (the session's trajectory, or the
  // operator's jog / goal / stream / home, which do not end a session), the exit code and the
  // end line when the session ends, and the line of an operator's shutdown.
  void NoteSessionMotion(double time_s);
  void EndSession(int exit_code, const char* line);
  void EndByShutdown();
  void WriteEndReport() const;
  services::StatusFigures Figures();
  // The running state on NodeStatus: HOLD while held, else RUNNING.
  hexa_msg_NodeState RunningState() const;
  void LogSummary();

  SupervisorNodeOptions options_;
  std::shared_ptr<spdlog::logger> log_;
  Supervisor supervisor_;
  services::Runtime runtime_;
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Topic<hexa_msg_ImuSample> imu_topic_;
  comm::Topic<hexa_msg_LegSetpoint> setpoint_topic_;
  comm::Topic<hexa_msg_PoseReport> pose_topic_;
  comm::Topic<hexa_msg_OperatorCommand> operator_topic_;
  comm::Topic<hexa_msg_FaultEvent> fault_topic_;
  comm::Reader<hexa_msg_LegSensors> sensors_reader_;
  comm::Reader<hexa_msg_ImuSample> imu_reader_;
  comm::Reader<hexa_msg_OperatorCommand> operator_reader_;
  comm::Reader<hexa_msg_FaultEvent> fault_reader_;
  comm::LegRoutedWriter<hexa_msg_LegSetpoint> setpoint_writer_;
  comm::Writer<hexa_msg_PoseReport> pose_writer_;
  node::FaultPublisher faults_;
  node::PeerTracker plant_status_;  // the plant's NodeStatus: its hardware lifecycle
  comm::GuardCondition done_;  // set by the cycle when the service should exit

  // RunCycle on the IMU and leg-sensor readers' data; its mutex guards everything below.
  services::ControlCycle cycle_;
  std::int64_t last_imu_mono_ns_ = 0;  // real time: when the last IMU sample was taken
  // Real time: an IMU sample taken far later than the plant wrote it while this process used
  // almost no CPU meanwhile means the host did not run the process (docs/liveliness.md); the
  // newest such stall is named in the hold line.
  struct HostStall {
    std::uint64_t tick = 0;
    double lag_s = 0.0;   // the sample's age when it was taken
    double wall_s = 0.0;  // since the cycle before it
    double cpu_s = 0.0;   // the process's CPU time in that interval
    std::int64_t at_mono_ns = 0;
  };
  HostStall host_stall_;
  std::int64_t cycle_mono_ns_ = 0;  // the previous real-time cycle: monotonic and process CPU
  std::int64_t cycle_cpu_ns_ = 0;
  void NoteInputLag(std::uint64_t tick);
  LegArray<hexa_msg_LegSensors> sensors_{};
  bool imu_lost_ = false;  // the plant reported FAULT_IMU_LOST: lockstep runs without it
  bool RunLockstepWithoutImu();
  // Lockstep: puts the six legs' samples of tick m (sensor_ring_) into sensors_; false if
  // one is missing.
  bool SensorsOfTick(std::uint64_t m);
  LegArray<bool> sensors_seen_{};
  // Lockstep: each leg's last samples by tick. The IMU of tick m is paired with the legs'
  // samples of tick m even when newer ones came first (a re-asked tick arrives after the
  // plant published the next ones; the plant runs up to 5 ticks ahead of this service).
  static constexpr std::size_t kSensorRing = 16;
  LegArray<std::array<hexa_msg_LegSensors, kSensorRing>> sensor_ring_{};
  LegArray<std::size_t> sensor_ring_count_{};
  const hexa_msg_LegSensors* RingSample(std::size_t leg_index, std::uint64_t tick) const;
  LegArray<std::uint64_t> sensor_tick_at_last_run_{};
  hexa_msg_ImuSample imu_{};
  bool imu_seen_ = false;
  std::uint64_t last_run_tick_ = 0;
  node::CommandRefusals refusals_;  // operator commands from writers not of this session
  std::array<hexa_msg_LegSetpoint, kNumLegs> last_setpoints_{};
  std::uint64_t setpoint_republishes_ = 0;
  bool ran_once_ = false;
  int imu_misses_consecutive_ = 0;
  LegArray<int> leg_misses_consecutive_{};
  LegArray<FaultReason> leg_fault_{};
  FaultReason system_fault_ = FaultReason::kNone;

  // The motion stream's socket (--stream), drained every tick; its decoder's refusals.
  std::unique_ptr<udp::MotionStreamReceiver> stream_receiver_;
  StreamCounters stream_decoder_refusals_;
  StreamState last_stream_state_ = StreamState::kWaiting;
  std::uint64_t stream_clamped_ticks_ = 0;

  SupervisorInput input_;
  SupervisorOutput output_;
  std::optional<StartRequest> pending_start_;
  OperatorCommandKind pending_command_ = OperatorCommandKind::kNone;
  bool pending_from_operator_ = false;  // false: autostart (no one waits for an answer)
  std::uint32_t pending_sequence_ = 0;
  JogRequest pending_jog_;              // the newest jog message (kJog)
  Pose pending_goal_;                   // kGoal
  UserFramesConfig pending_frames_;     // kFrames
  dds_instance_handle_t jog_writer_ = 0;  // the writer of the newest jog message
  bool answer_jog_ = false;             // the pending jog is a writer's first: answer it
  double last_jog_time_s_ = 0.0;        // the tick that applied the last jog message
  bool stopped_by_operator_ = false;    // a `stop` ended the motion before its end
  double stopped_at_trajectory_s_ = 0;  // the trajectory time of that stop
  bool homing_ = false;                 // an operator's `home` runs (not the session's trajectory)
  bool trajectory_started_ = false;     // the session's trajectory was started (start, autostart)
  // The operator motions that ran (kMotion* bits): named in the end line of a shutdown that
  // came before the trajectory started.
  unsigned operator_motions_ = 0;
  char hold_line_[512] = {};  // the newest hold's one-line description (ReportHold)
  char end_line_[600] = {};   // how the session ended (EndSession)
  // The last answer, repeated in the periodic NodeStatus for a while: the status writer keeps
  // only its newest sample, so a periodic status written right after the answer could
  // otherwise replace it before a slow operator's reader has it.
  char last_answer_[160] = {};
  std::uint64_t last_answer_cycle_ = 0;
  // The last FaultEvent of each leg (index leg - 1) and of no leg (index kNumLegs): who
  // reported it and why, for the hold's one-line description.
  struct ReportedFault {
    FaultReason reason = FaultReason::kNone;
    std::array<char, sizeof(hexa_msg_FaultEvent{}.source_node)> source{};
    std::array<char, sizeof(hexa_msg_FaultEvent{}.detail)> detail{};
  };
  std::array<ReportedFault, kNumLegs + 1> reported_{};
  // Start-up: the legs whose primary's setpoint reader has not matched yet (WaitUntilMatched).
  std::string missing_primaries_;
  bool autostart_pending_ = false;
  bool hardware_active_ = false;            // --activation operator: the plant's word
  std::int64_t activation_deadline_ns_ = 0; // the pending start / home's answer due (0: none)
  bool left_idle_ = false;  // the session's trajectory (or a hold) took the platform out of IDLE
  bool was_initialized_ = false;
  int exit_code_ = -1;  // set when the service should exit
  std::uint64_t hold_exit_tick_ = 0;  // --exit-when-done after a fault: leave at this tick
  node::CycleTimeWindow cycle_times_;
  std::uint64_t cycles_ = 0;
};

}  // namespace hexa::task_space
