// The leg controller service: one process per leg. Event-driven on its own leg's sensor
// sample; answers each tick with a valve command computed by the core LegController
// (BS-SMC or PI). Knows nothing of the other legs. Optional hot standby (lower ownership
// strength) and fault injection for safety tests.
//
// Threads: the control cycle runs on Cyclone's receive thread, in the sensor and setpoint
// readers' data callbacks (a sample is answered where it is received, with no hand-over to
// another thread: docs/performance.md). The main thread publishes nothing per tick: it waits
// for shutdown and, in both modes, asserts the writer's MANUAL_BY_TOPIC liveliness while the
// control path is idle - only if it can take the control lock (a hung control cycle holds
// it) and every answer the cycle computed was published (a silent one did not): a crashed,
// hung or silent controller lets its lease lapse, and a hot standby takes over. In lockstep a
// lapse alone does not tell a hung controller from a stopped one, so the main thread also
// says when its cycle is stuck (NodeStatus FAULT; core ControlCycleWatch), and the plant
// judges by that (docs/faults.md).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "hexa/comm/comm.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/services/command_refusal.hpp"
#include "hexa/services/control_cycle.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/runtime.hpp"

namespace hexa::leg_ctrl {

enum class FaultKind { kNone, kCrash, kHang, kSlow, kGarbage, kSilence };
bool ParseFaultKind(const std::string& text, FaultKind& kind);
const char* ToString(FaultKind kind);

struct FaultInjection {
  FaultKind kind = FaultKind::kNone;
  double at_sim_time_s = 0.0;  // the fault starts at this simulated time
  double slow_extra_s = 0.005; // kSlow: added to every cycle
};

// Lockstep: sensor samples not answered yet are queued in tick order (the plant does not
// wait for a hot standby, which may lag it: on a loaded machine by a hundred ticks and more);
// the readers keep this many samples per leg: 1 s of ticks.
inline constexpr std::size_t kLockstepQueue = 1000;
// The last setpoints received: lockstep needs the one issued at 5 floor((n - 1) / 5), which a
// lagging standby looks for after newer ones arrived. 256 setpoints = 1.28 s: more than the
// queue holds.
inline constexpr std::size_t kSetpointRing = 256;

// SCHED_FIFO priority in real time unless --rt-priority says otherwise: the highest of the
// loop's processes; a leg has the tightest deadline (its 10 ms liveliness lease) and the
// shortest work (docs/measurements/deployment_lapses.md, "Where the lapses' milliseconds go").
inline constexpr int kRealtimePriority = 80;

struct LegNodeOptions {
  node::CommonOptions common;
  int leg = 1;                 // 1..6
  LegControllerKind controller = LegControllerKind::kBsSmc;
  ExcitationParams excitation;  // kExcitation: the leg's identification window
  bool standby = false;
  bool coupled_legs = false;  // --coupled-legs: leg_controller.coupled.enabled
  FaultInjection fault;
  double startup_timeout_s = 30.0;
  // Matched readers of the valve-command writer required before RUNNING (the plant, plus
  // the recorder when one records the session: a reader that matches late misses ticks).
  int valve_readers = 1;
};

// "leg3", "leg3_standby": the node's name on NodeStatus and in the log.
std::string NodeName(const LegNodeOptions& options);
// hexa_leg_ctrl's command line into `options`: -1 to go on, else the exit code (0 --help,
// exit_code::kUsage with the message on stderr).
int ParseOptions(int argc, char** argv, LegNodeOptions& options);

class LegNode {
 public:
  LegNode(const LegNodeOptions& options, const config::SystemConfig& config,
          std::shared_ptr<spdlog::logger> log);
  int Run();

 private:
  // Start-up: the plant's sensor writer and valve readers (and the recorder's), and in
  // lockstep the supervisor's setpoint writer, matched.
  bool PeersMatched(std::string& missing);
  void RunCycle();
  void TakeSetpoints();
  void TakeSensorsLockstep();
  // Lockstep: a re-ask of a tick this node cannot answer yet, logged with the setpoint reader's
  // state (which setpoint it waits for, writers, lost or refused samples).
  void LogWaitingForSetpoint(std::uint64_t tick);
  void TakeSensorsRealtime();
  void ResendLastAnswer();
  void AnswerAndReport(const hexa_msg_LegSensors& sensors);
  const IssuedSetpoint* SetpointFor(std::uint64_t tick) const;
  bool CanAnswer(std::uint64_t tick) const;
  void Answer(const hexa_msg_LegSensors& sensors);
  bool InjectFault(double sim_time_s);
  services::StatusFigures Figures();
  // Lockstep: the supervisor's process is gone (its setpoint writer left without disposing
  // its setpoints, or the launcher's process id of it ended): ticks are answered with the
  // newest setpoint held, which goes stale. A lapsed lease alone is a supervisor that does not
  // run now (stopped, or a loaded machine): the legs wait for it. Real time: never (the legs
  // use the newest setpoint anyway). Evaluated by the main thread (SupervisorGoneNow), read
  // by the cycle.
  bool SupervisorLost() const { return supervisor_lost_; }
  bool SupervisorGoneNow() const;
  // Lockstep, main thread, with the control lock: once the supervisor is gone no setpoint
  // triggers the cycle, so this thread runs it.
  void RunCycleWithoutSupervisor();
  // Lockstep, main thread: the control cycle stuck (hang / silence) is said on NodeStatus.
  void WatchControlCycle();
  // One FaultEvent per episode of held control (bad input, stale setpoint), repeated at the
  // status rate while it lasts (docs/faults.md).
  void ReportControlFault(const hexa_msg_LegSensors& sensors);
  void AssertLivelinessIfIdle(std::int64_t idle_ns);
  // One wake-up of the main thread: the watchdog, the stuck-cycle watch, the supervisor's
  // loss, the idle liveliness. False when the wait set failed.
  bool MainThreadLook(std::int64_t idle_ns);
  void LogSummary();

  LegNodeOptions options_;
  std::shared_ptr<spdlog::logger> log_;
  services::Runtime runtime_;
  const std::string& name_ = runtime_.name();
  LegController controller_;
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Topic<hexa_msg_LegSetpoint> setpoint_topic_;
  comm::Topic<hexa_msg_ValveCommand> valve_topic_;
  comm::Reader<hexa_msg_LegSensors> sensors_reader_;
  comm::Reader<hexa_msg_LegSetpoint> setpoint_reader_;
  comm::Writer<hexa_msg_ValveCommand> valve_writer_;
  node::StatusPublisher stuck_status_;  // the main thread's: the cycle stuck (or no longer)
  node::FaultPublisher faults_;

  LockstepSchedule schedule_;
  // RunCycle on the sensor and setpoint readers' data; its mutex guards the control state
  // below (receive thread(s) and the main thread).
  services::ControlCycle cycle_;
  std::atomic<std::int64_t> last_write_ns_{0};
  ControlCycleWatch cycle_watch_;                 // main thread only
  int watched_tid_ = 0;  // the cycle's thread at the previous check, and its schedstat then
  std::uint64_t watched_run_ns_ = 0, watched_wait_ns_ = 0;
  ControlCycleWatch::Cause stuck_reported_ = ControlCycleWatch::Cause::kNone;
  SetpointRing<IssuedSetpoint, kSetpointRing> setpoints_;
  bool has_pending_ = false;         // real time: the newest unanswered sample
  hexa_msg_LegSensors pending_{};
  services::SampleQueue<hexa_msg_LegSensors, kLockstepQueue> queue_;  // lockstep
  std::uint64_t queue_overflows_ = 0;
  std::uint64_t ticks_missed_ = 0;  // lockstep: ticks that never reached this node
  bool answered_any_ = false;
  bool unwritten_answer_ = false;    // an answer was computed and not published (yet)
  bool supervisor_seen_ = false;     // an authenticated setpoint of it has arrived
  bool supervisor_lost_ = false;     // SupervisorLost()
  bool supervisor_finished_ = false;  // it disposed its setpoints: the session is ending
  // Held-control fault episode (ReportControlFault).
  hexa_msg_FaultReason control_fault_ = hexa_msg_FAULT_NONE;
  std::uint64_t control_fault_ticks_ = 0;  // consecutive held ticks of the current cause
  std::uint64_t control_ok_ticks_ = 0;     // consecutive good ticks (ends the episode)
  bool control_fault_reported_ = false;
  hexa_msg_ValveCommand last_command_{};
  LegControllerInput input_;
  LegControllerOutput output_;
  node::CycleTimeWindow cycle_times_;
  std::uint64_t cycles_ = 0;
  std::uint64_t resent_ = 0;
  bool fault_active_ = false;
  hexa_msg_ControllerKind base_controller_ = hexa_msg_CONTROLLER_BSSMC;
  // Setpoints from writers not of this session are refused (docs/faults.md); the writers
  // whose setpoints were authenticated (a dispose counts only from one of them).
  node::CommandRefusals refusals_;
  comm::TrustedWriters trusted_setpoint_writers_;
  std::uint64_t waiting_logged_tick_ = 0;  // lockstep: the re-asked tick last logged as waiting
};

}  // namespace hexa::leg_ctrl
