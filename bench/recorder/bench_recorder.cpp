// Highest message rate the recorder's writer sustains to disk, as a multiple of the system's
// nominal rate: 6 legs x 1 kHz x 2 topics + 1 kHz ground truth + 200 Hz x (IMU + 6 setpoints +
// pose) = 14 600 messages/s. Target: 10x.
//
//   bench_recorder [--benchmark_filter=...]     (files go to $HEXA_BENCH_DIR, default /tmp)
//
// Each message is converted from its DDS struct (ToProto, as `record` does), serialized and
// written; chunks close every 100 ms of log time (the recorder's default flush interval, log
// time advancing at the nominal rate x 10) and are synced with the given mode. "x_nominal" is
// items_per_second / 14 600.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder {
namespace {

constexpr double kNominalRate = 6 * 1000 * 2 + 1000 + 200 * (1 + 6 + 1);  // 14 600 msg/s

std::string BenchPath(const char* name) {
  const char* dir = std::getenv("HEXA_BENCH_DIR");
  return std::string(dir ? dir : "/tmp") + "/hexa_bench_" + name + "_" +
         std::to_string(::getpid()) + ".mcap";
}

// sync: 0 none, 1 fflush, 2 fdatasync; zstd: 0 uncompressed chunks, 1 zstd (the default).
McapWriterConfig Config(int sync, int zstd) {
  McapWriterConfig c;
  c.sync = static_cast<McapSyncMode>(sync);
  c.compression = zstd ? McapCompression::kZstd : McapCompression::kNone;
  c.chunk_max_span_ns = 100'000'000;
  return c;
}

// LegSensors only: the most frequent message of the system.
void BM_WriteLegSensors(benchmark::State& state) {
  const std::string path = BenchPath("sensors");
  RecordingWriter w(Config(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))));
  w.Open(path);
  const uint16_t ch = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(), {});
  hexa_msg_LegSensors s{};
  rec::LegSensors msg;
  const uint64_t step_ns = static_cast<uint64_t>(1e9 / (10 * kNominalRate));
  uint64_t t = 1'700'000'000'000'000'000ull, tick = 0;
  for (auto _ : state) {
    ++tick;
    s.leg_id = static_cast<uint8_t>(1 + tick % 6);
    s.header.tick = tick / 6;
    s.header.sim_time_s = 1e-3 * static_cast<double>(tick / 6);
    s.header.source_time_ns = static_cast<int64_t>(t);
    s.length_m = 0.5 + 1e-7 * static_cast<double>(tick % 1000);
    s.cap_pressure_pa = 4e5 + static_cast<double>(tick % 777);
    s.rod_pressure_pa = 3e5 - static_cast<double>(tick % 555);
    s.supply_pressure_pa = 7e5;
    ToProto(s, msg);
    w.Write(ch, t, t, msg);
    t += step_ns;
  }
  w.Close();
  state.SetItemsProcessed(state.iterations());
  state.SetBytesProcessed(static_cast<int64_t>(w.mcap().stats().bytes));
  state.counters["x_nominal"] =
      benchmark::Counter(static_cast<double>(state.iterations()) / kNominalRate,
                         benchmark::Counter::kIsRate);
  state.counters["bytes_per_msg"] =
      static_cast<double>(w.mcap().stats().bytes) / static_cast<double>(state.iterations());
  state.counters["syncs"] = static_cast<double>(w.mcap().stats().syncs);
  ::unlink(path.c_str());
}
BENCHMARK(BM_WriteLegSensors)->ArgNames({"sync", "zstd"})->Args({0, 0})->Args({0, 1})
    ->Args({1, 0})->Args({1, 1})->Args({2, 0})->Args({2, 1})->UseRealTime()->MinTime(2.0);

// The nominal mix of one 1 ms tick (6 sensors, 6 valve commands, ground truth; every fifth
// tick IMU, 6 setpoints, pose) = 13 or 21 messages.
void BM_WriteNominalMix(benchmark::State& state) {
  const std::string path = BenchPath("mix");
  RecordingWriter w(Config(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))));
  w.Open(path);
  const uint16_t cs = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(), {});
  const uint16_t cv = w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(), {});
  const uint16_t cg = w.AddTopic("hexa_GroundTruth", *rec::GroundTruth::descriptor(), {});
  const uint16_t ci = w.AddTopic("hexa_ImuSample", *rec::ImuSample::descriptor(), {});
  const uint16_t cp = w.AddTopic("hexa_LegSetpoint", *rec::LegSetpoint::descriptor(), {});
  const uint16_t cr = w.AddTopic("hexa_PoseReport", *rec::PoseReport::descriptor(), {});
  hexa_msg_LegSensors s{};
  hexa_msg_ValveCommand v{};
  hexa_msg_GroundTruth g{};
  hexa_msg_ImuSample imu{};
  hexa_msg_LegSetpoint sp{};
  hexa_msg_PoseReport pose{};
  for (int i = 0; i < 6; ++i) g.leg_length_m[i] = 0.5 + 0.01 * i;
  rec::LegSensors ms;
  rec::ValveCommand mv;
  rec::GroundTruth mg;
  rec::ImuSample mi;
  rec::LegSetpoint msp;
  rec::PoseReport mp;
  uint64_t t = 1'700'000'000'000'000'000ull, tick = 0, messages = 0;
  for (auto _ : state) {
    ++tick;
    for (uint8_t leg = 1; leg <= 6; ++leg) {
      s.leg_id = v.leg_id = leg;
      s.header.tick = v.header.tick = tick;
      s.length_m = 0.5 + 1e-6 * static_cast<double>(tick % 999);
      v.valve_v = 5.0 + 1e-3 * static_cast<double>(tick % 777);
      ToProto(s, ms);
      w.Write(cs, t, t, ms);
      ToProto(v, mv);
      w.Write(cv, t + 1000, t, mv);
    }
    g.header.tick = tick;
    ToProto(g, mg);
    w.Write(cg, t + 2000, t, mg);
    messages += 13;
    if (tick % 5 == 0) {
      imu.header.tick = tick;
      ToProto(imu, mi);
      w.Write(ci, t + 3000, t, mi);
      for (uint8_t leg = 1; leg <= 6; ++leg) {
        sp.leg_id = leg;
        sp.header.tick = tick;
        ToProto(sp, msp);
        w.Write(cp, t + 4000, t, msp);
      }
      pose.header.tick = tick;
      ToProto(pose, mp);
      w.Write(cr, t + 5000, t, mp);
      messages += 8;
    }
    t += 100'000;  // log time at 10x the nominal rate: 1 ms of system time per 0.1 ms
  }
  w.Close();
  state.SetItemsProcessed(static_cast<int64_t>(messages));
  state.SetBytesProcessed(static_cast<int64_t>(w.mcap().stats().bytes));
  state.counters["x_nominal"] =
      benchmark::Counter(static_cast<double>(messages) / kNominalRate, benchmark::Counter::kIsRate);
  state.counters["bytes_per_msg"] =
      static_cast<double>(w.mcap().stats().bytes) / static_cast<double>(messages);
  ::unlink(path.c_str());
}
BENCHMARK(BM_WriteNominalMix)->ArgNames({"sync", "zstd"})->Args({0, 0})->Args({0, 1})
    ->Args({2, 0})->Args({2, 1})->UseRealTime()->MinTime(2.0);

}  // namespace
}  // namespace hexa::recorder

BENCHMARK_MAIN();
