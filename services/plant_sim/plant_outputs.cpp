// The plant node's outputs of a tick: every leg's sensor sample (and a re-ask's, to one leg),
// the IMU, ground truth and the tracker; the supervisor's inputs again when a leg cannot
// answer for want of a setpoint.
#include <cstdio>

#include "plant_node.hpp"

namespace hexa::plant_sim {
void PlantNode::PublishTick(int only_leg) {
  const device::DeviceSensors& out = link_.sensors();
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
    s.relayed_present = relayed_.present;
    s.relayed_tick = relayed_.tick;
    for (std::size_t j = 0; j < kNumLegs; ++j) {
      s.relayed_valid[j] = relayed_.parts[j].valid;
      s.relayed_force_n[j] = relayed_.parts[j].force_n;
      s.relayed_rate_n_s[j] = relayed_.parts[j].rate_n_s;
    }
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
  // Ground truth of this tick (for the recorder only), when the device is a simulation. Like
  // applied_valve_v, the command ages in it are those of the step that led to this state
  // (filled in by CompleteTick).
  const PlatformPlant* sim = device_.simulation();
  if (sim == nullptr) return;
  hexa_msg_GroundTruth& g = truth_sample_;
  comm::FillHeader(g.header, tick_, t, now_ns);
  const PlatformTrueState& truth = sim->output().truth;
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
  const TrackerReading& tracker = sim->output().tracker;
  if (tracker.fresh) {  // external instrument (calibration only), 100 Hz when on
    hexa_msg_TrackerPose tp{};
    comm::FillHeader(tp.header, tick_, t, now_ns);
    for (int k = 0; k < 3; ++k) tp.position_m[k] = tracker.p_BP_B_m[k];
    tp.orientation_wxyz[0] = tracker.q_BP.w();
    tp.orientation_wxyz[1] = tracker.q_BP.x();
    tp.orientation_wxyz[2] = tracker.q_BP.y();
    tp.orientation_wxyz[3] = tracker.q_BP.z();
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

}  // namespace hexa::plant_sim
