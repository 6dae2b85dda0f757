// The plant service: the simulated rig behind DDS, and the clock master. Publishes every
// leg's sensors each 1 ms tick, the IMU every 5 ms, ground truth each tick; applies each
// leg's valve command after command hygiene (missing, stale, NaN or out-of-range -> valve
// at null, FaultEvent). Lockstep or real time (docs/architecture.md).
//
// Threads. Lockstep: the tick advances on Cyclone's receive thread, in the ValveCommand
// reader's data callback: when the last awaited leg has answered tick n the plant steps and
// publishes tick n + 1 at once, with no hand-over to another thread (docs/performance.md).
// The main thread only watches for silence (re-ask, dead legs, timeout) and shutdown. Real
// time: the main thread ticks on the clock and takes the newest commands at each tick; no
// thread wakes on their arrival. One mutex guards the loop state in both.
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
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/core/command_hygiene.hpp"
#include "hexa/core/command_source.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/core/schedule_slips.hpp"
#include "hexa/core/plant_faults.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/services/command_refusal.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/peer_processes.hpp"

namespace hexa::plant_sim {

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
  bool tracker = false;            // publish the external pose instrument (calibration)
  FreeFallBenchParams free_fall;   // --bench free-fall: the Appendix B bench, not the platform
};

// Age of the command the plant applied at a tick, in ticks (tick - answered tick; 0 = the
// command answered the sensors of this tick), per leg. Real time: a command older than the
// sensor sample just before it (age >= 1) arrived too late for its tick: a late tick.
struct CommandAgeHistogram {
  static constexpr int kBins = 6;  // 0, 1, 2, 3-7, 8-15, >= 16
  std::array<std::uint64_t, kBins> bins{};
  std::uint64_t none = 0;          // no command yet
  void Add(std::int64_t age_ticks);
  std::uint64_t late() const;      // age >= 1
  std::uint64_t total() const;
};

// Distribution of a duration (a lockstep tick's wall time; the real-time wake-up lateness)
// over a whole run, in 10 us bins up to 100 ms: allocation-free after construction.
class DurationHistogram {
 public:
  static constexpr std::int64_t kBinNs = 10'000;
  static constexpr std::size_t kBins = 10'000;
  void Add(std::int64_t duration_ns);
  std::uint64_t count() const { return count_; }
  // Upper edge of the bin holding the q-quantile (0 < q <= 1), in seconds; 0 when empty.
  double Quantile_s(double q) const;
  double max_s() const { return static_cast<double>(max_ns_) * 1e-9; }
  double mean_s() const { return count_ == 0 ? 0.0 : sum_s_ / static_cast<double>(count_); }

 private:
  std::array<std::uint32_t, kBins + 1> bins_{};  // the last one: beyond 100 ms
  std::uint64_t count_ = 0;
  std::int64_t max_ns_ = 0;
  double sum_s_ = 0.0;
};

// The leg controllers' ValveCommand writers as the plant's six per-leg readers see them
// (one reader per leg partition, comm/leg_readers.hpp): which leg each writer drives (its
// USER_DATA, "leg=N standby=S") and whether it is alive (each reader's liveliness slots,
// comm/status.hpp). Only a writer in leg N's partition that names leg N counts for leg N; a
// writer elsewhere or naming another leg counts for none. Refresh() resolves writers seen for
// the first time (allocates, but only when a writer appears); Counts() reads atomics only.
// A writer whose USER_DATA cannot be read yet (discovery lags the liveliness callback that
// claimed its slot) is asked again on later refreshes; with `may_give_up` (the running loops)
// it counts as gone after 100 of them, without (the start-up wait, where discovery on a loaded
// machine can lag by seconds and no real-time loop pays for the retries) it is asked until the
// wait ends.
class LegWriterTable {
 public:
  void Refresh(const comm::LegReaders<hexa_msg_ValveCommand>& readers, bool may_give_up = true);
  LegWriterCounts Counts(int leg) const;
  // "leg1: 1 alive (primary) ..." for the log, and the slots not resolved to a leg (yet) or
  // given up on. Allocates.
  std::string Describe() const;

 private:
  static constexpr std::size_t kSlots = comm::StatusCounters::kMaxWriters;
  struct PerReader {
    const comm::StatusCounters* counters = nullptr;
    std::array<std::int8_t, kSlots> leg{};          // 0 unresolved, -1 not this leg's writer, 1..6
    std::array<bool, kSlots> standby{};
    std::array<std::uint8_t, kSlots> unresolved{};  // refreshes that could not resolve the slot
  };
  void RefreshOne(const comm::Reader<hexa_msg_ValveCommand>& reader, int reader_leg, bool may_give_up);
  LegArray<PerReader> readers_{};
};

class PlantNode {
 public:
  PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
            std::shared_ptr<spdlog::logger> log);
  // Runs until shutdown (exit 0), a peer timeout (3), a non-finite state (4), or the
  // configured duration (0).
  int Run();
  const PlatformPlant& plant() const { return plant_; }  // e.g. for its true parameters

 private:
  bool WaitForPeers();
  // Start-up: the first expected peer whose process the launcher named and that ended
  // ("" if none); and each missing peer with its process state, for the log.
  std::string EndedPeer(const std::vector<std::string>& expected) const;
  std::string DescribeMissing(const std::vector<std::string>& missing) const;
  // Lockstep: what leg `leg`'s controllers show (writers, processes ended or stuck).
  SilentLegFacts LegFacts(int leg);
  // Lockstep, recorder sync: may a sync that has stood still `blocked_ns` be given up? Never
  // while the readers' processes (supervisor, recorder) exist (a stopped recorder is waited
  // for); after recorder_sync_give_up_s when one ended or they are not known (another host).
  bool SyncGiveUpDue(std::int64_t blocked_ns) const;
  int RunLockstep(std::uint64_t last_tick);
  int RunRealtime(std::uint64_t last_tick);
  // Receive thread (lockstep): takes the commands and, when the tick is complete, advances.
  static void OnValveData(void* self);
  void AdvanceIfComplete();
  void StartTick(std::int64_t now_ns);  // publish tick_ and await its answers
  // Publishes the sensors of tick_ (all legs, or `only_leg` to that leg alone), and with all legs the IMU
  // (every 5th tick) and ground truth. Batched: each reader gets one datagram.
  void PublishTick(int only_leg = 0);
  void ReaskSupervisor();  // lockstep: re-publishes the supervisor's inputs of s(n)
  void TakeCommands(bool feed_barrier);
  // A sample of another leg's key from leg `reader_leg`'s partition: refused, counted, logged.
  void RejectCommand(int reader_leg, const hexa_msg_ValveCommand& c, const dds_sample_info_t& info);
  // Command hygiene and one plant step; false when the plant state became non-finite.
  bool ApplyAndStep(std::uint64_t stale_tolerance);
  void EndTick();
  // Dead legs: lockstep (main thread) judges the legs the barrier still awaits; real time
  // (every tick) holds the legs without a live writer. Both publish the cause once.
  void JudgeSilentLegs(std::int64_t now_ns);
  // Ticks since leg i's newest answered tick (tick_ - answered); -1 before its first command.
  std::int64_t CommandAge(std::size_t i) const;
  // Lockstep main thread, under the lock: faults to take, gone writers, dead legs, re-asks,
  // the overall timeout; shortens `wait` to the next check.
  void WatchSilence(dds_duration_t& wait);
  void CheckLinksRealtime();
  void MarkLegDead(int leg, hexa_msg_FaultReason reason, const char* detail);
  void ReportGoneWriters();
  // Supervisor's sensor-consistency faults: that leg's valve is held at null (interlock).
  void TakeFaultEvents();
  void MonitorCompute(const hexa_msg_ValveCommand& c, dds_instance_handle_t writer);
  void PublishStatus(hexa_msg_NodeState state, const char* detail);
  void LogLastGoodState() const;
  void LogCommandAges() const;
  void WriteSummary(int exit_code) const;

  PlantNodeOptions options_;
  config::SystemConfig config_;
  std::shared_ptr<spdlog::logger> log_;
  PlatformPlant plant_;
  CommandHygieneParams hygiene_;
  LockstepSchedule schedule_;
  LockstepBarrier barrier_;
  std::uint64_t last_tick_ = UINT64_MAX;

  comm::Participant participant_;
  comm::ShutdownGuard shutdown_;
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
  node::StatusPublisher status_;
  node::FaultPublisher faults_;
  node::PeerTracker peers_;
  comm::Topic<hexa_msg_FaultEvent> fault_topic_;
  comm::Reader<hexa_msg_FaultEvent> fault_reader_;  // polled: never a callback (see .cpp)
  comm::WaitSet waitset_;

  std::mutex mutex_;  // everything below; the receive thread and the main thread
  std::uint64_t tick_ = 0;
  bool running_ = false;        // lockstep: the receive thread may advance
  bool sync_pending_ = false;   // lockstep: tick_ is not published until the recorder caught up
  bool ack_wait_requested_ = false;  // the main thread is to start an acknowledgement wait
  bool ack_wait_active_ = false;     // ... and is in it
  std::uint64_t ack_wait_tick_ = 0;  // the tick at which it was requested
  int64_t sync_blocked_since_ns_ = 0;
  // Lockstep: leases of awaited legs lapsed while their processes were not shown dead or
  // stuck (stopped, not scheduled): waited through, one per leg and tick, logged once per leg.
  std::uint64_t lapses_waited_ = 0;
  LegArray<std::uint64_t> lapse_waited_tick_{};
  node::PeerProcesses peer_processes_;  // --peer-pid: the session's processes on this host
  LegArray<std::string> leg_name_{}, standby_name_{};  // "leg3", "leg3_standby"
  bool sync_suspended_ = false;  // a sync was given up: no blocking until a wait succeeds
  std::uint64_t recorder_syncs_given_up_ = 0;
  // Real time: wake-ups later than this restart the schedule (RunRealtime).
  // Every slip is logged with its tick and kept (count, total, worst, the first 64 ticks) for
  // the summary: a lapse's tick can be matched to the stall before it.
  static constexpr int64_t kSlipAfter_ns = 2'000'000;
  core::ScheduleSlips slips_{kSlipAfter_ns};
  std::uint64_t recorder_syncs_ = 0;      // acknowledgement waits
  std::uint64_t recorder_sync_blocks_ = 0;  // of them, the loop stopped for
  double recorder_sync_wait_s_ = 0.0;     // time the loop stood still for them
  int exit_code_ = -1;          // set when the run ends (>= 0)
  LegArray<LatestCommand> latest_{};
  LegArray<CommandEpisode> episodes_{};  // fault episodes per leg: one report each
  // Real time: lease lapses while the leg's commands were fresh (the host, not the leg).
  std::int64_t lapse_confirm_ticks_ = 10;      // the lease in ticks
  std::uint64_t slip_recent_until_tick_ = 0;  // a slip of the schedule: stale tolerance after it
  LegArray<bool> lapse_while_fresh_{};
  std::uint64_t lapses_while_fresh_ = 0;
  LegWriterTable writers_;
  LegMask dropped_ = 0;                  // lockstep: legs no longer awaited (dead)
  LegArray<bool> link_dead_{};           // no live writer now (real time) / dropped (lockstep)
  LegArray<bool> interlock_{};           // a sensor fault of the leg reported: valve at null
  LegArray<hexa_msg_FaultReason> forced_reason_{};  // why the valve is forced to null
  LegArray<bool> gone_reported_{};
  LegArray<std::uint32_t> link_alive_run_{};
  LegArray<bool> link_armed_{};  // real time: a writer of the leg has been seen alive  // real time: ticks alive since the leg was dead
  LegArray<WriterComputeBudgets> compute_{};  // per writer: primary and standby
  bool imu_lost_reported_ = false;
  bool host_overload_reported_ = false;
  LegArray<std::uint32_t> faults_per_leg_{};
  LegArray<CommandAgeHistogram> command_age_{};
  hexa_msg_GroundTruth truth_sample_{};
  node::CycleTimeWindow cycle_times_;
  DurationHistogram tick_wall_;   // lockstep: publish -> complete; real time: wake-up lateness
  std::int64_t loop_started_ns_ = 0;
  std::int64_t loop_ended_ns_ = 0;
  std::int64_t tick_started_ns_ = 0;
  std::uint32_t overruns_ = 0;
  std::uint64_t resent_samples_ = 0;  // lockstep: sensor samples re-published to silent legs
  // Lockstep: the supervisor's inputs of the newest supervisor tick (six legs' sensors and
  // the IMU), re-published with a re-ask: a leg that cannot answer may lack that tick's
  // setpoint because the supervisor lost its inputs, or the leg lost the setpoint.
  std::array<hexa_msg_LegSensors, kNumLegs> supervisor_sensors_{};
  hexa_msg_ImuSample supervisor_imu_{};
  bool supervisor_inputs_valid_ = false;
  std::uint64_t supervisor_reasks_ = 0;
  // Re-asks of the supervisor back off within a tick (the re-ask period, then doubling up to
  // 1 s): a supervisor that is only slow is not buried under repeated inputs (docs/faults.md,
  // "Re-asks back off").
  ReaskBackoff supervisor_reask_{50'000'000, 1'000'000'000};
  bool supervisor_inputs_lost_ = false;  // --lose-supervisor-inputs done
  LegArray<std::uint64_t> rejected_per_leg_{};  // samples of another leg's key, per partition
  // Command reception (docs/faults.md, "Foreign commands"): unauthenticated samples refused
  // and reported; per leg, which authenticated writer (primary or standby) is applied.
  node::CommandRefusals refusals_;
  LegArray<CommandSourceSelector> sources_{};
};

}  // namespace hexa::plant_sim
