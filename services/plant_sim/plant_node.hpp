// The plant service: the simulated rig behind DDS, and the clock master. Publishes every
// leg's sensors each 1 ms tick, the IMU every 5 ms, ground truth each tick; applies each
// leg's valve command after the command arbitration (core/command_arbitration.hpp: missing,
// stale, NaN or out-of-range -> valve at null, FaultEvent; dead legs, the interlock, the
// host-overload rule). Lockstep or real time (docs/architecture.md).
//
// Parts: the command arbitration (core, pure), the lockstep clock's decisions (core
// lockstep_clock.hpp) and the real-time clock (realtime_clock.hpp), the rig behind the device
// seam (device/device.hpp: SimDevice, the simulation, or RemoteBoardDevice, an I/O board over
// UDP) and the plant's link to it (device_link.hpp, without DDS), the valve writers' table
// (leg_writer_table.hpp), the figures of the run (run_figures.hpp). One tick is
// read -> arbitrate -> step the device -> write (PlantNode::CompleteTick and PublishTick).
// Files: plant_node.cpp (the loops), plant_commands.cpp (reception, dead legs, the wording of
// fault events), plant_outputs.cpp (publishing), plant_device.cpp (the device's events),
// plant_lifecycle.cpp (start-up, status and the end-of-run report on the service runtime,
// services::Runtime), plant_options.cpp (the command line).
//
// Threading rule. Every member below `cycle_` is touched only with the cycle's mutex held, by
// exactly one thread at a time; the members above it are set in the constructor and only read
// after (DDS entities are thread-safe).
//   Lockstep: the tick advances on Cyclone's receive thread, in the ValveCommand readers'
//   data callback (services::ControlCycle runs OnCommands): when the last awaited leg has
//   answered tick n the plant steps and publishes tick n + 1 at once, with no hand-over to
//   another thread (docs/performance.md: a hand-over costs a wake-up per tick). The main thread only watches
//   for silence (re-ask, dead legs, timeout), waits for the recorder's acknowledgements and
//   for shutdown, under the same lock between its waits; it never blocks while holding it.
//   Real time: the main thread alone runs the loop; no callback is installed (the lock is held
//   for form, uncontended), and commands are taken at each tick.
//   The FaultEvent reader is polled, never a callback: this process writes FaultEvents with
//   the lock held, and Cyclone may deliver a local sample inside that write.
//
// Dead legs (docs/faults.md): every leg controller's ValveCommand writer carries its leg in
// USER_DATA and asserts MANUAL_BY_TOPIC liveliness from its control loop. Real time: a leg
// with no live writer (crashed, hung or silent; or gone) has its valve held at null and is
// reported with the cause. Lockstep judges facts, not the wall clock: a leg whose controller
// process ended (--peer-pid, same host), whose writers are gone, or whose controller reports
// its cycle stuck with its lease lapsed, is dead; a leg that is only slow, stopped or not
// scheduled is waited for. A dead leg is no longer awaited, and lockstep keeps ticking so
// that the supervisor can hold.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/core/command_arbitration.hpp"
#include "hexa/core/coupled_legs.hpp"
#include "hexa/core/hardware_lifecycle.hpp"
#include "hexa/core/lockstep_clock.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/core/plant_faults.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/device/remote_board_device.hpp"
#include "hexa/device/sim_device.hpp"
#include "hexa/services/command_refusal.hpp"
#include "hexa/services/control_cycle.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/peer_processes.hpp"
#include "hexa/services/runtime.hpp"
#include "device_link.hpp"
#include "leg_writer_table.hpp"
#include "realtime_clock.hpp"
#include "run_figures.hpp"

namespace hexa::plant_sim {

inline constexpr double kTickS = 0.001;  // one tick of the loop

// The rig behind the device seam: the simulation in this process, or a remote I/O board over
// UDP (docs/board_protocol.md; hexa_board_emulator, or real hardware).
enum class DeviceKind { kSim, kBoard };

struct BoardLinkOptions {
  std::string host;           // dotted IPv4 address of the board
  std::uint16_t port = 0;
  // Lockstep: a command frame must be answered by a datagram within this (the emulator in
  // step mode); bring-up: the board must answer within this. The board has failed when no
  // intact frame came for `lost_after_ticks` ticks in a row (lost or refused frames).
  double answer_timeout_s = 2.0;
  std::uint64_t lost_after_ticks = 20;
};

// How the hardware lifecycle's activation is asked for (hexa/core/hardware_lifecycle.hpp).
enum class HardwareActivation {
  kAuto,      // at the first tick (and at an operator reset while inactive)
  kOperator,  // by an operator start or home only
};

struct PlantNodeOptions {
  node::CommonOptions common;
  std::string profile;             // disturbance profile name in the rig file
  std::uint64_t seed = 1;
  int expected_legs = 6;           // leg controllers that must answer every tick (1..N)
  bool expect_supervisor = true;   // the supervisor must be RUNNING before tick 0
  bool expect_recorder = false;    // wait for the recorder before tick 0
  bool expect_standbys = false;    // wait for a hot standby per leg before tick 0
  double duration_s = 0.0;         // stop after this simulated time (0 = until stopped)
  double startup_timeout_s = 30.0; // peers must be ready within this
  std::uint64_t realtime_stale_ticks = 15;  // real time: command tolerance (main.cpp)
  // Real time: ticks a leg's first command may take (the loop starting up) before it is
  // missing; the stale check is armed by the first command.
  std::uint64_t startup_grace_ticks = 500;
  // Lockstep fault injection (tests): the supervisor's inputs of this tick are not sent
  // (as if lost); -1: none.
  std::int64_t lose_supervisor_inputs_tick = -1;
  double resend_after_s = 0.05;    // lockstep: republish sensors of a silent leg after this
  // Lockstep with a recorder: every recorder_sync_ticks the plant's main thread starts
  // waiting, beside the loop, until every reliable reader (the recorder's too) has
  // acknowledged what the plant wrote so far. The loop goes on, and stops only when such a
  // wait, begun recorder_sync_window_ticks ago, has not ended: a fast loop never runs further
  // ahead of a slow recorder than that. The writers keep 3 s = 3000 ticks of history
  // (comm WriterHistoryDepth); samples older than that could no longer be repaired, so the
  // window plus one sync period stays within half of it (PlantNode checks). 0 = never.
  std::uint64_t recorder_sync_ticks = 100;
  std::uint64_t recorder_sync_window_ticks = 1200;
  // A loop that has stood still this long for a sync gives it up and runs on without blocking
  // until a wait succeeds again: a reader that never acknowledges (its process killed or hung
  // and not yet dropped by discovery, 10 s) must not stop the control loop (docs/faults.md).
  double recorder_sync_give_up_s = 1.0;
  // Start-up: after this long waiting, say every second which peer is missing and why.
  double startup_report_after_s = 3.0;
  ComputeBudgetParams compute_budget;  // leg controllers' compute time per cycle
  PlantFaultParams plant_faults;       // injected rig faults (--fault)
  std::string summary_path;        // write the run's figures here as JSON at exit ("" = no)
  std::string truth_out_path;      // --truth-out: the plant's true parameters ("" = no)
  bool tracker = false;            // publish the external pose instrument (calibration)
  FreeFallBenchParams free_fall;   // --bench free-fall: the Appendix B bench, not the platform
  DeviceKind device = DeviceKind::kSim;
  BoardLinkOptions board;          // --device board
  HardwareActivation activation = HardwareActivation::kAuto;
};

// SCHED_FIFO priority in real time, below the legs (80): a tick of the simulation can cost a
// millisecond (stiff substeps), and the plant above the legs on their CPU made their valve writers
// lapse (docs/measurements/deployment_lapses.md, "Where the lapses' milliseconds go"); late, the
// plant only slips.
inline constexpr int kRealtimePriority = 70;

// Reads hexa_plant_sim's command line into `options`: -1 to run, else the exit code (--help:
// kOk; a bad value: kUsage, the error printed).
int ParseOptions(int argc, char** argv, PlantNodeOptions& options);

class PlantNode {
 public:
  PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
            std::shared_ptr<spdlog::logger> log);
  // Runs until shutdown (exit_code::kOk), peers not ready or a lockstep stall
  // (kPlantLockstepStall), a non-finite state (kPlantNonFinite), or the configured duration.
  int Run();
  // The simulated rig (its true parameters, for evaluation); nullptr on a remote board.
  const PlatformPlant* simulation() const { return device_.simulation(); }

 private:
  // plant_lifecycle.cpp: start-up, status, the report at the end.
  services::PeerWait StartupWait();
  // Whether every awaited reader and writer is matched (DDS alone; StartupWait adds the
  // peers' NodeStatus RUNNING); `counts` says what is matched of what is awaited.
  bool PeersMatched(std::string& counts);
  std::string DescribeMissing(const std::vector<std::string>& missing) const;
  services::StatusFigures Figures();
  bool SyncGiveUpDue(std::int64_t blocked_ns) const;
  void LogStart() const;
  void LogEnd() const;
  void LogLastGoodState() const;
  void LogCommandAges() const;
  void WriteSummary(int exit_code) const;

  // plant_node.cpp: the loops and the tick.
  int RunLockstep(std::uint64_t last_tick);
  int RunRealtime(std::uint64_t last_tick);
  void OnCommands();  // the cycle (lockstep: on the receive thread, ValveCommand data)
  void AdvanceIfComplete();
  void StartTick(std::int64_t now_ns);  // publish tick_ and await its answers
  // Arbitrate, step the device, end the tick; false when the device failed (non-finite).
  bool CompleteTick(const ArbitrationInput& in);
  void WatchSilence(dds_duration_t& wait);  // lockstep main thread, under the lock
  void ServeRecorderSync(bool acked);       // lockstep main thread: an acknowledgement wait

  // plant_device.cpp: the device's bring-up and one exchange per tick through link_ (write the
  // valves, read the next sample; the board's e-stop and link judged).
  void BringUpDevice();
  device::DeviceStatus ExchangeWithDevice(const LegArray<double>& valve_v);
  void JudgeDeviceSafety();  // after the exchange, for the sample of the new tick_
  void TakeOperatorCommands();  // estop: latch the device; reset: ask the device to re-arm
  void LatchOperatorEstop(std::uint32_t sequence);  // once per command, whichever path brings it
  void LogDeviceEnd() const;
  void Report(const DeviceEvents& events);  // FaultEvents and log lines

  // plant_hardware.cpp: the hardware lifecycle (core/hardware_lifecycle.hpp) for this tick:
  // reads the device's sample and safety, the legs' controllers and the activation asked for,
  // decides, answers the operator on NodeStatus and says whether the commands apply.
  void UpdateHardware();
  // An operator start / home (operator activation) or reset (automatic activation) asks for
  // activation at this tick.
  void AskActivation(const hexa_msg_OperatorCommand& c);
  // The NodeStatus detail: the newest activation answer for a while, else the mode and the
  // hardware state (hexa/services/command_answer.hpp says how it reads).
  const char* StatusDetail();

  // plant_outputs.cpp: sensors of tick_ (all legs, or `only_leg` alone: a re-ask), the IMU
  // (every 5th tick), ground truth and the tracker. Batched: each reader gets one datagram.
  void PublishTick(int only_leg = 0);
  void ReaskSupervisor();  // lockstep: re-publishes the supervisor's inputs of s(n)

  // plant_commands.cpp: reception and the arbitration's events.
  void TakeCommands(bool feed_barrier);
  void RejectCommand(int reader_leg, const hexa_msg_ValveCommand& c, const dds_sample_info_t& info);
  void TakeFaultEvents();  // the supervisor's sensor-consistency faults: the interlock
  LegArray<LegWriterCounts> WriterCounts() const;
  SilentLegFacts LegFacts(int leg);
  void JudgeSilentLegs(std::int64_t now_ns);  // lockstep
  void ReportGoneWriters();                   // lockstep
  // Publishes (with a reason) and logs each event, worded for the operator.
  void Report(const ArbitrationEvents& events);

  PlantNodeOptions options_;
  config::SystemConfig config_;
  std::shared_ptr<spdlog::logger> log_;
  std::unique_ptr<device::Device> device_owner_;
  device::Device& device_;              // the rig the loop reads and writes
  device::RemoteBoardDevice* board_;    // the same device when it is a remote board, else null
  ArbitrationParams arbitration_params_;
  LockstepSchedule schedule_;

  // Participant (write batching on), shutdown guard, wait set, lifecycle and NodeStatus,
  // --peer-pid processes.
  services::Runtime runtime_;
  comm::GuardCondition wake_;  // set by the receive thread: the run ended, or a recorder sync
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Topic<hexa_msg_ImuSample> imu_topic_;
  comm::Topic<hexa_msg_GroundTruth> truth_topic_;
  comm::Topic<hexa_msg_ValveCommand> valve_topic_;
  comm::LegRoutedWriter<hexa_msg_LegSensors> sensors_writer_;
  comm::Writer<hexa_msg_ImuSample> imu_writer_;
  comm::Writer<hexa_msg_GroundTruth> truth_writer_;
  comm::Topic<hexa_msg_TrackerPose> tracker_topic_;
  comm::Writer<hexa_msg_TrackerPose> tracker_writer_;
  // One reader per leg partition: leg N's commands only from leg N's writers (comm/leg_readers.hpp).
  comm::LegReaders<hexa_msg_ValveCommand> valve_readers_;
  node::FaultPublisher faults_;
  node::PeerTracker peers_;
  comm::Topic<hexa_msg_FaultEvent> fault_topic_;
  comm::Reader<hexa_msg_FaultEvent> fault_reader_;  // polled: never a callback
  // The operator's e-stop and reset, polled each tick (the supervisor answers them).
  comm::Topic<hexa_msg_OperatorCommand> operator_topic_;
  comm::Reader<hexa_msg_OperatorCommand> operator_reader_;
  LegArray<std::string> leg_name_{}, standby_name_{};  // "leg3", "leg3_standby"

  services::ControlCycle cycle_;  // its mutex guards everything below (the threading rule)
  std::uint64_t tick_ = 0;
  int exit_code_ = -1;  // set when the run ends (>= 0)
  CommandArbitration arbitration_;
  ArbitrationOutput arbitration_out_;
  // The legs' feedback parts relayed with the next tick's samples (coupled leg feedback,
  // hexa/core/coupled_legs.hpp): the commands' parts as arbitrated, judged after each tick.
  FeedbackRelay relay_;
  RelayedFeedback relayed_;
  ArbitrationEvents events_;  // the events of a call between ticks (cleared before each)
  LockstepClock lockstep_;
  RealtimeClock realtime_;
  std::uint64_t slip_recent_until_tick_ = 0;  // real time: stale tolerance after a slip
  LegWriterTable writers_;
  node::CommandRefusals refusals_;
  LegArray<std::uint64_t> rejected_per_leg_{};  // samples of another leg's key, per partition
  // Lockstep: the supervisor's inputs of the newest supervisor tick (six legs' sensors and
  // the IMU), re-published with a re-ask: a leg that cannot answer may lack that tick's
  // setpoint because the supervisor lost its inputs, or the leg lost the setpoint.
  std::array<hexa_msg_LegSensors, kNumLegs> supervisor_sensors_{};
  hexa_msg_ImuSample supervisor_imu_{};
  bool supervisor_inputs_valid_ = false;
  std::uint64_t supervisor_reasks_ = 0;
  bool supervisor_inputs_lost_ = false;  // --lose-supervisor-inputs done
  bool imu_lost_reported_ = false;
  hexa_msg_GroundTruth truth_sample_{};
  // Figures of the run.
  RunFigures figures_;  // command ages, tick durations, the loop's wall time, re-sends
  node::CycleTimeWindow cycle_times_;
  std::int64_t tick_started_ns_ = 0;
  // The device: the exchange, the control round trip, the e-stop and the board's link
  // (device_link.hpp), and the events of its newest call.
  DeviceLink link_;
  DeviceEvents device_events_;
  // The hardware lifecycle (plant_hardware.cpp) and its newest decision; the activation asked
  // for this tick (0: the automatic one, else the operator command's sequence).
  HardwareLifecycle lifecycle_;
  HardwareLifecycleOutput hardware_;
  bool activation_asked_ = false;
  std::uint32_t activation_sequence_ = 0;
  const char* activation_kind_ = "";
  bool auto_activation_done_ = false;
  char hardware_answer_[160] = {};  // repeated on NodeStatus for a while (a keep-last topic)
  std::uint64_t hardware_answer_tick_ = 0;
  char status_detail_[160] = {};
};

}  // namespace hexa::plant_sim
