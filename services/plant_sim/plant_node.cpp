#include "plant_node.hpp"

#include <time.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "hexa/services/json.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::plant_sim {
namespace {

constexpr double kTickS = 0.001;
constexpr dds_attach_t kTokenShutdown = 1;
constexpr dds_attach_t kTokenWake = 2;
constexpr dds_attach_t kTokenPeers = 3;

hexa_msg_FaultReason FaultOf(CommandCheck check) {
  switch (check) {
    case CommandCheck::kMissing: return hexa_msg_FAULT_COMMAND_DEADLINE_MISSED;
    case CommandCheck::kStale: return hexa_msg_FAULT_COMMAND_STALE;
    case CommandCheck::kNotFinite: return hexa_msg_FAULT_COMMAND_NOT_FINITE;
    case CommandCheck::kOutOfRange: return hexa_msg_FAULT_COMMAND_OUT_OF_RANGE;
    case CommandCheck::kOk:
    case CommandCheck::kAwaitingFirst: break;
  }
  return hexa_msg_FAULT_NONE;
}

PlatformPlantConfig MakePlantConfig(const PlantNodeOptions& o, const config::SystemConfig& c) {
  PlatformPlantConfig p;
  p.rig = c.rig;
  p.disturbance = c.profiles.at(o.profile);
  p.seed = o.seed;
  p.tracker.enabled = o.tracker;
  p.free_fall = o.free_fall;
  p.faults = o.plant_faults;
  return p;
}

hexa_msg_FaultReason WireReason(SilentLegVerdict v) {
  switch (v) {
    case SilentLegVerdict::kLivelinessLost: return hexa_msg_FAULT_LIVELINESS_LOST;
    case SilentLegVerdict::kWriterGone: return hexa_msg_FAULT_WRITER_GONE;
    case SilentLegVerdict::kProcessEnded: return hexa_msg_FAULT_WRITER_GONE;
    case SilentLegVerdict::kWait: break;
  }
  return hexa_msg_FAULT_NONE;
}

// The longest wait between two re-asks of the supervisor within one tick.
constexpr std::int64_t kSupervisorReaskMax_ns = 1'000'000'000;

LockstepBarrierParams BarrierParams(const PlantNodeOptions& o) {
  LockstepBarrierParams p;
  p.reask_after_ns = static_cast<std::int64_t>(o.resend_after_s * 1e9);
  p.timeout_ns = static_cast<std::int64_t>(o.common.lockstep_timeout_s * 1e9);
  return p;
}

// A leg controller's valve writer says which leg it drives (comm::LegEndpointUserData); false
// for anything else, a leg beyond the rig's too.
bool ParseLegUserData(const std::string& text, int& leg, bool& standby) {
  return comm::ParseLegEndpointUserData(text, leg, standby) && leg <= static_cast<int>(kNumLegs);
}

// The valve readers keep 64 samples per leg: with SHARED ownership a standby's samples (and
// a foreign writer's) share leg N's instance with the primary's, and a keep-last-1 history
// would let one displace the other before the plant takes it.
comm::QosParams ValveReaderQos(const node::CommonOptions& o) {
  comm::QosParams q = node::QosFor(o, comm::TopicKind::kValveCommand);
  q.control_reader_depth = 64;
  return q;
}

SourceLiveliness SourceLivelinessOf(comm::WriterLiveliness l) {
  switch (l) {
    case comm::WriterLiveliness::kAlive: return SourceLiveliness::kAlive;
    case comm::WriterLiveliness::kNotAlive: return SourceLiveliness::kNotAlive;
    case comm::WriterLiveliness::kGone: return SourceLiveliness::kGone;
    case comm::WriterLiveliness::kUnknown: break;
  }
  return SourceLiveliness::kUnknown;
}

std::string LegList(LegMask mask) {
  std::string text;
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
    if (mask & LegBit(leg)) text += " leg" + std::to_string(leg);
  return text;
}

}  // namespace

void LegWriterTable::Refresh(const comm::LegReaders<hexa_msg_ValveCommand>& readers, bool may_give_up) {
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) RefreshOne(readers.leg(leg), leg, may_give_up);
}

void LegWriterTable::RefreshOne(const comm::Reader<hexa_msg_ValveCommand>& reader, int reader_leg,
                                bool may_give_up) {
  PerReader& r = readers_[static_cast<std::size_t>(reader_leg - 1)];
  r.counters = &reader.status();
  const auto& slots = r.counters->writers();
  for (std::size_t k = 0; k < kSlots; ++k) {
    const dds_instance_handle_t h = slots[k].publication.load(std::memory_order_acquire);
    if (h == 0) break;  // slots are claimed in order
    if (r.leg[k] != 0) continue;
    // What the writer says it is counts only when the session key vouches for it, by the rule
    // of the valve commands (comm::MatchedWriterClaim): a foreign writer that claims to be
    // leg N's controller is not counted as one.
    std::string claim;
    const comm::CommandTrust trust = comm::MatchedWriterClaim(reader.get(), h, claim);
    int leg = 0;
    bool standby = false;
    if (trust == comm::CommandTrust::kUnknownWriter) {
      // Not (yet) known as a matched publication: discovery may lag the liveliness callback
      // that claimed the slot, so ask again on later refreshes; a writer still unknown after
      // 100 of them is gone (it cannot count as alive, and no leg can claim it). Not while
      // waiting for the peers: there, a loaded machine's discovery may take longer than 100
      // refreshes, and giving up left a live leg's writer unresolved for good (the start-up
      // never completed: "legs with a live writer 5/6").
      if (r.unresolved[k] < 255) ++r.unresolved[k];
      if (may_give_up && r.unresolved[k] >= 100) r.leg[k] = -1;
    } else if (comm::Trusted(trust) && ParseLegUserData(claim, leg, standby) && leg == reader_leg) {
      r.leg[k] = static_cast<std::int8_t>(leg);
      r.standby[k] = standby;
    } else {
      // A tool's writer (replay), one that names another leg than its partition's, or one
      // whose claim the session key does not vouch for: not this leg's controller
      // (RejectCommand and the command check refuse its samples).
      r.leg[k] = -1;
    }
  }
}

LegWriterCounts LegWriterTable::Counts(int leg) const {
  LegWriterCounts c;
  const PerReader& r = readers_[static_cast<std::size_t>(leg - 1)];
  if (r.counters == nullptr) return c;
  const auto& slots = r.counters->writers();
  for (std::size_t k = 0; k < kSlots; ++k) {
    if (r.leg[k] != leg) continue;
    switch (static_cast<comm::WriterLiveliness>(slots[k].state.load(std::memory_order_relaxed))) {
      case comm::WriterLiveliness::kAlive: ++c.alive; break;
      case comm::WriterLiveliness::kNotAlive: ++c.not_alive; break;
      case comm::WriterLiveliness::kGone: ++c.gone; break;
      case comm::WriterLiveliness::kUnknown: break;
    }
  }
  return c;
}

std::string LegWriterTable::Describe() const {
  std::string text;
  static const char* kState[] = {"unknown", "alive", "not alive", "gone"};
  for (const PerReader& r : readers_) {
    if (r.counters == nullptr) continue;
    const auto& slots = r.counters->writers();
    for (std::size_t k = 0; k < kSlots; ++k) {
      if (slots[k].publication.load(std::memory_order_acquire) == 0) break;
      if (r.leg[k] <= 0) {
        // Unresolved, or given up on; a writer resolved to another leg is not listed.
        const bool given_up = r.leg[k] < 0 && r.unresolved[k] >= 100;
        if (r.leg[k] == 0 || given_up) {
          text += " a writer in leg" + std::to_string(&r - readers_.data() + 1) + "'s partition " +
                  (given_up ? std::string("never resolved (given up)")
                            : "not resolved yet (" + std::to_string(r.unresolved[k]) + " refreshes)") +
                  ";";
        }
        continue;
      }
      const int state = slots[k].state.load(std::memory_order_relaxed);
      text += " leg" + std::to_string(r.leg[k]) + (r.standby[k] ? " standby " : " primary ") +
              kState[std::clamp(state, 0, 3)] + ";";
    }
  }
  return text;
}

void CommandAgeHistogram::Add(std::int64_t age_ticks) {
  if (age_ticks < 0) {
    ++none;
    return;
  }
  const int bin = age_ticks <= 2 ? static_cast<int>(age_ticks) : (age_ticks < 8 ? 3 : (age_ticks < 16 ? 4 : 5));
  ++bins[static_cast<std::size_t>(bin)];
}

std::uint64_t CommandAgeHistogram::late() const {
  std::uint64_t n = 0;
  for (int k = 1; k < kBins; ++k) n += bins[static_cast<std::size_t>(k)];
  return n;
}

std::uint64_t CommandAgeHistogram::total() const { return bins[0] + late() + none; }

void DurationHistogram::Add(std::int64_t duration_ns) {
  const std::int64_t d = std::max<std::int64_t>(0, duration_ns);
  const std::size_t bin = std::min<std::size_t>(static_cast<std::size_t>(d / kBinNs), kBins);
  ++bins_[bin];
  ++count_;
  max_ns_ = std::max(max_ns_, d);
  sum_s_ += static_cast<double>(d) * 1e-9;
}

double DurationHistogram::Quantile_s(double q) const {
  if (count_ == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b <= kBins; ++b) {
    seen += bins_[b];
    if (seen >= rank) return b == kBins ? max_s() : static_cast<double>((b + 1) * kBinNs) * 1e-9;
  }
  return max_s();
}

PlantNode::PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
                     std::shared_ptr<spdlog::logger> log)
    : options_(options),
      config_(config),
      log_(std::move(log)),
      plant_(MakePlantConfig(options, config)),
      hygiene_([&] {
        CommandHygieneParams h = CommandHygieneParams::FromValve(config.rig.valve, 0);
        if (options.common.mode == node::TimeMode::kRealtime)
          h.startup_grace_ticks = options.startup_grace_ticks;
        return h;
      }()),
      barrier_(BarrierParams(options)),
      // The six legs' samples of a tick leave in one datagram per reader (comm/writer.hpp).
      participant_(static_cast<dds_domainid_t>(options.common.domain_id),
                   comm::WriteBatching::kOn),
      shutdown_(participant_),
      wake_(participant_),
      sensors_topic_(participant_),
      imu_topic_(participant_),
      truth_topic_(participant_),
      valve_topic_(participant_),
      sensors_writer_(participant_, sensors_topic_,
                      node::QosFor(options.common, comm::TopicKind::kLegSensors)),
      imu_writer_(participant_, imu_topic_, node::QosFor(options.common, comm::TopicKind::kImuSample)),
      truth_writer_(participant_, truth_topic_,
                    node::QosFor(options.common, comm::TopicKind::kGroundTruth)),
      tracker_topic_(participant_),
      tracker_writer_(participant_, tracker_topic_,
                      node::QosFor(options.common, comm::TopicKind::kTrackerPose)),
      valve_readers_(participant_, valve_topic_, comm::EndpointRole::kControlReader,
                     ValveReaderQos(options.common), 64),
      status_(participant_, "plant"),
      faults_(participant_, "plant"),
      peers_(participant_),
      fault_topic_(participant_),
      fault_reader_(participant_, fault_topic_, comm::EndpointRole::kControlReader,
                    node::QosFor(options.common, comm::TopicKind::kFaultEvent), 64),
      waitset_(participant_) {
  for (const std::string& spec : options.common.peer_pids) {
    std::string error;
    if (!peer_processes_.Add(spec, error)) throw std::invalid_argument(error);
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    leg_name_[i] = "leg" + std::to_string(i + 1);
    standby_name_[i] = leg_name_[i] + "_standby";
  }
  lapse_confirm_ticks_ = std::max<std::int64_t>(1, std::llround(options.common.realtime_lease_s / kTickS));
  forced_reason_.fill(hexa_msg_FAULT_NONE);
  supervisor_reask_ = ReaskBackoff(BarrierParams(options).reask_after_ns, kSupervisorReaskMax_ns);
  waitset_.Attach(shutdown_.guard_condition(), kTokenShutdown);
  waitset_.Attach(wake_.get(), kTokenWake);
  waitset_.Attach(peers_.data_condition(), kTokenPeers);
  for (auto& age : truth_sample_.command_age_ticks) age = -1;
  // The loop may run recorder_sync_window_ticks (+ one sync period) ahead of the recorder;
  // the writers must still hold those samples, with margin.
  const auto depth = static_cast<std::uint64_t>(
      std::min({comm::WriterHistoryDepth(comm::TopicKind::kLegSensors),
                comm::WriterHistoryDepth(comm::TopicKind::kGroundTruth),
                comm::WriterHistoryDepth(comm::TopicKind::kValveCommand),
                schedule_.supervisor_every_ticks *
                    comm::WriterHistoryDepth(comm::TopicKind::kLegSetpoint)}));
  if (2 * (options_.recorder_sync_window_ticks + options_.recorder_sync_ticks) > depth)
    throw std::invalid_argument("recorder_sync_window_ticks " +
                                std::to_string(options_.recorder_sync_window_ticks) +
                                " + recorder_sync_ticks " +
                                std::to_string(options_.recorder_sync_ticks) +
                                ": more than half the writers' history of " +
                                std::to_string(depth) + " ticks");
}

void PlantNode::PublishStatus(hexa_msg_NodeState state, const char* detail) {
  const auto valve = valve_readers_.Snapshot();
  status_.Publish(state, tick_, static_cast<double>(tick_) * kTickS,
                  valve.requested_deadline_missed_total + overruns_,
                  valve.liveliness_changed_events, cycle_times_.total(), cycle_times_.Median(),
                  cycle_times_.Max(), detail);
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
    const node::PeerProcessState state = peer_processes_.State(name);
    ended = ended || state == node::PeerProcessState::kEnded;
    known = known || state != node::PeerProcessState::kUnknown;
  }
  if (known && !ended) return false;
  return blocked_ns > static_cast<std::int64_t>(options_.recorder_sync_give_up_s * 1e9);
}

std::string PlantNode::EndedPeer(const std::vector<std::string>& expected) const {
  for (const std::string& name : expected)
    if (peer_processes_.State(name) == node::PeerProcessState::kEnded) return name;
  return {};
}

std::string PlantNode::DescribeMissing(const std::vector<std::string>& missing) const {
  std::string text;
  for (const std::string& name : missing) {
    text += text.empty() ? "" : "; ";
    if (!peer_processes_.Known(name)) {
      text += name + " (no NodeStatus RUNNING yet; process not known on this host)";
      continue;
    }
    const node::PeerProcessState state = peer_processes_.State(name);
    text += peer_processes_.Describe(name) +
            (state == node::PeerProcessState::kStopped
                 ? ": it cannot start until it is continued"
                 : state == node::PeerProcessState::kRunning ? ": not RUNNING yet (matching its peers)" : "");
  }
  return text;
}

bool PlantNode::WaitForPeers() {
  std::vector<std::string> expected;
  for (int leg = 1; leg <= options_.expected_legs; ++leg) {
    expected.push_back("leg" + std::to_string(leg));
    if (options_.expect_standbys) expected.push_back("leg" + std::to_string(leg) + "_standby");
  }
  if (options_.expect_supervisor) expected.push_back("supervisor");
  if (options_.expect_recorder) expected.push_back("recorder");
  // Sensor readers: each leg controller (and its hot standby) in its leg's partition; the
  // supervisor and the recorder on the all-legs writer. Valve writers: one per leg
  // controller. A standby must see tick 0 too: lockstep does not wait for it later, and a
  // standby that missed ticks no longer computes the primary's commands.
  const uint32_t per_leg = options_.expect_standbys ? 2u : 1u;
  const uint32_t all_legs_readers = (options_.expect_supervisor ? 1u : 0u) +
                                    (options_.expect_recorder ? 1u : 0u);
  const uint32_t sensor_readers =
      static_cast<uint32_t>(options_.expected_legs) * per_leg + all_legs_readers;
  auto sensor_readers_matched = [&] {
    uint32_t n = 0;
    for (int leg = 1; leg <= options_.expected_legs; ++leg)
      n += std::min(per_leg, sensors_writer_.leg(leg).Snapshot().publication_matched_current);
    return n + std::min(all_legs_readers, sensors_writer_.all().Snapshot().publication_matched_current);
  };
  const uint32_t valve_writers = static_cast<uint32_t>(options_.expected_legs) * per_leg;
  PublishStatus(hexa_msg_NODE_STARTING, "waiting for peers");
  const int64_t end = node::MonotonicNow_ns() + static_cast<int64_t>(options_.startup_timeout_s * 1e9);
  int64_t next_log =
      node::MonotonicNow_ns() + static_cast<int64_t>(options_.startup_report_after_s * 1e9);
  while (!shutdown_.requested()) {
    peers_.Poll();
    const auto missing = peers_.NotRunning(expected);
    const auto sensors = sensor_readers_matched();
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
    if (missing.empty() && sensors >= sensor_readers && valves >= valve_writers &&
        imu >= all_legs_readers && truth >= truth_readers && legs_alive == options_.expected_legs) {
      log_->info("all peers ready: {} sensor readers, {} valve writers; writers:{}", sensors,
                 valves, writers_.Describe());
      return true;
    }
    const int64_t now = node::MonotonicNow_ns();
    // A process the launcher started for this session has ended: it will never be ready.
    if (const std::string ended = EndedPeer(expected); !ended.empty()) {
      log_->error("peers not ready: {}'s process has ended (the launcher's log says how); "
                  "waited {:.1f} s", ended,
                  options_.startup_timeout_s - static_cast<double>(end - now) * 1e-9);
      return false;
    }
    if (now > end) {
      log_->error("peers not ready after {} s: not running: {}; sensor readers {}/{}, valve "
                  "writers {}/{} (legs with known writers {}/{}), IMU readers {}/{}, "
                  "ground-truth readers {}/{}; writers:{}",
                  options_.startup_timeout_s, missing.empty() ? "none" : DescribeMissing(missing), sensors,
                  sensor_readers, valves, valve_writers, legs_alive, options_.expected_legs, imu,
                  all_legs_readers, truth, truth_readers, writers_.Describe());
      return false;
    }
    if (now > next_log) {
      // After a few seconds, every second: which peer is missing and why.
      log_->warn("waiting for peers for {:.1f} s: {}; sensor readers {}/{}, valve writers {}/{} "
                 "(legs with known writers {}/{}); writers:{}",
                 options_.startup_timeout_s - static_cast<double>(end - now) * 1e-9,
                 missing.empty() ? std::string("every process RUNNING") : DescribeMissing(missing),
                 sensors, sensor_readers, valves, valve_writers, legs_alive,
                 options_.expected_legs, writers_.Describe());
      next_log = now + 1'000'000'000;
    }
    // Wakes on NodeStatus data or shutdown; the timeout re-checks the match counts, which
    // change without data.
    waitset_.Wait(DDS_MSECS(50));
  }
  return false;
}

void PlantNode::PublishTick(int only_leg) {
  const PlatformPlantOutput& out = plant_.output();
  const double t = static_cast<double>(tick_) * kTickS;
  const int64_t now_ns = comm::RealtimeNow_ns();
  const bool lose_supervisor_inputs =
      only_leg == 0 && !supervisor_inputs_lost_ &&
      options_.lose_supervisor_inputs_tick == static_cast<std::int64_t>(tick_) &&
      options_.common.mode == node::TimeMode::kLockstep;
  if (lose_supervisor_inputs) {
    supervisor_inputs_lost_ = true;
    log_->warn("FAULT INJECTION: tick {}: the supervisor's inputs (six leg samples, IMU) "
               "withheld as if lost", tick_);
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (only_leg != 0 && static_cast<int>(i) + 1 != only_leg) continue;
    hexa_msg_LegSensors s{};
    s.leg_id = static_cast<uint8_t>(i + 1);
    comm::FillHeader(s.header, tick_, t, now_ns);
    s.length_m = out.legs[i].length_m;
    s.cap_pressure_pa = out.legs[i].chamber1_pressure_pa;
    s.rod_pressure_pa = out.legs[i].chamber2_pressure_pa;
    s.supply_pressure_pa = out.legs[i].supply_pressure_pa;
    if (only_leg != 0) {
      sensors_writer_.WriteToLegOnly(s, now_ns);  // a re-ask: that leg's controllers only
      return;
    }
    if (lose_supervisor_inputs) {
      sensors_writer_.leg(static_cast<int>(i) + 1).WriteDeferred(s, now_ns);  // legs only
    } else {
      sensors_writer_.WriteDeferred(s, now_ns);
    }
    if (schedule_.SupervisorDue(tick_)) supervisor_sensors_[i] = s;
  }
  sensors_writer_.Flush();
  if (schedule_.SupervisorDue(tick_) && out.imu.dropped_out) {
    // The IMU delivers nothing (plant fault imu-dropout). A hardware I/O node sees its read
    // of the device time out at the sample's due time and says so, once; in lockstep the
    // supervisor needs that to run its tick without the sample (docs/faults.md).
    if (!imu_lost_reported_) {
      imu_lost_reported_ = true;
      char detail[160];
      std::snprintf(detail, sizeof detail, "IMU: no sample at tick %llu (due every %d ticks): "
                    "the device does not answer", static_cast<unsigned long long>(tick_),
                    schedule_.supervisor_every_ticks);
      faults_.Publish(0, tick_, hexa_msg_FAULT_IMU_LOST, detail);
      log_->error("tick {}: {}", tick_, detail);
    }
  } else if (schedule_.SupervisorDue(tick_)) {
    hexa_msg_ImuSample imu{};
    comm::FillHeader(imu.header, tick_, t, now_ns);
    const auto& q = out.imu.q_BP_measured;
    imu.orientation_wxyz[0] = q.w();
    imu.orientation_wxyz[1] = q.x();
    imu.orientation_wxyz[2] = q.y();
    imu.orientation_wxyz[3] = q.z();
    for (int k = 0; k < 3; ++k) imu.angular_rate_rad_s[k] = out.imu.angular_rate_B_rad_s[k];
    if (!lose_supervisor_inputs) imu_writer_.Write(imu, now_ns);
    supervisor_imu_ = imu;
    supervisor_inputs_valid_ = true;
  }
  // Ground truth of this tick (for the recorder only). Like applied_valve_v, the command ages
  // in it are those of the step that led to this state (filled in by ApplyAndStep).
  hexa_msg_GroundTruth& g = truth_sample_;
  comm::FillHeader(g.header, tick_, t, now_ns);
  const PlatformTrueState& truth = out.truth;
  for (int k = 0; k < 3; ++k) {
    g.position_m[k] = truth.pose.p_BP_B_m[k];
    g.linear_velocity_m_s[k] = truth.twist_B[k];
    g.angular_velocity_rad_s[k] = truth.twist_B[3 + k];
  }
  g.orientation_wxyz[0] = truth.q_BP.w();
  g.orientation_wxyz[1] = truth.q_BP.x();
  g.orientation_wxyz[2] = truth.q_BP.y();
  g.orientation_wxyz[3] = truth.q_BP.z();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    g.leg_length_m[i] = truth.length_m[i];
    g.piston_velocity_m_s[i] = truth.piston_velocity_m_s[i];
    g.cap_pressure_pa[i] = truth.legs[i].chamber1_pressure_pa;
    g.rod_pressure_pa[i] = truth.legs[i].chamber2_pressure_pa;
    g.spool_position_m[i] = truth.legs[i].spool_m;
    g.applied_valve_v[i] = truth.applied_valve_v[i];
  }
  truth_writer_.Write(g, now_ns);
  if (out.tracker.fresh) {  // external instrument (calibration only), 100 Hz when on
    hexa_msg_TrackerPose tp{};
    comm::FillHeader(tp.header, tick_, t, now_ns);
    for (int k = 0; k < 3; ++k) tp.position_m[k] = out.tracker.p_BP_B_m[k];
    tp.orientation_wxyz[0] = out.tracker.q_BP.w();
    tp.orientation_wxyz[1] = out.tracker.q_BP.x();
    tp.orientation_wxyz[2] = out.tracker.q_BP.y();
    tp.orientation_wxyz[3] = out.tracker.q_BP.z();
    tracker_writer_.Write(tp, now_ns);
  }
}

void PlantNode::ReaskSupervisor() {
  // A leg cannot answer tick n > 0 without the setpoint of tick s(n) (core
  // lockstep_protocol.hpp). If the supervisor lost its inputs of s(n), or a leg lost the
  // setpoint, only the supervisor can repair it: it computes a tick it has not seen, and
  // answers a repeated one by re-publishing that tick's setpoints. Readers that already have
  // these samples (the recorder) count them as duplicates, not as loss.
  // Only the first tick of each setpoint's span can lack it: a leg that answered tick
  // s(n) + 1 had the setpoint of s(n).
  std::uint64_t setpoint_tick = 0;
  if (!options_.expect_supervisor || !supervisor_inputs_valid_ ||
      !RequiredSetpointTick(tick_, schedule_.supervisor_every_ticks, setpoint_tick) ||
      tick_ != setpoint_tick + 1 || supervisor_imu_.header.tick != setpoint_tick)
    return;
  const int64_t now_ns = comm::RealtimeNow_ns();
  for (const hexa_msg_LegSensors& s : supervisor_sensors_)
    sensors_writer_.all().WriteDeferred(s, now_ns);
  sensors_writer_.all().Flush();
  imu_writer_.Write(supervisor_imu_, now_ns);
  ++supervisor_reasks_;
}

void PlantNode::TakeCommands(bool feed_barrier) {
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    auto& reader = valve_readers_.leg(leg);
    while (reader.Take() > 0) {
      for (std::size_t k = 0; k < reader.count(); ++k) {
        if (!reader.info(k).valid_data) continue;
        const auto& c = reader.sample(k);
        const dds_sample_info_t& info = reader.info(k);
        // Only the session's own controllers command a valve (docs/faults.md, "Foreign
        // commands"): an unauthenticated sample is refused and its writer reported.
        const comm::CommandTrust trust = reader.Authenticate(k);
        if (!comm::Trusted(trust)) {
          refusals_.Refuse(reader.get(), info, trust, "ValveCommand", static_cast<uint8_t>(leg),
                           tick_, faults_, *log_);
          continue;
        }
        if (c.leg_id != leg) {  // a writer of leg `leg`'s partition wrote another leg's key
          RejectCommand(leg, c, info);
          continue;
        }
        // The reader's ownership: the live primary's samples, else the live standby's.
        const comm::StatusCounters& status = reader.status();
        const auto liveliness = [&status](std::uint64_t writer) {
          return SourceLivelinessOf(status.LivelinessOf(writer));
        };
        if (sources_[static_cast<std::size_t>(leg - 1)].Offer(info.publication_handle, c.standby,
                                                              {c.header.tick, c.valve_v}, liveliness) !=
            CommandSourceSelector::Verdict::kApply)
          continue;
        // The applying writer's compute time, older answers included: a slow primary's answers
        // are older than its standby's, and they are what shows it is slow.
        MonitorCompute(c, info.publication_handle);
        LatestCommand& latest = latest_[c.leg_id - 1];
        if (latest.received && c.header.tick < latest.answered_tick) continue;  // older
        latest = LatestCommand{true, c.header.tick, c.valve_v};
        if (feed_barrier) barrier_.Answer(c.leg_id, c.header.tick);
      }
    }
  }
}

void PlantNode::RejectCommand(int reader_leg, const hexa_msg_ValveCommand& c,
                              const dds_sample_info_t& info) {
  // Leg N's partition is granted to leg N's identities only (DDS Security): a sample for
  // another leg from there is an attempt to command that leg. Refused, counted, and logged
  // at the first one and every 1000th (the writer's GUID lookup allocates: not per sample).
  const std::uint64_t n = ++rejected_per_leg_[static_cast<std::size_t>(reader_leg - 1)];
  if (n != 1 && n % 1000 != 0) return;
  log_->warn("REJECTED valve command for leg {} (tick {}, {:.6g} V) from a writer in partition "
             "{} [{}]: only leg {}'s identities may write there; {} rejected so far",
             static_cast<int>(c.leg_id), c.header.tick, c.valve_v, comm::LegPartition(reader_leg),
             valve_readers_.leg(reader_leg).DescribeWriter(info.publication_handle), reader_leg, n);
}

void PlantNode::MonitorCompute(const hexa_msg_ValveCommand& c, dds_instance_handle_t writer) {
  const std::size_t i = c.leg_id - 1u;
  WriterComputeBudgets& m = compute_[i];
  switch (m.Update(writer, c.header.tick, c.compute_time_s, options_.compute_budget)) {
    case ComputeBudgetMonitor::Event::kStarted: {
      char detail[160];
      std::snprintf(detail, sizeof detail, "compute time over the %.3f ms budget for %llu cycles "
                    "in a row (up to %.3f ms, tick %llu): the controller cannot keep 1 kHz",
                    options_.compute_budget.budget_s * 1e3,
                    static_cast<unsigned long long>(options_.compute_budget.overrun_limit),
                    m.last_run_max_s() * 1e3, static_cast<unsigned long long>(c.header.tick));
      faults_.Publish(c.leg_id, tick_, hexa_msg_FAULT_COMPUTE_OVERRUN, detail);
      log_->warn("leg {} tick {}: {}", c.leg_id, tick_, detail);
      break;
    }
    case ComputeBudgetMonitor::Event::kEnded:
      log_->info("leg {} tick {}: compute time within budget again", c.leg_id, tick_);
      break;
    case ComputeBudgetMonitor::Event::kNone: break;
  }
}

void PlantNode::MarkLegDead(int leg, hexa_msg_FaultReason reason, const char* detail) {
  const std::size_t i = static_cast<std::size_t>(leg - 1);
  link_dead_[i] = true;
  forced_reason_[i] = reason;
  faults_.Publish(static_cast<uint8_t>(leg), tick_, reason, detail);
  log_->error("leg {} tick {}: {}", leg, tick_, detail);
}

SilentLegFacts PlantNode::LegFacts(int leg) {
  const std::size_t i = static_cast<std::size_t>(leg - 1);
  SilentLegFacts f;
  f.writers = writers_.Counts(leg);
  auto add = [&](const std::string& name) {
    if (peer_processes_.Known(name)) {
      ++f.processes;
      if (peer_processes_.State(name) == node::PeerProcessState::kEnded) ++f.processes_ended;
    }
    // The controller's main thread says its cycle is stuck (leg_node: ControlCycleWatch).
    if (peers_.StateOf(name) == hexa_msg_NODE_FAULT) ++f.processes_stuck;
  };
  add(leg_name_[i]);
  if (options_.expect_standbys) add(standby_name_[i]);
  return f;
}

void PlantNode::JudgeSilentLegs(std::int64_t now_ns) {
  // Lockstep: facts about the legs' processes, never the wall clock alone
  // (JudgeSilentLegLockstep). A leg that is slow, stopped or not scheduled is waited for; the
  // lockstep timeout stays the last resort.
  // A tick normally completes within a millisecond: the processes are looked at (which reads
  // /proc and NodeStatus under the loop's lock) only once it has waited a few.
  const std::int64_t silent_ns = now_ns - barrier_.began_ns();
  if (barrier_.complete() || silent_ns < 5'000'000) return;
  writers_.Refresh(valve_readers_);
  peers_.Poll();
  LegMask dead = 0;
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    if (!(barrier_.missing() & LegBit(leg))) continue;
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    const SilentLegFacts f = LegFacts(leg);
    const SilentLegVerdict v = JudgeSilentLegLockstep(f);
    if (v == SilentLegVerdict::kWait) {
      if (f.writers.alive == 0 && lapse_waited_tick_[i] != tick_ + 1) {
        ++lapses_waited_;
        if (lapse_waited_tick_[i] == 0)
          log_->warn("tick {}: leg {}'s lease lapsed ({}): not a fault in lockstep, the plant "
                     "waits for it (logged once per leg, counted)", tick_, leg,
                     peer_processes_.Known(leg_name_[i]) ? peer_processes_.Describe(leg_name_[i])
                                                         : "process not known on this host");
        lapse_waited_tick_[i] = tick_ + 1;
      }
      continue;
    }
    dead |= LegBit(leg);
    char detail[160];
    if (v == SilentLegVerdict::kLivelinessLost) {
      std::snprintf(detail, sizeof detail, "liveliness lost: no answer to tick %llu; %s",
                    static_cast<unsigned long long>(tick_), peers_.DetailOf(leg_name_[i]).c_str());
    } else {
      std::snprintf(detail, sizeof detail, "%s: no answer to tick %llu for %.0f ms (writers: %d "
                    "alive, %d not alive, %d gone; processes ended %d of %d): no longer "
                    "awaited, valve held at null", ToString(v), static_cast<unsigned long long>(tick_),
                    static_cast<double>(silent_ns) * 1e-6, f.writers.alive, f.writers.not_alive,
                    f.writers.gone, f.processes_ended, f.processes);
    }
    MarkLegDead(leg, WireReason(v), detail);
    gone_reported_[i] = v != SilentLegVerdict::kLivelinessLost;
  }
  if (dead == 0) return;
  dropped_ |= dead;
  barrier_.Release(dead);
  AdvanceIfComplete();
}

std::int64_t PlantNode::CommandAge(std::size_t i) const {
  const LatestCommand& latest = latest_[i];
  return latest.received ? static_cast<std::int64_t>(tick_) - static_cast<std::int64_t>(latest.answered_tick)
                         : -1;
}

void PlantNode::CheckLinksRealtime() {
  // Real time: a leg without a live writer is held at null from this tick (its last commands
  // come from a controller whose loop no longer runs) and reported once (ApplyAndStep); it is
  // released after a writer has been alive for 100 ticks in a row (a flickering lease stays
  // one episode). A lapse while the leg's commands are still fresh (newer than the lease; after
  // a slip of the plant's schedule, than the stale-command tolerance) is the host delaying the
  // renewal, not the leg (RealtimeLapseMeansDead): it is counted and judged again next tick. Every awaited leg dead at once is the host (ApplyAndStep), not six
  // controllers.
  for (int leg = 1; leg <= options_.expected_legs; ++leg) {
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    const LegWriterCounts c = writers_.Counts(leg);
    if (c.alive > 0) link_armed_[i] = true;
    if (!link_armed_[i]) continue;  // no command yet: the start-up grace covers it
    if (c.alive == 0) {
      link_alive_run_[i] = 0;
      if (!link_dead_[i]) {
        const std::int64_t age = CommandAge(i);
        // After a slip of the plant's schedule the controllers on the same host catch up
        // over a few ticks: their answers count as fresh for the stale-command tolerance.
        const std::int64_t confirm =
            tick_ <= slip_recent_until_tick_
                ? std::max(lapse_confirm_ticks_, static_cast<std::int64_t>(options_.realtime_stale_ticks))
                : lapse_confirm_ticks_;
        if (!RealtimeLapseMeansDead(c, age, confirm)) {
          // The leg's commands are fresh: the host delayed the lease renewal (counted).
          if (!lapse_while_fresh_[i]) ++lapses_while_fresh_;
          lapse_while_fresh_[i] = true;
          continue;
        }
        link_dead_[i] = true;
        forced_reason_[i] = WireReason(JudgeSilentLeg(c));
      }
    } else {
      lapse_while_fresh_[i] = false;
      if (link_dead_[i] && ++link_alive_run_[i] >= 100) {
        link_dead_[i] = false;
        forced_reason_[i] = interlock_[i] ? hexa_msg_FAULT_SENSOR_INCONSISTENT : hexa_msg_FAULT_NONE;
        log_->info("leg {} tick {}: a writer has been alive for 100 ticks: valve released", leg, tick_);
      }
    }
  }
}

void PlantNode::ReportGoneWriters() {
  // A leg declared dead because its lease lapsed is reported again, once, when its writers
  // are gone too: the process (or its participant) no longer exists - a crash, not a hang.
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
    const std::size_t i = static_cast<std::size_t>(leg - 1);
    if (!link_dead_[i] || gone_reported_[i]) continue;
    const LegWriterCounts c = writers_.Counts(leg);
    if (c.alive != 0 || c.not_alive != 0) continue;
    gone_reported_[i] = true;
    char detail[160];
    std::snprintf(detail, sizeof detail, "writer gone: the controller's writer (%d) no longer "
                  "exists: its process ended or its participant's lease expired", c.gone);
    faults_.Publish(static_cast<uint8_t>(leg), tick_, hexa_msg_FAULT_WRITER_GONE, detail);
    log_->error("leg {} tick {}: {}", leg, tick_, detail);
  }
}

void PlantNode::TakeFaultEvents() {
  // Polled, never a data callback: this process writes FaultEvents while holding mutex_, and
  // Cyclone may deliver to a local reader's callback inside that write (self-deadlock).
  while (fault_reader_.Take() > 0) {
    for (std::size_t k = 0; k < fault_reader_.count(); ++k) {
      if (!fault_reader_.info(k).valid_data) continue;
      const hexa_msg_FaultEvent& f = fault_reader_.sample(k);
      if (f.reason != hexa_msg_FAULT_SENSOR_INCONSISTENT || f.leg_id < 1 || f.leg_id > kNumLegs)
        continue;
      const std::size_t i = f.leg_id - 1u;
      if (interlock_[i]) continue;
      // The leg's length reading is wrong: its controller drives the leg on a false length
      // (a stuck potentiometer runs it into its end stop). Close its valve, for good.
      interlock_[i] = true;
      if (forced_reason_[i] == hexa_msg_FAULT_NONE) forced_reason_[i] = hexa_msg_FAULT_SENSOR_INCONSISTENT;
      log_->error("leg {} tick {}: {} reports its length inconsistent: valve held at null from "
                  "now on", f.leg_id, tick_, f.source_node);
    }
  }
}

bool PlantNode::ApplyAndStep(std::uint64_t stale_tolerance) {
  hygiene_.stale_tolerance_ticks = stale_tolerance;
  LegArray<double> valve_v{};
  LegArray<CommandCheck> checks{};
  LegArray<bool> forced{};
  int stale_legs = 0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LatestCommand& latest = latest_[i];
    const std::int64_t age = CommandAge(i);
    command_age_[i].Add(age);
    truth_sample_.command_age_ticks[i] = static_cast<int32_t>(std::clamp<std::int64_t>(age, -1, INT32_MAX));
    checks[i] = CheckCommand(latest, tick_, hygiene_);
    valve_v[i] = SafeValveVoltage(latest, checks[i], hygiene_);
    // A dead leg (no live writer; lockstep: no longer awaited) or one whose length reading
    // the supervisor found wrong: valve at null whatever its last command says.
    forced[i] = link_dead_[i] || interlock_[i];
    if (forced[i]) {
      valve_v[i] = hygiene_.null_voltage_v;
      if (!IsCommandFault(checks[i])) checks[i] = CommandCheck::kMissing;  // keeps the episode open
    }
    if (static_cast<int>(i) < options_.expected_legs &&
        (checks[i] == CommandCheck::kStale || link_dead_[i]))
      ++stale_legs;
  }
  // Every awaited leg stale (or without a live writer) in the same tick is not six controller
  // faults: the host did not run the loop (the plant's own wake-ups, the legs or the network
  // were descheduled). Say that once, with the measured lateness, instead of six leg faults.
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  const bool overload = realtime && options_.expected_legs > 1 && stale_legs == options_.expected_legs;
  if (overload && !host_overload_reported_) {
    host_overload_reported_ = true;
    std::uint64_t newest = 0;
    for (int i = 0; i < options_.expected_legs; ++i)
      newest = std::max(newest, latest_[static_cast<std::size_t>(i)].answered_tick);
    char detail[160];
    std::snprintf(detail, sizeof detail,
                  "host overload: all %d legs' commands late at tick %llu (newest answers tick "
                  "%llu); plant wake-up late by up to %.1f ms: the host does not keep 1 ms",
                  options_.expected_legs, static_cast<unsigned long long>(tick_),
                  static_cast<unsigned long long>(newest), tick_wall_.max_s() * 1e3);
    faults_.Publish(0, tick_, hexa_msg_FAULT_HOST_OVERLOAD, detail);
    log_->error("tick {}: {}", tick_, detail);
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandCheck check = checks[i];
    switch (episodes_[i].Update(check)) {
      case CommandEpisode::Event::kStarted: {
        ++faults_per_leg_[i];
        if (overload) break;  // reported once as the host's, above
        char detail[160];
        hexa_msg_FaultReason reason = FaultOf(check);
        if (forced[i] && dropped_ & LegBit(static_cast<int>(i) + 1)) {
          break;  // lockstep: reported when the leg was judged dead (JudgeSilentLegs)
        } else if (forced[i] && link_dead_[i]) {
          reason = forced_reason_[i];
          std::snprintf(detail, sizeof detail, "%s: no live writer of the leg's valve commands "
                        "(last answer: tick %llu): valve held at null",
                        reason == hexa_msg_FAULT_WRITER_GONE ? "writer gone" : "liveliness lost",
                        static_cast<unsigned long long>(latest_[i].answered_tick));
          gone_reported_[i] = reason == hexa_msg_FAULT_WRITER_GONE;
        } else if (forced[i]) {
          break;  // the interlock: the supervisor reported it (TakeFaultEvents)
        } else {
          std::snprintf(detail, sizeof detail, "valve command %s (%.6g V, answers tick %llu): valve held at null",
                        ToString(check), latest_[i].valve_v,
                        static_cast<unsigned long long>(latest_[i].answered_tick));
        }
        faults_.Publish(static_cast<uint8_t>(i + 1), tick_, reason, detail);
        log_->warn("leg {} tick {}: {}", i + 1, tick_, detail);
        break;
      }
      case CommandEpisode::Event::kEnded:
        log_->info("leg {} tick {}: valve commands valid again ({} faulty ticks in the episode)",
                   i + 1, tick_, episodes_[i].fault_ticks());
        break;
      case CommandEpisode::Event::kNone: break;
    }
  }
  plant_.Step(valve_v, kTickS);
  if (plant_.output().status != PlantStatus::kNonFiniteState) return true;
  faults_.Publish(0, tick_, hexa_msg_FAULT_STATE_NOT_FINITE, "plant state not finite: stopped");
  log_->error("plant state became non-finite at tick {}: stopping", tick_);
  LogLastGoodState();
  PublishStatus(hexa_msg_NODE_FAULT, "state not finite");
  return false;
}

void PlantNode::EndTick() {
  ++tick_;
  if (tick_ % 100 != 0) return;
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  PublishStatus(hexa_msg_NODE_RUNNING, realtime ? "real time" : "lockstep");
  // A fault episode still in effect is repeated at the status rate (one event per leg per
  // 100 ticks, whatever the command does meanwhile), so that a supervisor reset while the
  // cause persists sees the fault again.
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!episodes_[i].active()) continue;
    const bool forced = link_dead_[i] || interlock_[i];
    char detail[160];
    std::snprintf(detail, sizeof detail, "valve command still %s (%llu faulty ticks): valve held at null",
                  forced ? "forced to null" : ToString(episodes_[i].latest()),
                  static_cast<unsigned long long>(episodes_[i].fault_ticks()));
    faults_.Publish(static_cast<uint8_t>(i + 1), tick_,
                    forced ? forced_reason_[i] : FaultOf(episodes_[i].latest()), detail);
  }
}

void PlantNode::OnValveData(void* self) {
  auto* node = static_cast<PlantNode*>(self);
  std::lock_guard<std::mutex> lock(node->mutex_);
  node->TakeCommands(true);
  node->AdvanceIfComplete();
}

void PlantNode::AdvanceIfComplete() {
  // Lockstep: every awaited leg answered tick_ -> step, publish tick_ + 1 and await it. While
  // a recorder sync is pending, tick_ is not published yet and the barrier still holds the
  // previous (complete) tick: nothing may advance.
  while (running_ && !sync_pending_ && barrier_.complete()) {
    const int64_t now = node::MonotonicNow_ns();
    cycle_times_.Add(static_cast<double>(now - tick_started_ns_) * 1e-9);
    tick_wall_.Add(now - tick_started_ns_);
    if (!ApplyAndStep(0)) {
      exit_code_ = 4;
    } else {
      EndTick();
      if (tick_ >= last_tick_) exit_code_ = 0;
    }
    if (exit_code_ >= 0) {
      running_ = false;
      wake_.Set();
      return;
    }
    if (options_.expect_recorder && options_.recorder_sync_ticks > 0 &&
        tick_ % options_.recorder_sync_ticks == 0) {
      if (!ack_wait_requested_ && !ack_wait_active_) {
        // The main thread waits for the acknowledgements (they arrive on this thread) while
        // the loop goes on.
        ack_wait_requested_ = true;
        ack_wait_tick_ = tick_;
        wake_.Set();
      } else if (!sync_suspended_ && tick_ - ack_wait_tick_ >= options_.recorder_sync_window_ticks) {
        // The wait begun at ack_wait_tick_ has not ended: the recorder is that far behind.
        // The main thread publishes tick_ when it ends.
        sync_pending_ = true;
        sync_blocked_since_ns_ = now;
        ++recorder_sync_blocks_;
        wake_.Set();
        return;
      }
    }
    StartTick(now);
  }
}

void PlantNode::StartTick(int64_t now_ns) {
  tick_started_ns_ = now_ns;
  supervisor_reask_.Begin(now_ns);
  PublishTick();
  barrier_.Begin(tick_, static_cast<LegMask>(FirstLegs(options_.expected_legs) & ~dropped_), now_ns);
  TakeCommands(true);  // answers that came in with this callback's data
}

void PlantNode::WatchSilence(dds_duration_t& wait) {
  TakeFaultEvents();
  ReportGoneWriters();
  const int64_t now = node::MonotonicNow_ns();
  JudgeSilentLegs(now);
  if (exit_code_ >= 0) return;
  switch (barrier_.Check(now)) {
    case LockstepBarrier::Action::kWait:
      wait = std::clamp<dds_duration_t>(barrier_.next_check_ns() - now, DDS_MSECS(1), DDS_MSECS(10));
      break;
    case LockstepBarrier::Action::kReask:
      // A sample can be lost to a reader that had not yet matched this writer, or to an
      // ownership hand-over (hot standby): ask the silent legs again for this tick. Leg
      // controllers answer a repeated tick with their cached command.
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
        if (barrier_.missing() & LegBit(leg)) {
          PublishTick(leg);
          ++resent_samples_;
        }
      if (supervisor_reask_.Due(now)) ReaskSupervisor();
      break;
    case LockstepBarrier::Action::kTimeout: {
      std::string states;
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
        if (barrier_.missing() & LegBit(leg))
          states += "; " + peer_processes_.Describe(leg_name_[static_cast<std::size_t>(leg - 1)]);
      if (options_.expect_supervisor) states += "; " + peer_processes_.Describe("supervisor");
      log_->error("lockstep: tick {} not answered within {} s (the last resort) by:{}{}", tick_,
                  options_.common.lockstep_timeout_s, LegList(barrier_.missing()), states);
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
        if (!(barrier_.missing() & LegBit(leg))) continue;
        char detail[160];
        std::snprintf(detail, sizeof detail, "lockstep: no command for tick %llu within %.1f s",
                      static_cast<unsigned long long>(tick_), options_.common.lockstep_timeout_s);
        faults_.Publish(static_cast<uint8_t>(leg), tick_,
                        hexa_msg_FAULT_COMMAND_DEADLINE_MISSED, detail);
      }
      exit_code_ = 3;
      running_ = false;
      break;
    }
  }
}

int PlantNode::RunLockstep(std::uint64_t last_tick) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_tick_ = last_tick;
    running_ = true;
    // The callback first, then tick 0: an answer can never arrive unseen.
    valve_readers_.OnDataAvailable(&PlantNode::OnValveData, this);
    StartTick(node::MonotonicNow_ns());
    AdvanceIfComplete();
  }
  waitset_.Detach(peers_.data_condition());  // NodeStatus traffic must not wake this thread
  // The receive thread runs the loop; this thread watches for silence and shutdown, and
  // keeps the loop within recorder_sync_ticks of the recorder. Every 10 ms at most it judges
  // the legs the tick still awaits (a dead one is no longer awaited: the detection bound is
  // the liveliness lease + 10 ms, docs/faults.md), takes the supervisor's sensor faults and
  // reports writers that are gone.
  while (!shutdown_.requested()) {
    dds_duration_t wait = DDS_MSECS(10);
    bool waiting_for_acks = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (exit_code_ >= 0) break;
      if (ack_wait_requested_) {
        ack_wait_requested_ = false;
        ack_wait_active_ = true;
        wake_.Set(false);
      }
      waiting_for_acks = ack_wait_active_;
    }
    // Everything written so far is in every reliable reader's history (the recorder's too):
    // from then on no sample of it can be lost by a keep-last writer history. The loop writes
    // on meanwhile (Cyclone's writers are thread-safe). Measured: while the loop writes at
    // full speed the acknowledgements do not come (a wait ends ~17 ms after the loop stopped
    // at the window: about two heartbeat intervals, deploy/cyclonedds-loopback.xml). Only the all-legs
    // partition (supervisor, recorder) and the ground truth: a leg controller's lost sample is
    // repaired by the re-ask, and a hung controller never acknowledges. Waited in 10 ms
    // slices, between which this thread watches the legs as when it is idle.
    bool acked = false;
    if (waiting_for_acks) {
      acked = sensors_writer_.all().WaitForAcks(DDS_MSECS(10)) == DDS_RETCODE_OK &&
              truth_writer_.WaitForAcks(DDS_MSECS(10)) == DDS_RETCODE_OK;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      // systemd's watchdog: this thread holds the loop's lock, so the receive thread is not
      // stuck in a tick (a stuck tick keeps the lock and the pings stop).
      node::service_manager::Watchdog();
      if (exit_code_ >= 0) break;
      const int64_t now = node::MonotonicNow_ns();
      bool resume = false;
      if (waiting_for_acks && acked) {
        ack_wait_active_ = false;
        ++recorder_syncs_;
        if (sync_suspended_) log_->info("tick {}: recorder sync acknowledged again", tick_);
        sync_suspended_ = false;
        resume = sync_pending_;
      } else if (waiting_for_acks && sync_pending_ && SyncGiveUpDue(now - sync_blocked_since_ns_)) {
        // A reader does not acknowledge (a dead supervisor or recorder, until discovery
        // drops it): the control loop must not stand still for it.
        sync_suspended_ = true;
        ++recorder_syncs_given_up_;
        log_->warn("tick {}: a reliable reader has not acknowledged for {:.1f} s ({}; {}): "
                   "recorder sync given up, the loop runs on (counted, logged per episode)",
                   tick_, static_cast<double>(now - sync_blocked_since_ns_) * 1e-9,
                   peer_processes_.Describe("recorder"), peer_processes_.Describe("supervisor"));
        resume = true;
      }
      if (resume) {
        sync_pending_ = false;
        recorder_sync_wait_s_ += static_cast<double>(now - sync_blocked_since_ns_) * 1e-9;
        if (running_) {
          if (!sync_suspended_) {
            ack_wait_requested_ = true;  // the next wait starts at once
            ack_wait_tick_ = tick_;
          }
          StartTick(now);
          AdvanceIfComplete();
        }
      }
      if (options_.expect_supervisor && running_) {
        // The supervisor ends the session (trajectory done, or after holding): no more ticks
        // (the legs wait for setpoints that will not come; that is no fault), until stopped.
        peers_.Poll();
        if (peers_.StateOf("supervisor") == hexa_msg_NODE_STOPPING) {
          running_ = false;
          log_->info("the supervisor ended its run at tick {}: no more ticks", tick_);
        }
      }
      if (!running_) {
        wait = DDS_MSECS(100);  // the run has ended: wait to be stopped
      } else {
        WatchSilence(wait);
        if (exit_code_ >= 0) break;
      }
    }
    if (!waiting_for_acks) waitset_.Wait(wait);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
  }
  // No callback runs after this (it touches members destroyed before the reader).
  valve_readers_.OnDataAvailable(nullptr, nullptr);
  return exit_code_ >= 0 ? exit_code_ : 0;
}

int PlantNode::RunRealtime(std::uint64_t last_tick) {
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  // No data callback in real time: this thread alone touches the loop state. The lock is
  // held for form (uncontended) so that the helpers' contract is the same in both modes.
  std::lock_guard<std::mutex> lock(mutex_);
  while (!shutdown_.requested() && tick_ < last_tick) {
    node::service_manager::Watchdog();
    PublishTick();
    next.tv_nsec += 1'000'000;
    if (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    TakeCommands(false);
    if (tick_ % 10 == 0) TakeFaultEvents();  // the interlock within 10 ms: no take every tick
    CheckLinksRealtime();
    if (tick_ % 100 == 0) {
      writers_.Refresh(valve_readers_);  // a writer that appeared (a restarted controller)
      ReportGoneWriters();
    }
    const int64_t late_ns = node::MonotonicNow_ns() -
                            (static_cast<int64_t>(next.tv_sec) * 1'000'000'000 + next.tv_nsec);
    if (late_ns > 1'000'000) ++overruns_;
    cycle_times_.Add(static_cast<double>(late_ns) * 1e-9);
    tick_wall_.Add(late_ns);
    if (slips_.Record(tick_, late_ns)) {
      // The host stalled this process (and, on one machine, the controllers with it). The
      // simulated rig stops with it: the schedule restarts from now instead of stepping the
      // missed ticks in a burst that no controller could answer (their commands would all
      // look stale: a fault of the simulation, not of the controllers). A real rig does not
      // stop; docs/performance.md says what this hides and how often it happens. Every slip
      // is logged with its tick, so that a lapse can be matched to the stall before it.
      log_->warn("tick {}: the plant woke {:.1f} ms late: its schedule slips (simulated time "
                 "pauses with the host; slip {})", tick_, late_ns * 1e-6, slips_.count());
      slip_recent_until_tick_ = tick_ + options_.realtime_stale_ticks;
      clock_gettime(CLOCK_MONOTONIC, &next);
    }
    if (!ApplyAndStep(options_.realtime_stale_ticks)) return 4;
    EndTick();
  }
  return 0;
}

void PlantNode::LogLastGoodState() const {
  const auto& t = plant_.truth();
  log_->error("last good state at t = {:.3f} s: p = ({:.5f}, {:.5f}, {:.5f}) m, legs P1 = "
              "[{:.0f} {:.0f} {:.0f} {:.0f} {:.0f} {:.0f}] Pa",
              t.time_s, t.pose.p_BP_B_m.x(), t.pose.p_BP_B_m.y(), t.pose.p_BP_B_m.z(),
              t.legs[0].chamber1_pressure_pa, t.legs[1].chamber1_pressure_pa,
              t.legs[2].chamber1_pressure_pa, t.legs[3].chamber1_pressure_pa,
              t.legs[4].chamber1_pressure_pa, t.legs[5].chamber1_pressure_pa);
}

void PlantNode::LogCommandAges() const {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandAgeHistogram& h = command_age_[i];
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
  json::Value j = {{"mode", realtime ? "realtime" : "lockstep"},
                   {"exit_code", exit_code},
                   {"ticks", tick_},
                   {"sim_time_s", static_cast<double>(tick_) * kTickS},
                   {"valve_deadline_misses", valve.requested_deadline_missed_total},
                   {"loop_overruns", overruns_},
                   {"lockstep_resends", resent_samples_},
                   {"schedule_slips", slips_.count()},
                   {"slipped_s", static_cast<double>(slips_.total_ns()) * 1e-9},
                   {"refused_commands", refusals_.samples()},
                   {"refused_writers", refusals_.writers()},
                   {"loop_wall_s", static_cast<double>(loop_ended_ns_ - loop_started_ns_) * 1e-9}};
  j[realtime ? "wake_lateness_s" : "tick_wall_s"] = {{"median", tick_wall_.Quantile_s(0.5)},
                                                     {"p99", tick_wall_.Quantile_s(0.99)},
                                                     {"max", tick_wall_.max_s()},
                                                     {"mean", tick_wall_.mean_s()}};
  j["command_age_bins"] = {"0", "1", "2", "3-7", "8-15", ">=16"};
  j["legs"] = json::Value::array();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandAgeHistogram& h = command_age_[i];
    json::Value ages = json::Value::array();
    for (int k = 0; k < CommandAgeHistogram::kBins; ++k) ages.push_back(h.bins[static_cast<std::size_t>(k)]);
    j["legs"].push_back({{"leg", i + 1},
                         {"command_age", ages},
                         {"no_command", h.none},
                         {"late_ticks", h.late()},
                         {"faults", faults_per_leg_[i]},
                         {"dead", static_cast<bool>(link_dead_[i])},
                         {"forced_reason", static_cast<int>(forced_reason_[i])},
                         {"interlock", static_cast<bool>(interlock_[i])},
                         {"compute_max_s", compute_[i].max_s()},
                         {"compute_over_budget", compute_[i].over_budget()},
                         {"cycles", compute_[i].cycles()}});
  }
  // Every slip's tick (the first ScheduleSlips::kKept), to match a fault to the stall before it.
  j["worst_slip"] = {{"tick", slips_.worst().tick},
                     {"late_s", static_cast<double>(slips_.worst().late_ns) * 1e-9}};
  j["slips"] = json::Value::array();
  for (std::size_t k = 0; k < slips_.kept_count(); ++k)
    j["slips"].push_back({{"tick", slips_.kept(k).tick},
                          {"late_s", static_cast<double>(slips_.kept(k).late_ns) * 1e-9}});
  std::string error;
  if (!json::WriteFile(options_.summary_path, j, 2, error)) log_->error("summary: {}", error);
}

int PlantNode::Run() {
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  if (!WaitForPeers()) {
    PublishStatus(hexa_msg_NODE_FAULT, "peers not ready");
    return shutdown_.requested() ? 0 : 3;
  }
  PublishStatus(hexa_msg_NODE_RUNNING, realtime ? "real time" : "lockstep");
  node::service_manager::Ready(realtime ? "ticking in real time" : "ticking in lockstep");
  log_->info("ticking in {} mode, profile '{}', seed {}", realtime ? "real-time" : "lockstep",
             options_.profile, options_.seed);
  log_->info("dead legs: {}; compute budget {:.3f} ms x {} cycles",
             realtime ? fmt::format("liveliness lease {:.3f} s", options_.common.realtime_lease_s)
                      : fmt::format("lockstep: a process ended ({}), writers gone, or a "
                                    "controller stuck (lease {:.3f} s lapsed and its cycle "
                                    "stuck); last resort {:.1f} s",
                                    peer_processes_.empty()
                                        ? "no process ids given: seen when its participant's "
                                          "lease expires"
                                        : "process ids given by the launcher",
                                    options_.common.lockstep_lease_s,
                                    options_.common.lockstep_timeout_s),
             options_.compute_budget.budget_s * 1e3, options_.compute_budget.overrun_limit);
  for (const PlantFault& f : options_.plant_faults.faults)
    log_->warn("FAULT INJECTION: {} of leg {} at t = {:.3f} s", ToString(f.kind), f.leg, f.at_time_s);
  const uint64_t last_tick = options_.duration_s > 0
                                 ? static_cast<uint64_t>(std::llround(options_.duration_s / kTickS))
                                 : UINT64_MAX;
  loop_started_ns_ = node::MonotonicNow_ns();
  const int rc = realtime ? RunRealtime(last_tick) : RunLockstep(last_tick);
  std::lock_guard<std::mutex> lock(mutex_);
  loop_ended_ns_ = node::MonotonicNow_ns();
  uint32_t faults = 0;
  for (auto f : faults_per_leg_) faults += f;
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
             overruns_, faults, resent_samples_, barrier_.reasks_total(), supervisor_reasks_,
             sensors_writer_.write_errors_total(), recorder_syncs_, recorder_sync_blocks_,
             recorder_sync_wait_s_, recorder_syncs_given_up_, slips_.count(),
             static_cast<double>(slips_.total_ns()) * 1e-6, lapses_waited_, lapses_while_fresh_, rejected,
             refusals_.samples(), refusals_.writers(), writers_.Describe());
  if (slips_.count() > 0) {
    std::string ticks;
    for (std::size_t k = 0; k < slips_.kept_count(); ++k)
      ticks += fmt::format("{}{} ({:.1f} ms)", k == 0 ? "" : ", ", slips_.kept(k).tick,
                           static_cast<double>(slips_.kept(k).late_ns) * 1e-6);
    log_->info("schedule slips (wake-ups more than {:.1f} ms late): {}, worst {:.1f} ms at tick {}; "
               "ticks{}: {}", static_cast<double>(slips_.threshold_ns()) * 1e-6, slips_.count(),
               static_cast<double>(slips_.worst().late_ns) * 1e-6, slips_.worst().tick,
               slips_.count() > slips_.kept_count() ? " (the first ones)" : "", ticks);
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (compute_[i].cycles() == 0) continue;
    log_->info("leg {} compute time: max {:.3f} ms, {} of {} cycles over the {:.3f} ms budget",
               i + 1, compute_[i].max_s() * 1e3, compute_[i].over_budget(), compute_[i].cycles(),
               options_.compute_budget.budget_s * 1e3);
  }
  LogCommandAges();
  WriteSummary(rc);
  if (rc != 4) PublishStatus(hexa_msg_NODE_STOPPING, "stopped");
  node::service_manager::Stopping("stopped");
  return rc;
}

}  // namespace hexa::plant_sim
