// The plant service: the simulated rig behind DDS, and the clock master. Publishes every
// leg's sensors each 1 ms tick, the IMU every 5 ms, ground truth each tick; applies each
// leg's valve command after command hygiene (missing, stale, NaN or out-of-range -> valve
// at null, FaultEvent). Lockstep or real time (docs/architecture.md).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/core/command_hygiene.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/services/node.hpp"

namespace hexa::plant_sim {

struct PlantNodeOptions {
  node::CommonOptions common;
  std::string profile;             // disturbance profile name in the rig file
  std::uint64_t seed = 1;
  int expected_legs = 6;           // leg controllers that must answer every tick
  bool expect_supervisor = true;   // lockstep: wait for its setpoints every 5th tick
  bool expect_recorder = false;    // wait for the recorder before tick 0
  double duration_s = 0.0;         // stop after this simulated time (0 = until stopped)
  double startup_timeout_s = 30.0; // peers must be ready within this
  std::uint64_t realtime_stale_ticks = 15;  // real time: command tolerance (main.cpp)
  double resend_after_s = 0.05;    // lockstep: republish sensors of a silent leg after this
};

class PlantNode {
 public:
  PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
            std::shared_ptr<spdlog::logger> log);
  // Runs until shutdown (exit 0), a peer timeout (3), a non-finite state (4), or the
  // configured duration (0).
  int Run();

 private:
  bool WaitForPeers();
  void PublishSensors(bool with_imu_and_truth, int only_leg = 0);
  void TakeCommands();
  void TakeSetpoints();
  bool LockstepCollect();
  void ApplyAndStep(std::uint64_t stale_tolerance);
  void PublishStatus(hexa_msg_NodeState state, const char* detail);
  void LogLastGoodState() const;

  PlantNodeOptions options_;
  config::SystemConfig config_;
  std::shared_ptr<spdlog::logger> log_;
  PlatformPlant plant_;
  CommandHygieneParams hygiene_;

  comm::Participant participant_;
  comm::ShutdownGuard shutdown_;
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Topic<hexa_msg_ImuSample> imu_topic_;
  comm::Topic<hexa_msg_GroundTruth> truth_topic_;
  comm::Topic<hexa_msg_ValveCommand> valve_topic_;
  comm::Topic<hexa_msg_LegSetpoint> setpoint_topic_;
  comm::Writer<hexa_msg_LegSensors> sensors_writer_;
  comm::Writer<hexa_msg_ImuSample> imu_writer_;
  comm::Writer<hexa_msg_GroundTruth> truth_writer_;
  comm::Reader<hexa_msg_ValveCommand> valve_reader_;
  comm::Reader<hexa_msg_LegSetpoint> setpoint_reader_;
  node::StatusPublisher status_;
  node::FaultPublisher faults_;
  node::PeerTracker peers_;
  comm::WaitSet waitset_;

  std::uint64_t tick_ = 0;
  LegArray<LatestCommand> latest_{};
  LegArray<std::uint64_t> setpoint_tick_{};
  LegArray<bool> setpoint_seen_{};
  LegArray<CommandCheck> last_check_{};
  LegArray<std::uint32_t> faults_per_leg_{};
  node::CycleTimeWindow cycle_times_;
  std::uint32_t overruns_ = 0;
  std::uint32_t resends_ = 0;
};

}  // namespace hexa::plant_sim
