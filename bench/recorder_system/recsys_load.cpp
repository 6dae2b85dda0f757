// Load generator for the recorder system benchmark (run_bench.py): publishes the system's
// nominal topic mix per 1 ms tick (6 LegSensors, 6 ValveCommand, 1 GroundTruth; every 5th tick
// ImuSample, 6 LegSetpoint, PoseReport: 14.6 messages per tick) at SPEED ticks per ms, as
// bench/recorder's rec_dds_load does, but several of these processes can run side by side:
// each takes its own leg ids (LEG_OFFSET + 1..6) so that the recorder's per-instance tick
// analysis still sees every stream, and only the one with KEYLESS = 1 publishes the keyless
// topics (GroundTruth, ImuSample, PoseReport). One process tops out at ~6x nominal on this VM
// (single writer thread); several reach the recorder's limit.
//   recsys_load DOMAIN SECONDS SPEED LEG_OFFSET KEYLESS
// SECONDS is the intended duration (ticks = SECONDS * 1000 * SPEED).
// Prints: "sent N ticks T elapsed_s E rate_msg_s R behind_ticks B" (B: ticks that started
// more than one period late, i.e. the publisher itself could not keep the pace).
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <thread>

#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/writer.hpp"

namespace {
int64_t MonoNs() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}
}  // namespace

int main(int argc, char** argv) {
  using namespace hexa;
  if (argc < 6) {
    std::fprintf(stderr, "usage: recsys_load DOMAIN SECONDS SPEED LEG_OFFSET KEYLESS\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const double seconds = std::atof(argv[2]);
  const double speed = std::atof(argv[3]);
  const int leg_offset = std::atoi(argv[4]);
  const bool keyless = std::atoi(argv[5]) != 0;
  if (!(speed > 0) || !(seconds > 0) || leg_offset < 0 || leg_offset > 240) {
    std::fprintf(stderr, "bad arguments\n");
    return 2;
  }
  comm::EnsureDdsConfig();
  comm::Participant p(domain);
  comm::QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  // Reliable writers (the lockstep QoS): the recorder under test reads with its default,
  // reliable QoS, which a real-time (best-effort) periodic writer does not match.
  params.lockstep = true;
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
  for (int i = 0; i < 1000; ++i) {  // bounded wait for the recorder to match every writer
    if (ws.Snapshot().publication_matched_current && wv.Snapshot().publication_matched_current &&
        wg.Snapshot().publication_matched_current && wi.Snapshot().publication_matched_current &&
        wp.Snapshot().publication_matched_current && wr.Snapshot().publication_matched_current)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // SECONDS of publishing at SPEED: SECONDS * 1000 * SPEED ticks.
  const uint64_t ticks = static_cast<uint64_t>(seconds * 1000.0 * speed);
  const int64_t period_ns = static_cast<int64_t>(1e6 / speed);
  uint64_t sent = 0, behind = 0;
  hexa_msg_LegSensors s{};
  hexa_msg_ValveCommand v{};
  hexa_msg_GroundTruth g{};
  hexa_msg_ImuSample imu{};
  hexa_msg_LegSetpoint sp{};
  hexa_msg_PoseReport pose{};
  s.length_m = 0.5034;
  s.cap_pressure_pa = 4e5;
  v.valve_v = 5.0;
  const int64_t t0 = MonoNs();
  for (uint64_t tick = 1; tick <= ticks; ++tick) {
    const int64_t due = t0 + static_cast<int64_t>(tick - 1) * period_ns;
    int64_t mono = MonoNs();
    if (mono < due) {
      const timespec ts_due{static_cast<time_t>(due / 1'000'000'000),
                            static_cast<long>(due % 1'000'000'000)};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts_due, nullptr);
    } else if (mono - due > period_ns) {
      ++behind;
    }
    const int64_t now = comm::RealtimeNow_ns();
    for (int k = 1; k <= 6; ++k) {
      const auto leg = static_cast<uint8_t>(leg_offset + k);
      s.leg_id = v.leg_id = sp.leg_id = leg;
      s.header.tick = v.header.tick = tick;
      s.header.source_time_ns = v.header.source_time_ns = now;
      ws.Write(s, now);
      wv.Write(v, now);
      sent += 2;
      if (tick % 5 == 0) {
        sp.header.tick = tick;
        sp.header.source_time_ns = now;
        wp.Write(sp, now);
        ++sent;
      }
    }
    if (keyless) {
      g.header.tick = tick;
      g.header.source_time_ns = now;
      wg.Write(g, now);
      ++sent;
      if (tick % 5 == 0) {
        imu.header.tick = pose.header.tick = tick;
        imu.header.source_time_ns = pose.header.source_time_ns = now;
        wi.Write(imu, now);
        wr.Write(pose, now);
        sent += 2;
      }
    }
  }
  const double elapsed_s = static_cast<double>(MonoNs() - t0) * 1e-9;
  // Let reliable repairs finish before the participant goes away.
  for (dds_entity_t w : {ws.get(), wv.get(), wg.get(), wi.get(), wp.get(), wr.get()})
    dds_wait_for_acks(w, DDS_SECS(5));
  std::printf("sent %llu ticks %llu elapsed_s %.4f rate_msg_s %.0f behind_ticks %llu\n",
              static_cast<unsigned long long>(sent), static_cast<unsigned long long>(ticks),
              elapsed_s, static_cast<double>(sent) / elapsed_s,
              static_cast<unsigned long long>(behind));
  return 0;
}
