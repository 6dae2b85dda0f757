// The plant node's life cycle: start-up (waiting for its peers), the status it publishes, the
// service manager's notifications and watchdog, and the report of the run at its end
// (log and JSON summary), on the services' shared runtime (hexa/services/runtime.hpp).
#include <algorithm>
#include <cmath>

#include "hexa/services/exit_code.hpp"
#include "hexa/services/json.hpp"
#include "hexa/services/service_manager.hpp"
#include "plant_node.hpp"

namespace hexa::plant_sim {
namespace {

constexpr dds_attach_t kTokenPeers = 3;  // the Runtime's shutdown is 1, the loop's wake 2

}  // namespace

int PlantNode::Run() {
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  runtime_.Start(Figures(), "waiting for peers");
  // NodeStatus data wakes the wait (a peer RUNNING); the loop polls it without waking.
  runtime_.waitset().Attach(peers_.data_condition(), kTokenPeers);
  const services::PeerWaitResult started = runtime_.WaitForPeers(StartupWait());
  runtime_.waitset().Detach(peers_.data_condition());
  if (started != services::PeerWaitResult::kMatched)
    return runtime_.FailStart(Figures(), "peers not ready", exit_code::kPeersNotMatched);
  {
    HardwareLifecycleInput configured;  // the device was brought up (BringUpDevice)
    configured.device_configured = true;
    lifecycle_.Update(configured, hardware_);
  }
  runtime_.Running(Figures(), StatusDetail(), realtime ? "ticking in real time" : "ticking in lockstep");
  LogStart();
  log_->info("hardware {}: {}", ToString(hardware_.state),
             options_.activation == HardwareActivation::kAuto
                 ? "activated at the first tick (--activation auto)"
                 : "every valve at its safe value until an operator start or home is granted "
                   "(--activation operator)");
  const uint64_t last_tick = options_.duration_s > 0
                                 ? static_cast<uint64_t>(std::llround(options_.duration_s / kTickS))
                                 : UINT64_MAX;
  figures_.loop_started_ns = node::MonotonicNow_ns();
  int rc = realtime ? RunRealtime(last_tick) : RunLockstep(last_tick);
  if (rc == exit_code::kOk && link_.lost()) rc = exit_code::kPlantDeviceLost;  // said at the end
  std::lock_guard<std::mutex> lock(cycle_.mutex());
  figures_.loop_ended_ns = node::MonotonicNow_ns();
  {
    HardwareLifecycleInput end;  // the run is over: back to inactive, then the device closes
    end.device_configured = !link_.lost();
    end.deactivate = true;
    lifecycle_.Update(end, hardware_);
    if (hardware_.changed) log_->info("hardware {}: the run ended", ToString(hardware_.state));
  }
  LogEnd();
  LogDeviceEnd();
  LogCommandAges();
  WriteSummary(rc);
  device_.Close();  // the valves to their safe state, the link released
  // A non-finite state leaves its FAULT as the plant's last word (no STOPPING after it).
  if (rc != exit_code::kPlantNonFinite) runtime_.Stop(Figures(), "stopped");
  else node::service_manager::Stopping("stopped");
  return rc;
}

void PlantNode::LogStart() const {
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  log_->info("ticking in {} mode on the {}, profile '{}', seed {}", realtime ? "real-time" : "lockstep",
             board_ ? "remote board at " + options_.board.host + ":" + std::to_string(options_.board.port)
                    : std::string("simulated rig"),
             options_.profile, options_.seed);
  log_->info("dead legs: {}; compute budget {:.3f} ms x {} cycles",
             realtime ? fmt::format("liveliness lease {:.3f} s", options_.common.realtime_lease_s)
                      : fmt::format("lockstep: a process ended ({}), writers gone, or a "
                                    "controller stuck (lease {:.3f} s lapsed and its cycle "
                                    "stuck); last resort {:.1f} s",
                                    runtime_.peer_processes().empty()
                                        ? "no process ids given: seen when its participant's "
                                          "lease expires"
                                        : "process ids given by the launcher",
                                    options_.common.lockstep_lease_s,
                                    options_.common.lockstep_timeout_s),
             options_.compute_budget.budget_s * 1e3, options_.compute_budget.overrun_limit);
  for (const PlantFault& f : options_.plant_faults.faults)
    log_->warn("FAULT INJECTION: {} of leg {} at t = {:.3f} s", ToString(f.kind), f.leg, f.at_time_s);
}

void PlantNode::LogEnd() const {
  const core::ScheduleSlips& slips = realtime_.slips();
  uint32_t faults = 0;
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) faults += arbitration_.episodes(leg);
  const auto valve = valve_readers_.Snapshot();
  std::uint64_t rejected = 0;
  for (auto r : rejected_per_leg_) rejected += r;
  log_->info("stopped at tick {} (t = {:.3f} s): valve deadline misses {}, loop overruns {}, "
             "command faults {}, lockstep resends {} (in {} re-asks, {} to the supervisor), "
             "failed writes {}, recorder syncs {} (the loop stood still for {} of them, "
             "{:.3f} s; {} given up), schedule slips {} ({:.1f} ms), lockstep lease lapses "
             "waited through {}, real-time lease lapses with fresh commands {}, "
             "rejected commands {}, refused commands {} (from {} writers not of this session); "
             "writers:{}",
             tick_, static_cast<double>(tick_) * kTickS, valve.requested_deadline_missed_total,
             realtime_.overruns(), faults, figures_.resent_samples, lockstep_.barrier().reasks_total(),
             supervisor_reasks_, sensors_writer_.write_errors_total(), lockstep_.syncs(),
             lockstep_.sync_blocks(), lockstep_.sync_wait_s(), lockstep_.syncs_given_up(),
             slips.count(), static_cast<double>(slips.total_ns()) * 1e-6,
             arbitration_.lapses_waited(), arbitration_.lapses_while_fresh(), rejected,
             refusals_.samples(), refusals_.writers(), writers_.Describe());
  if (slips.count() > 0) {
    std::string ticks;
    for (std::size_t k = 0; k < slips.kept_count(); ++k)
      ticks += fmt::format("{}{} ({:.1f} ms)", k == 0 ? "" : ", ", slips.kept(k).tick,
                           static_cast<double>(slips.kept(k).late_ns) * 1e-6);
    log_->info("schedule slips (wake-ups more than {:.1f} ms late): {}, worst {:.1f} ms at tick {}; "
               "ticks{}: {}", static_cast<double>(slips.threshold_ns()) * 1e-6, slips.count(),
               static_cast<double>(slips.worst().late_ns) * 1e-6, slips.worst().tick,
               slips.count() > slips.kept_count() ? " (the first ones)" : "", ticks);
  }
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    const WriterComputeBudgets& c = arbitration_.compute(leg);
    if (c.cycles() == 0) continue;
    log_->info("leg {} compute time: max {:.3f} ms, {} of {} cycles over the {:.3f} ms budget",
               leg, c.max_s() * 1e3, c.over_budget(), c.cycles(), options_.compute_budget.budget_s * 1e3);
  }
}

services::StatusFigures PlantNode::Figures() {
  const auto valve = valve_readers_.Snapshot();
  services::StatusFigures f;
  f.tick = tick_;
  f.sim_time_s = static_cast<double>(tick_) * kTickS;
  f.deadline_missed = static_cast<std::uint32_t>(valve.requested_deadline_missed_total + realtime_.overruns());
  f.liveliness_changes = valve.liveliness_changed_events;
  f.cycles = cycle_times_.total();
  f.cycle_median_s = cycle_times_.Median();
  f.cycle_max_s = cycle_times_.Max();
  return f;
}

bool PlantNode::SyncGiveUpDue(std::int64_t blocked_ns) const {
  // The readers the sync waits for: the supervisor's and the recorder's (all-legs partition,
  // ground truth). Processes that exist (perhaps stopped: a SIGSTOP, a loaded machine) are
  // waited for: giving up would let the loop run past the writers' history and the recorder
  // lose samples. One whose process ended never acknowledges (until discovery drops it,
  // 10 s): given up after recorder_sync_give_up_s, as when the processes are not known here
  // (another host). Not at once: a supervisor that died ends the session 2 s later (the
  // launcher), and a loop let free at once outran the recorder in that time (21680 samples
  // lost in one run) where a 1 s pause keeps it within the history.
  bool known = false, ended = false;
  for (const char* name : {"recorder", "supervisor"}) {
    const node::PeerProcessState state = runtime_.peer_processes().State(name);
    ended = ended || state == node::PeerProcessState::kEnded;
    known = known || state != node::PeerProcessState::kUnknown;
  }
  if (known && !ended) return false;
  return blocked_ns > static_cast<std::int64_t>(options_.recorder_sync_give_up_s * 1e9);
}
std::string PlantNode::DescribeMissing(const std::vector<std::string>& missing) const {
  std::string text;
  for (const std::string& name : missing) {
    text += text.empty() ? "" : "; ";
    if (!runtime_.peer_processes().Known(name)) {
      text += name + " (no NodeStatus RUNNING yet; process not known on this host)";
      continue;
    }
    const node::PeerProcessState state = runtime_.peer_processes().State(name);
    text += runtime_.peer_processes().Describe(name) +
            (state == node::PeerProcessState::kStopped
                 ? ": it cannot start until it is continued"
                 : state == node::PeerProcessState::kRunning ? ": not RUNNING yet (matching its peers)" : "");
  }
  return text;
}

services::PeerWait PlantNode::StartupWait() {
  services::PeerWait wait;
  wait.rule.timeout_s = options_.startup_timeout_s;
  wait.rule.report_after_s = options_.startup_report_after_s;
  for (int leg = 1; leg <= options_.expected_legs; ++leg) {
    wait.processes.push_back(leg_name_[static_cast<std::size_t>(leg - 1)]);
    if (options_.expect_standbys) wait.processes.push_back(standby_name_[static_cast<std::size_t>(leg - 1)]);
  }
  if (options_.expect_supervisor) wait.processes.push_back("supervisor");
  if (options_.expect_recorder) wait.processes.push_back("recorder");
  // A process the launcher started for this session has ended: it will never be ready.
  wait.fail_when_a_process_ends = true;
  wait.recheck_ns = 50'000'000;  // and on NodeStatus data
  wait.matched = [this, expected = wait.processes](std::string& missing) {
    peers_.Poll();
    const std::vector<std::string> not_running = peers_.NotRunning(expected);
    std::string counts;
    if (PeersMatched(counts) && not_running.empty()) {
      log_->info("all peers ready: {}", counts);
      return true;
    }
    missing = "not running: " +
              (not_running.empty() ? std::string("none (every process RUNNING)")
                                   : DescribeMissing(not_running)) + "; " + counts;
    return false;
  };
  return wait;
}

bool PlantNode::PeersMatched(std::string& counts) {
  // Sensor readers: each leg controller (and its hot standby) in its leg's partition; the
  // supervisor and the recorder on the all-legs writer. Valve writers: one per leg
  // controller. A standby must see tick 0 too: lockstep does not wait for it later, and a
  // standby that missed ticks no longer computes the primary's commands.
  const uint32_t per_leg = options_.expect_standbys ? 2u : 1u;
  const uint32_t all_legs_readers = (options_.expect_supervisor ? 1u : 0u) +
                                    (options_.expect_recorder ? 1u : 0u);
  const uint32_t sensor_readers =
      static_cast<uint32_t>(options_.expected_legs) * per_leg + all_legs_readers;
  uint32_t sensors = 0;
  for (int leg = 1; leg <= options_.expected_legs; ++leg)
    sensors += std::min(per_leg, sensors_writer_.leg(leg).Snapshot().publication_matched_current);
  sensors += std::min(all_legs_readers, sensors_writer_.all().Snapshot().publication_matched_current);
  const uint32_t valve_writers = static_cast<uint32_t>(options_.expected_legs) * per_leg;
  const auto valves = valve_readers_.Snapshot().subscription_matched_current;
  // The IMU too: a reader matched on its side may not be matched on this side yet, and a
  // volatile IMU(0) sent before would never reach it (the supervisor would wait for it).
  const auto imu = imu_writer_.Snapshot().publication_matched_current;
  const auto truth = truth_writer_.Snapshot().publication_matched_current;
  const uint32_t truth_readers = options_.expect_recorder ? 1u : 0u;
  // Every awaited leg's writers known as that leg's (USER_DATA resolved). Alive or not: a
  // writer whose lease lapsed before it wrote (its process stopped or not scheduled during
  // start-up) is seen alive again only when it writes, and in lockstep a lapse decides
  // nothing (docs/faults.md). Real time: the control readers are best effort, and a
  // best-effort reader learns a writer's liveliness from its data only (no heartbeats):
  // before the first command no leg looks alive. CheckLinksRealtime arms a leg once it has
  // been seen alive.
  writers_.Refresh(valve_readers_, /*may_give_up=*/false);
  int legs_alive = 0;
  for (int leg = 1; leg <= options_.expected_legs; ++leg) {
    const LegWriterCounts c = writers_.Counts(leg);
    legs_alive += c.alive + c.not_alive >= static_cast<int>(per_leg) ? 1 : 0;
  }
  if (options_.common.mode == node::TimeMode::kRealtime) legs_alive = options_.expected_legs;
  counts = fmt::format("sensor readers {}/{}, valve writers {}/{} (legs with known writers "
                        "{}/{}), IMU readers {}/{}, ground-truth readers {}/{}; writers:{}",
                        sensors, sensor_readers, valves, valve_writers, legs_alive,
                        options_.expected_legs, imu, all_legs_readers, truth, truth_readers,
                        writers_.Describe());
  return sensors >= sensor_readers && valves >= valve_writers && imu >= all_legs_readers &&
         truth >= truth_readers && legs_alive == options_.expected_legs;
}

void PlantNode::LogLastGoodState() const {
  const PlatformPlant* sim = device_.simulation();
  if (sim == nullptr) return;
  const auto& t = sim->truth();
  log_->error("last good state at t = {:.3f} s: p = ({:.5f}, {:.5f}, {:.5f}) m, legs P1 = "
              "[{:.0f} {:.0f} {:.0f} {:.0f} {:.0f} {:.0f}] Pa",
              t.time_s, t.pose.p_BP_B_m.x(), t.pose.p_BP_B_m.y(), t.pose.p_BP_B_m.z(),
              t.legs[0].chamber1_pressure_pa, t.legs[1].chamber1_pressure_pa,
              t.legs[2].chamber1_pressure_pa, t.legs[3].chamber1_pressure_pa,
              t.legs[4].chamber1_pressure_pa, t.legs[5].chamber1_pressure_pa);
}

void PlantNode::LogCommandAges() const {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandAgeHistogram& h = figures_.command_age[i];
    if (h.total() == 0) continue;
    log_->info("leg {} command age at apply (ticks): 0: {}, 1: {}, 2: {}, 3-7: {}, 8-15: {}, "
               ">=16: {}, none: {}; late ticks {} of {} ({:.3f} %)",
               i + 1, h.bins[0], h.bins[1], h.bins[2], h.bins[3], h.bins[4], h.bins[5], h.none,
               h.late(), h.total(), 100.0 * static_cast<double>(h.late()) / static_cast<double>(h.total()));
  }
}

void PlantNode::WriteSummary(int exit_code) const {
  if (options_.summary_path.empty()) return;
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  const auto valve = valve_readers_.Snapshot();
  const core::ScheduleSlips& slips = realtime_.slips();
  json::Value j = {{"mode", realtime ? "realtime" : "lockstep"},
                   {"exit_code", exit_code},
                   {"ticks", tick_},
                   {"sim_time_s", static_cast<double>(tick_) * kTickS},
                   {"valve_deadline_misses", valve.requested_deadline_missed_total},
                   {"loop_overruns", realtime_.overruns()},
                   {"lockstep_resends", figures_.resent_samples},
                   {"schedule_slips", slips.count()},
                   {"slipped_s", static_cast<double>(slips.total_ns()) * 1e-9},
                   {"refused_commands", refusals_.samples()},
                   {"refused_writers", refusals_.writers()},
                   {"loop_wall_s", static_cast<double>(figures_.loop_ended_ns - figures_.loop_started_ns) * 1e-9}};
  j[realtime ? "wake_lateness_s" : "tick_wall_s"] = {{"median", figures_.tick_wall.Quantile_s(0.5)},
                                                     {"p99", figures_.tick_wall.Quantile_s(0.99)},
                                                     {"max", figures_.tick_wall.max_s()},
                                                     {"mean", figures_.tick_wall.mean_s()}};
  j["device"] = board_ ? "board" : "sim";
  j["control_round_trip_s"] = {{"median", link_.round_trip().Quantile_s(0.5)},
                               {"p99", link_.round_trip().Quantile_s(0.99)},
                               {"max", link_.round_trip().max_s()},
                               {"count", link_.round_trip().count()}};
  j["ticks_without_sample"] = link_.samples_missed_total();
  j["estop_unsafe_ticks"] = link_.estop_unsafe_ticks();
  if (board_ != nullptr) j["board_link"] = board_->counters().Describe();
  j["command_age_bins"] = {"0", "1", "2", "3-7", "8-15", ">=16"};
  j["legs"] = json::Value::array();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandAgeHistogram& h = figures_.command_age[i];
    const int leg = static_cast<int>(i) + 1;
    json::Value ages = json::Value::array();
    for (int k = 0; k < CommandAgeHistogram::kBins; ++k) ages.push_back(h.bins[static_cast<std::size_t>(k)]);
    j["legs"].push_back({{"leg", i + 1},
                         {"command_age", ages},
                         {"no_command", h.none},
                         {"late_ticks", h.late()},
                         {"faults", arbitration_.episodes(leg)},
                         {"dead", arbitration_.dead(leg)},
                         {"forced_reason", static_cast<int>(arbitration_.forced_reason(leg))},
                         {"interlock", arbitration_.interlocked(leg)},
                         {"compute_max_s", arbitration_.compute(leg).max_s()},
                         {"compute_over_budget", arbitration_.compute(leg).over_budget()},
                         {"cycles", arbitration_.compute(leg).cycles()}});
  }
  // Every slip's tick (the first ScheduleSlips::kKept), to match a fault to the stall before it.
  j["worst_slip"] = {{"tick", slips.worst().tick},
                     {"late_s", static_cast<double>(slips.worst().late_ns) * 1e-9}};
  j["slips"] = json::Value::array();
  for (std::size_t k = 0; k < slips.kept_count(); ++k)
    j["slips"].push_back({{"tick", slips.kept(k).tick},
                          {"late_s", static_cast<double>(slips.kept(k).late_ns) * 1e-9}});
  std::string error;
  if (!json::WriteFile(options_.summary_path, j, 2, error)) log_->error("summary: {}", error);
}

}  // namespace hexa::plant_sim
