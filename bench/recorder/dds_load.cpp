// Load generator for measuring `hexa_recorder record` end to end over DDS: publishes the
// system's nominal topic mix (per 1 ms tick: 6 LegSensors, 6 ValveCommand, 1 GroundTruth;
// every 5th tick also ImuSample, 6 LegSetpoint, PoseReport = 14 600 msg/s at --speed 1) on
// loopback, paced by absolute clock_nanosleep, then prints what it sent. Usage:
//   rec_dds_load DOMAIN SECONDS [SPEED]
// Run `hexa_recorder record --domain DOMAIN` first, then compare with `hexa_recorder info`.
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/writer.hpp"

int main(int argc, char** argv) {
  using namespace hexa;
  if (argc < 3) {
    std::fprintf(stderr, "usage: rec_dds_load DOMAIN SECONDS [SPEED]\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const double seconds = std::atof(argv[2]);
  const double speed = argc > 3 ? std::atof(argv[3]) : 1.0;
  comm::EnsureDdsConfig();
  comm::Participant p(domain);
  comm::QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  comm::Topic<hexa_msg_LegSensors> ts(p);
  comm::Topic<hexa_msg_ValveCommand> tv(p);
  comm::Topic<hexa_msg_GroundTruth> tg(p);
  comm::Topic<hexa_msg_ImuSample> ti(p);
  comm::Topic<hexa_msg_LegSetpoint> tp(p);
  comm::Topic<hexa_msg_PoseReport> tr(p);
  comm::Writer<hexa_msg_LegSensors> ws(p, ts, params);
  comm::Writer<hexa_msg_ValveCommand> wv(p, tv, params);
  comm::Writer<hexa_msg_GroundTruth> wg(p, tg, params);
  comm::Writer<hexa_msg_ImuSample> wi(p, ti, params);
  comm::Writer<hexa_msg_LegSetpoint> wp(p, tp, params);
  comm::Writer<hexa_msg_PoseReport> wr(p, tr, params);
  // Wait (bounded) for the recorder to match every writer.
  for (int i = 0; i < 1000; ++i) {
    if (ws.Snapshot().publication_matched_current && wv.Snapshot().publication_matched_current &&
        wg.Snapshot().publication_matched_current && wi.Snapshot().publication_matched_current &&
        wp.Snapshot().publication_matched_current && wr.Snapshot().publication_matched_current)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const uint64_t ticks = static_cast<uint64_t>(seconds * 1000.0);
  const long period_ns = static_cast<long>(1e6 / speed);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  uint64_t sent = 0;
  hexa_msg_LegSensors s{};
  hexa_msg_ValveCommand v{};
  hexa_msg_GroundTruth g{};
  hexa_msg_ImuSample imu{};
  hexa_msg_LegSetpoint sp{};
  hexa_msg_PoseReport pose{};
  for (uint64_t tick = 1; tick <= ticks; ++tick) {
    const int64_t now = comm::RealtimeNow_ns();
    for (uint8_t leg = 1; leg <= 6; ++leg) {
      s.leg_id = v.leg_id = leg;
      s.header.tick = v.header.tick = tick;
      s.header.source_time_ns = v.header.source_time_ns = now;
      ws.Write(s, now);
      wv.Write(v, now);
    }
    g.header.tick = tick;
    g.header.source_time_ns = now;
    wg.Write(g, now);
    sent += 13;
    if (tick % 5 == 0) {
      imu.header.tick = sp.header.tick = pose.header.tick = tick;
      imu.header.source_time_ns = sp.header.source_time_ns = pose.header.source_time_ns = now;
      wi.Write(imu, now);
      for (uint8_t leg = 1; leg <= 6; ++leg) {
        sp.leg_id = leg;
        wp.Write(sp, now);
      }
      wr.Write(pose, now);
      sent += 8;
    }
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // reliable repairs
  std::printf("sent %llu messages in %llu ticks\n", static_cast<unsigned long long>(sent),
              static_cast<unsigned long long>(ticks));
  return 0;
}
