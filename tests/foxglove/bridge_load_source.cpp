// A DDS load for hexa_bridge tests without a control session: every millisecond (CLOCK_MONOTONIC
// schedule) six LegSensors, six ValveCommand and one GroundTruth, every 5 ms one ImuSample, as
// a real-time session writes them, with plausible values (legs 0.6-0.7 m, the platform at
// 0.75 m). Best-effort writers (real time's QoS). Stops after --seconds or on SIGINT / SIGTERM.
//   bridge_load_source --domain N [--seconds 60]
#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "hexa/comm/comm.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/writer.hpp"

namespace comm = hexa::comm;

int main(int argc, char** argv) {
  int domain = -1;
  double seconds = 60;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--domain") == 0) domain = std::atoi(argv[i + 1]);
    else if (std::strcmp(argv[i], "--seconds") == 0) seconds = std::atof(argv[i + 1]);
  }
  if (domain < 0 || domain > 230 || !(seconds > 0 && seconds <= 3600)) {
    std::fprintf(stderr, "usage: bridge_load_source --domain 0..230 [--seconds 1..3600]\n");
    return 2;
  }
  comm::EnsureDdsConfig(std::nullopt);
  comm::Participant p(static_cast<dds_domainid_t>(domain));
  comm::ShutdownGuard shutdown(p);
  comm::Topic<hexa_msg_LegSensors> sensors_topic(p);
  comm::Topic<hexa_msg_ValveCommand> valve_topic(p);
  comm::Topic<hexa_msg_GroundTruth> truth_topic(p);
  comm::Topic<hexa_msg_ImuSample> imu_topic(p);
  comm::Writer<hexa_msg_LegSensors> sensors(p, sensors_topic);
  comm::Writer<hexa_msg_ValveCommand> valves(p, valve_topic);
  comm::Writer<hexa_msg_GroundTruth> truth(p, truth_topic);
  comm::Writer<hexa_msg_ImuSample> imu(p, imu_topic);
  std::printf("publishing on domain %d for %.0f s\n", domain, seconds);
  std::fflush(stdout);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const auto ticks = static_cast<uint64_t>(seconds * 1000);
  for (uint64_t tick = 1; tick <= ticks && !shutdown.requested(); ++tick) {
    const double t_s = 1e-3 * static_cast<double>(tick);
    const int64_t now = comm::RealtimeNow_ns();
    for (uint8_t leg = 1; leg <= 6; ++leg) {
      const double length_m = 0.65 + 0.05 * std::sin(t_s + leg);
      hexa_msg_LegSensors s{};
      s.leg_id = leg;
      s.header = {tick, t_s, now};
      s.length_m = length_m;
      s.cap_pressure_pa = s.rod_pressure_pa = 3e5;
      s.supply_pressure_pa = 6e5;
      sensors.Write(s, now);
      hexa_msg_ValveCommand v{};
      v.leg_id = leg;
      v.header = {tick, t_s, now};
      v.valve_v = 5.0;
      v.controller = hexa_msg_CONTROLLER_BSSMC;
      v.setpoint_tick = tick;
      v.desired_length_m = length_m;
      v.friction_scale = 1.0;
      valves.Write(v, now);
    }
    hexa_msg_GroundTruth g{};
    g.header = {tick, t_s, now};
    g.position_m[2] = 0.75;
    g.orientation_wxyz[0] = 1.0;
    for (int k = 0; k < 6; ++k) g.leg_length_m[k] = 0.65 + 0.05 * std::sin(t_s + k + 1);
    truth.Write(g, now);
    if (tick % 5 == 0) {
      hexa_msg_ImuSample m{};
      m.header = {tick, t_s, now};
      m.orientation_wxyz[0] = 1.0;
      imu.Write(m, now);
    }
    next.tv_nsec += 1'000'000;
    if (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  return 0;
}
