// The supervisor's cycle (supervisor_node.hpp): which samples a tick runs on. Real time: each
// IMU sample with the legs' newest; lockstep: the IMU and the six legs' samples of the same
// tick, a re-asked tick answered again; the main thread's IMU-miss count.
#include <time.h>

#include <algorithm>

#include "supervisor_node.hpp"

#include "hexa/comm/time.hpp"

namespace hexa::task_space {

void SupervisorNode::TakeSensors() {
  services::TakeValid(sensors_reader_, [&](const hexa_msg_LegSensors& s, std::size_t) {
    if (s.leg_id < 1 || s.leg_id > kNumLegs) return;
    const std::size_t i = s.leg_id - 1;
    sensor_ring_[i][sensor_ring_count_[i]++ % kSensorRing] = s;
    if (sensors_seen_[i] && s.header.tick < sensors_[i].header.tick) return;
    sensors_[i] = s;
    sensors_seen_[i] = true;
  });
}

const hexa_msg_LegSensors* SupervisorNode::RingSample(std::size_t leg_index,
                                                      std::uint64_t tick) const {
  const std::size_t n = std::min(sensor_ring_count_[leg_index], kSensorRing);
  for (std::size_t k = 0; k < n; ++k) {
    const hexa_msg_LegSensors& s = sensor_ring_[leg_index][k];
    if (s.header.tick == tick) return &s;
  }
  return nullptr;
}

bool SupervisorNode::TakeImu(bool& repeated) {
  return services::TakeNewest(imu_reader_, imu_, imu_seen_, repeated);
}

void SupervisorNode::RepublishSetpoints() {
  const int64_t now_ns = comm::RealtimeNow_ns();
  for (const hexa_msg_LegSetpoint& s : last_setpoints_) setpoint_writer_.WriteDeferred(s, now_ns);
  setpoint_writer_.Flush();
  if (setpoint_republishes_++ == 0)
    log_->info("lockstep re-ask of tick {}: its setpoints published again (logged once)",
               last_run_tick_);
}

bool SupervisorNode::SensorsOfTick(std::uint64_t m) {
  LegArray<const hexa_msg_LegSensors*> at_m{};
  for (std::size_t i = 0; i < kNumLegs; ++i)
    if ((at_m[i] = RingSample(i, m)) == nullptr) return false;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    sensors_[i] = *at_m[i];
    sensors_seen_[i] = true;
  }
  return true;
}

bool SupervisorNode::RunLockstepWithoutImu() {
  // The plant said the IMU delivers nothing: tick m runs on the six legs' samples of m with
  // the last orientation, as an IMU miss (the plant's FAULT_IMU_LOST holds the platform).
  bool ran = false;
  for (;;) {
    const std::uint64_t m = ran_once_ ? last_run_tick_ + static_cast<std::uint64_t>(5) : 0;
    if (!SensorsOfTick(m)) return ran;
    ++imu_misses_consecutive_;
    RunTick(m, sensors_[0].header.sim_time_s);
    ran = true;
    if (exit_code_ >= 0) return ran;
  }
}

void SupervisorNode::RunCycle() {
  if (exit_code_ >= 0) return;
  TakeSensors();
  if (imu_lost_ && options_.common.mode == node::TimeMode::kLockstep) {
    bool ignored = false;
    TakeImu(ignored);  // whatever still comes is stale: ignored
    RunLockstepWithoutImu();
    if (exit_code_ >= 0) done_.Set();
    return;
  }
  bool repeated_imu = false;
  const bool fresh_imu = TakeImu(repeated_imu);
  if (!imu_seen_) return;
  const std::uint64_t m = imu_.header.tick;
  if (options_.common.mode == node::TimeMode::kRealtime) {
    // On each IMU sample, with the newest leg samples.
    if (!fresh_imu) return;
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    imu_misses_consecutive_ = 0;
    NoteInputLag(m);
    RunTick(m, imu_.header.sim_time_s);
  } else {
    // Lockstep: the IMU of tick m and the six legs' samples of tick m.
    // The plant re-asks the tick it last sent when a leg cannot answer the next one (core
    // lockstep_protocol.hpp: that leg may lack this tick's setpoint): publish it again.
    if (ran_once_ && m <= last_run_tick_) {
      if (repeated_imu && m == last_run_tick_) RepublishSetpoints();
      return;
    }
    if (!SensorsOfTick(m)) return;
    RunTick(m, imu_.header.sim_time_s);
  }
  if (exit_code_ >= 0) done_.Set();
}

void SupervisorNode::NoteInputLag(std::uint64_t tick) {
  timespec cpu{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu);
  const std::int64_t cpu_ns = static_cast<std::int64_t>(cpu.tv_sec) * 1'000'000'000 + cpu.tv_nsec;
  const std::int64_t mono_ns = last_imu_mono_ns_;
  const std::int64_t lag_ns = comm::RealtimeNow_ns() - imu_.header.source_time_ns;
  // A sample older than 4 IMU periods, and a process that ran under a quarter of the time
  // since its previous cycle: it was ready to run (its data had come) but did not run.
  constexpr std::int64_t kLateInput_ns = 20'000'000;
  if (cycle_mono_ns_ > 0 && lag_ns > kLateInput_ns &&
      4 * (cpu_ns - cycle_cpu_ns_) < mono_ns - cycle_mono_ns_) {
    host_stall_ = HostStall{tick, static_cast<double>(lag_ns) * 1e-9,
                            static_cast<double>(mono_ns - cycle_mono_ns_) * 1e-9,
                            static_cast<double>(cpu_ns - cycle_cpu_ns_) * 1e-9, mono_ns};
    log_->warn("tick {}: the plant's IMU sample was {:.1f} ms old when this process took it, and "
               "the process ran {:.2f} ms of CPU in the {:.1f} ms since its previous cycle: the "
               "host did not run it",
               tick, host_stall_.lag_s * 1e3, host_stall_.cpu_s * 1e3, host_stall_.wall_s * 1e3);
  }
  cycle_mono_ns_ = mono_ns;
  cycle_cpu_ns_ = cpu_ns;
}

void SupervisorNode::MainThreadLook() {
  const bool realtime = !runtime_.lockstep();
  TakeOperatorCommands();
  TakeFaults();
  // Lockstep without the IMU: the tick it awaits may already be here (its data callback
  // ran before the plant's FAULT_IMU_LOST arrived).
  if (imu_lost_ && !realtime) RunCycle();
  // Real time: the IMU is due every 5 ms; 10 ms without one counts a miss and the state
  // machine runs on what it has (it holds after the configured count).
  constexpr int64_t kImuDue_ns = 10'000'000;
  if (realtime && ran_once_ && node::MonotonicNow_ns() - last_imu_mono_ns_ > kImuDue_ns) {
    ++imu_misses_consecutive_;
    last_imu_mono_ns_ = node::MonotonicNow_ns();
    // Once the plant reported the IMU lost: on the legs' newest samples, so that time goes
    // on without it (the hold, and the exit 1 s after it, must still come).
    if (imu_lost_ && sensors_seen_[0] && sensors_[0].header.tick > last_run_tick_) {
      RunTick(sensors_[0].header.tick, sensors_[0].header.sim_time_s);
    } else {
      RunTick(last_run_tick_, imu_.header.sim_time_s);
    }
  }
}

}  // namespace hexa::task_space
