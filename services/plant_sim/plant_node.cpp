#include "plant_node.hpp"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace hexa::plant_sim {
namespace {

constexpr double kTickS = 0.001;
constexpr int kImuEveryTicks = 5;
constexpr dds_attach_t kTokenShutdown = 1;
constexpr dds_attach_t kTokenValve = 2;
constexpr dds_attach_t kTokenSetpoint = 3;
constexpr dds_attach_t kTokenPeers = 4;

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
  return p;
}

}  // namespace

PlantNode::PlantNode(const PlantNodeOptions& options, const config::SystemConfig& config,
                     std::shared_ptr<spdlog::logger> log)
    : options_(options),
      config_(config),
      log_(std::move(log)),
      plant_(MakePlantConfig(options, config)),
      hygiene_(CommandHygieneParams::FromValve(config.rig.valve, 0)),
      participant_(static_cast<dds_domainid_t>(options.common.domain_id)),
      shutdown_(participant_),
      sensors_topic_(participant_),
      imu_topic_(participant_),
      truth_topic_(participant_),
      valve_topic_(participant_),
      setpoint_topic_(participant_),
      sensors_writer_(participant_, sensors_topic_,
                      node::QosFor(options.common, comm::TopicKind::kLegSensors)),
      imu_writer_(participant_, imu_topic_, node::QosFor(options.common, comm::TopicKind::kImuSample)),
      truth_writer_(participant_, truth_topic_,
                    node::QosFor(options.common, comm::TopicKind::kGroundTruth)),
      valve_reader_(participant_, valve_topic_, comm::EndpointRole::kControlReader,
                    node::QosFor(options.common, comm::TopicKind::kValveCommand), 64),
      setpoint_reader_(participant_, setpoint_topic_, comm::EndpointRole::kControlReader,
                       node::QosFor(options.common, comm::TopicKind::kLegSetpoint), 64),
      status_(participant_, "plant"),
      faults_(participant_, "plant"),
      peers_(participant_),
      waitset_(participant_) {
  waitset_.Attach(shutdown_.guard_condition(), kTokenShutdown);
  waitset_.Attach(valve_reader_.data_condition(), kTokenValve);
  waitset_.Attach(setpoint_reader_.data_condition(), kTokenSetpoint);
  waitset_.Attach(peers_.data_condition(), kTokenPeers);
  last_check_.fill(CommandCheck::kOk);
}

void PlantNode::PublishStatus(hexa_msg_NodeState state, const char* detail) {
  const auto valve = valve_reader_.Snapshot();
  status_.Publish(state, tick_, static_cast<double>(tick_) * kTickS,
                  valve.requested_deadline_missed_total + overruns_,
                  valve.liveliness_changed_events, cycle_times_.total(), cycle_times_.Median(),
                  cycle_times_.Max(), detail);
}

bool PlantNode::WaitForPeers() {
  std::vector<std::string> expected;
  for (int leg = 1; leg <= options_.expected_legs; ++leg) expected.push_back("leg" + std::to_string(leg));
  if (options_.expect_supervisor) expected.push_back("supervisor");
  if (options_.expect_recorder) expected.push_back("recorder");
  // Sensor readers: each leg controller (its own filtered reader), the supervisor, the
  // recorder. Valve writers: one per leg controller.
  const uint32_t sensor_readers = static_cast<uint32_t>(options_.expected_legs) +
                                  (options_.expect_supervisor ? 1u : 0u) +
                                  (options_.expect_recorder ? 1u : 0u);
  const uint32_t valve_writers = static_cast<uint32_t>(options_.expected_legs);
  PublishStatus(hexa_msg_NODE_STARTING, "waiting for peers");
  const int64_t end = node::MonotonicNow_ns() + static_cast<int64_t>(options_.startup_timeout_s * 1e9);
  int64_t next_log = node::MonotonicNow_ns() + 2'000'000'000;
  while (!shutdown_.requested()) {
    peers_.Poll();
    const auto missing = peers_.NotRunning(expected);
    const auto sensors = sensors_writer_.Snapshot().publication_matched_current;
    const auto valves = valve_reader_.Snapshot().subscription_matched_current;
    if (missing.empty() && sensors >= sensor_readers && valves >= valve_writers) {
      log_->info("all peers ready: {} sensor readers, {} valve writers", sensors, valves);
      return true;
    }
    const int64_t now = node::MonotonicNow_ns();
    if (now > end) {
      std::string names;
      for (const auto& m : missing) names += " " + m;
      log_->error("peers not ready after {} s: not running:{}; sensor readers {}/{}, valve "
                  "writers {}/{}", options_.startup_timeout_s, names.empty() ? " none" : names,
                  sensors, sensor_readers, valves, valve_writers);
      return false;
    }
    if (now > next_log) {
      log_->info("waiting for peers ({} not running, sensor readers {}/{}, valve writers {}/{})",
                 missing.size(), sensors, sensor_readers, valves, valve_writers);
      next_log = now + 2'000'000'000;
    }
    // Wakes on NodeStatus data or shutdown; the timeout re-checks the match counts, which
    // change without data.
    waitset_.Wait(DDS_MSECS(50));
  }
  return false;
}

void PlantNode::PublishSensors(bool with_imu_and_truth, int only_leg) {
  const PlatformPlantOutput& out = plant_.output();
  const double t = static_cast<double>(tick_) * kTickS;
  const int64_t now_ns = comm::RealtimeNow_ns();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (only_leg != 0 && static_cast<int>(i) + 1 != only_leg) continue;
    hexa_msg_LegSensors s{};
    s.leg_id = static_cast<uint8_t>(i + 1);
    comm::FillHeader(s.header, tick_, t, now_ns);
    s.length_m = out.legs[i].length_m;
    s.cap_pressure_pa = out.legs[i].chamber1_pressure_pa;
    s.rod_pressure_pa = out.legs[i].chamber2_pressure_pa;
    s.supply_pressure_pa = out.legs[i].supply_pressure_pa;
    sensors_writer_.Write(s, now_ns);
  }
  if (!with_imu_and_truth) return;
  if (tick_ % kImuEveryTicks == 0) {
    hexa_msg_ImuSample imu{};
    comm::FillHeader(imu.header, tick_, t, now_ns);
    const auto& q = out.imu.q_BP_measured;
    imu.orientation_wxyz[0] = q.w();
    imu.orientation_wxyz[1] = q.x();
    imu.orientation_wxyz[2] = q.y();
    imu.orientation_wxyz[3] = q.z();
    for (int k = 0; k < 3; ++k) imu.angular_rate_rad_s[k] = out.imu.angular_rate_B_rad_s[k];
    imu_writer_.Write(imu, now_ns);
  }
  hexa_msg_GroundTruth g{};
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
}

void PlantNode::TakeCommands() {
  while (valve_reader_.Take() > 0) {
    for (std::size_t k = 0; k < valve_reader_.count(); ++k) {
      if (!valve_reader_.info(k).valid_data) continue;
      const auto& c = valve_reader_.sample(k);
      if (c.leg_id < 1 || c.leg_id > kNumLegs) continue;
      LatestCommand& latest = latest_[c.leg_id - 1];
      if (latest.received && c.header.tick < latest.answered_tick) continue;  // older
      latest = LatestCommand{true, c.header.tick, c.valve_v};
    }
  }
}

void PlantNode::TakeSetpoints() {
  while (setpoint_reader_.Take() > 0) {
    for (std::size_t k = 0; k < setpoint_reader_.count(); ++k) {
      if (!setpoint_reader_.info(k).valid_data) continue;
      const auto& s = setpoint_reader_.sample(k);
      if (s.leg_id < 1 || s.leg_id > kNumLegs) continue;
      const std::size_t i = s.leg_id - 1;
      if (!setpoint_seen_[i] || s.header.tick > setpoint_tick_[i]) setpoint_tick_[i] = s.header.tick;
      setpoint_seen_[i] = true;
    }
  }
}

bool PlantNode::LockstepCollect() {
  const bool need_setpoints = options_.expect_supervisor && tick_ % kImuEveryTicks == 0;
  const int64_t start = node::MonotonicNow_ns();
  const int64_t resend_ns = static_cast<int64_t>(options_.resend_after_s * 1e9);
  int64_t next_resend = start + resend_ns;
  const int64_t end = start + static_cast<int64_t>(options_.common.lockstep_timeout_s * 1e9);
  while (!shutdown_.requested()) {
    TakeCommands();
    if (need_setpoints) TakeSetpoints();
    bool complete = true;
    for (int i = 0; i < options_.expected_legs; ++i) {
      if (!latest_[i].received || latest_[i].answered_tick < tick_) complete = false;
      if (need_setpoints && (!setpoint_seen_[i] || setpoint_tick_[i] < tick_)) complete = false;
    }
    if (complete) return true;
    const int64_t now = node::MonotonicNow_ns();
    if (now > end) {
      std::string missing;
      for (int i = 0; i < options_.expected_legs; ++i) {
        if (!latest_[i].received || latest_[i].answered_tick < tick_)
          missing += " leg" + std::to_string(i + 1) + "(command)";
        if (need_setpoints && (!setpoint_seen_[i] || setpoint_tick_[i] < tick_))
          missing += " leg" + std::to_string(i + 1) + "(setpoint)";
      }
      log_->error("lockstep: tick {} not answered within {} s by:{}", tick_,
                  options_.common.lockstep_timeout_s, missing);
      for (int i = 0; i < options_.expected_legs; ++i) {
        if (!latest_[i].received || latest_[i].answered_tick < tick_) {
          char detail[160];
          std::snprintf(detail, sizeof detail, "lockstep: no command for tick %llu within %.1f s",
                        static_cast<unsigned long long>(tick_), options_.common.lockstep_timeout_s);
          faults_.Publish(static_cast<uint8_t>(i + 1), tick_,
                          hexa_msg_FAULT_COMMAND_DEADLINE_MISSED, detail);
        }
      }
      return false;
    }
    if (now > next_resend) {
      // A sample can be lost to a reader that had not yet matched this writer, or to an
      // ownership hand-over (hot standby): ask the silent legs again for this tick. Leg
      // controllers answer a repeated tick with their cached command.
      for (int i = 0; i < options_.expected_legs; ++i) {
        if (!latest_[i].received || latest_[i].answered_tick < tick_) {
          PublishSensors(false, i + 1);
          ++resends_;
        }
      }
      next_resend = now + resend_ns;
    }
    waitset_.Wait(DDS_MSECS(10));
  }
  return false;
}

void PlantNode::ApplyAndStep(std::uint64_t stale_tolerance) {
  hygiene_.stale_tolerance_ticks = stale_tolerance;
  LegArray<double> valve_v{};
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const CommandCheck check = CheckCommand(latest_[i], tick_, hygiene_);
    valve_v[i] = SafeValveVoltage(latest_[i], check, hygiene_);
    if (check != last_check_[i]) {
      if (check == CommandCheck::kAwaitingFirst) {
        // Start-up: the controller has not had its tolerance to answer yet.
      } else if (check != CommandCheck::kOk) {
        char detail[160];
        std::snprintf(detail, sizeof detail, "valve command %s (%.6g V, answers tick %llu): valve held at null",
                      ToString(check), latest_[i].valve_v,
                      static_cast<unsigned long long>(latest_[i].answered_tick));
        faults_.Publish(static_cast<uint8_t>(i + 1), tick_, FaultOf(check), detail);
        log_->warn("leg {} tick {}: {}", i + 1, tick_, detail);
        ++faults_per_leg_[i];
      } else {
        log_->info("leg {} tick {}: valve command valid again", i + 1, tick_);
      }
      last_check_[i] = check;
    }
  }
  plant_.Step(valve_v, kTickS);
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

int PlantNode::Run() {
  const bool realtime = options_.common.mode == node::TimeMode::kRealtime;
  if (!WaitForPeers()) {
    PublishStatus(hexa_msg_NODE_FAULT, "peers not ready");
    return shutdown_.requested() ? 0 : 3;
  }
  PublishStatus(hexa_msg_NODE_RUNNING, realtime ? "real time" : "lockstep");
  log_->info("ticking in {} mode, profile '{}', seed {}", realtime ? "real-time" : "lockstep",
             options_.profile, options_.seed);
  const uint64_t last_tick = options_.duration_s > 0
                                 ? static_cast<uint64_t>(std::llround(options_.duration_s / kTickS))
                                 : UINT64_MAX;
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  int rc = 0;
  while (!shutdown_.requested() && tick_ < last_tick) {
    const int64_t t0 = node::MonotonicNow_ns();
    PublishSensors(true);
    if (realtime) {
      next.tv_nsec += 1'000'000;
      if (next.tv_nsec >= 1'000'000'000) {
        next.tv_nsec -= 1'000'000'000;
        ++next.tv_sec;
      }
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
      TakeCommands();
      const int64_t late_ns = node::MonotonicNow_ns() -
                              (static_cast<int64_t>(next.tv_sec) * 1'000'000'000 + next.tv_nsec);
      if (late_ns > 1'000'000) ++overruns_;
      ApplyAndStep(options_.realtime_stale_ticks);
    } else {
      if (!LockstepCollect()) {
        rc = shutdown_.requested() ? 0 : 3;
        break;
      }
      ApplyAndStep(0);
    }
    if (plant_.output().status == PlantStatus::kNonFiniteState) {
      faults_.Publish(0, tick_, hexa_msg_FAULT_STATE_NOT_FINITE, "plant state not finite: stopped");
      log_->error("plant state became non-finite at tick {}: stopping", tick_);
      LogLastGoodState();
      PublishStatus(hexa_msg_NODE_FAULT, "state not finite");
      return 4;
    }
    ++tick_;
    if (!realtime) cycle_times_.Add(static_cast<double>(node::MonotonicNow_ns() - t0) * 1e-9);
    if (tick_ % 100 == 0) {
      PublishStatus(hexa_msg_NODE_RUNNING, realtime ? "real time" : "lockstep");
      // Faults still in effect are repeated at the status rate, so that a supervisor reset
      // while the cause persists sees the fault again.
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        if (last_check_[i] == CommandCheck::kOk || last_check_[i] == CommandCheck::kAwaitingFirst)
          continue;
        faults_.Publish(static_cast<uint8_t>(i + 1), tick_, FaultOf(last_check_[i]),
                        "valve command still invalid: valve held at null");
      }
    }
  }
  uint32_t faults = 0;
  for (auto f : faults_per_leg_) faults += f;
  const auto valve = valve_reader_.Snapshot();
  log_->info("stopped at tick {} (t = {:.3f} s): valve deadline misses {}, loop overruns {}, "
             "command faults {}, lockstep resends {}",
             tick_, static_cast<double>(tick_) * kTickS, valve.requested_deadline_missed_total,
             overruns_, faults, resends_);
  PublishStatus(hexa_msg_NODE_STOPPING, "stopped");
  return rc;
}

}  // namespace hexa::plant_sim
