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
#include <mutex>
#include <optional>
#include <string>

#include "hexa/comm/comm.hpp"
#include "hexa/core/supervisor.hpp"
#include "hexa/services/command_refusal.hpp"
#include "hexa/services/node.hpp"

namespace hexa::task_space {

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
  int pose_readers = 0;  // matched PoseReport readers required before RUNNING (the recorder)
  // Fault injection (docs/faults.md): kill this process with SIGKILL at this simulated time
  // (< 0: never).
  double crash_at_s = -1.0;
};

class SupervisorNode {
 public:
  SupervisorNode(const SupervisorNodeOptions& options, const config::SystemConfig& config,
                 std::shared_ptr<spdlog::logger> log);
  int Run();

 private:
  bool WaitUntilMatched();
  void TakeSensors();
  // Takes the IMU samples; true if a newer one came. `repeated`: the newest tick came again
  // (a lockstep re-ask from the plant).
  bool TakeImu(bool& repeated);
  void TakeOperatorCommands();
  void TakeFaults();
  static void OnData(void* self);
  void RunCycle();
  void RunTick(std::uint64_t tick, double time_s);
  void Publish(std::uint64_t tick, double time_s);
  // Lockstep re-ask of tick last_run_tick_: its setpoints again (a leg may have lost them).
  void RepublishSetpoints();
  bool PrepareStart(const std::string& trajectory, int periods);
  void PublishStatus(hexa_msg_NodeState state, const char* detail);

  SupervisorNodeOptions options_;
  std::shared_ptr<spdlog::logger> log_;
  Supervisor supervisor_;
  comm::Participant participant_;
  comm::ShutdownGuard shutdown_;
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
  node::StatusPublisher status_;
  node::FaultPublisher faults_;
  comm::GuardCondition done_;  // set by the cycle when the service should exit
  comm::WaitSet waitset_;

  std::mutex mutex_;  // everything below
  std::int64_t last_imu_mono_ns_ = 0;  // real time: when the last IMU sample was taken
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

  SupervisorInput input_;
  SupervisorOutput output_;
  std::optional<StartRequest> pending_start_;
  OperatorCommandKind pending_command_ = OperatorCommandKind::kNone;
  // Start-up: the legs whose primary's setpoint reader has not matched yet (WaitUntilMatched).
  std::string missing_primaries_;
  bool autostart_pending_ = false;
  bool left_idle_ = false;
  bool was_initialized_ = false;
  int exit_code_ = -1;  // set when the service should exit
  std::uint64_t hold_exit_tick_ = 0;  // --exit-when-done after a fault: leave at this tick
  node::CycleTimeWindow cycle_times_;
  std::uint64_t cycles_ = 0;
};

}  // namespace hexa::task_space
