// loop_fanout: the system's lockstep topology with no physics, on the project's comm/ layer.
// One process per role, started by bench/loop/run_loop_bench.py:
//   plant       writes LegSensors for six legs each tick (one writer per leg partition, or
//               one keyed writer read through Cyclone's topic filter), then waits for the six
//               ValveCommands of that tick and, every 5th tick, the six LegSetpoints;
//   leg N       answers its leg's LegSensors with a ValveCommand of the same tick;
//   supervisor  reads every leg's LegSensors and answers every 5th tick with six setpoints;
//   recorder    passive: reliable keep-all readers on the three topics, takes every 2 ms.
// It is the naive anchor of docs/performance.md: what a straightforward fan-out of the same
// topology costs on this machine. The plant prints one JSON line with the per-tick wall time
// (median, p99, max) and every role prints its own CPU time (user, system) on exit.
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/json.hpp"

namespace {

using namespace hexa;

constexpr int kLegs = 6;
constexpr int kSupervisorEvery = 5;

struct Options {
  std::string role;
  int leg = 0;
  int domain = 0;
  long long ticks = 5000;
  bool partitions = true;   // writer-side routing (else one topic + reader-side topic filter)
  bool listener = false;    // answer on Cyclone's receive thread (else a WaitSet wakes us)
  bool supervisor = true;
  bool recorder = true;
  bool batch = false;       // Cyclone WriteBatch: a writer's samples go out at Flush()
};

int64_t Mono_ns() { return comm::MonotonicNow_ns(); }

comm::QosParams LockstepQos() {
  comm::QosParams q;
  q.lockstep = true;
  q.deadline_period_s = 10.0;  // a stall detector, as in the system's lockstep mode
  q.valve_liveliness_lease_s = 0.05;
  return q;
}

struct Cpu {
  double user_s = 0, sys_s = 0;
  long voluntary = 0, involuntary = 0;
};
Cpu CpuNow() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return {static_cast<double>(ru.ru_utime.tv_sec) + ru.ru_utime.tv_usec * 1e-6,
          static_cast<double>(ru.ru_stime.tv_sec) + ru.ru_stime.tv_usec * 1e-6, ru.ru_nvcsw,
          ru.ru_nivcsw};
}
// CPU used since the first tick reached this process (start-up and discovery excluded).
Cpu g_cpu_at_first_tick;
std::atomic<bool> g_first_tick_seen{false};
void MarkFirstTick() {
  if (!g_first_tick_seen.exchange(true)) g_cpu_at_first_tick = CpuNow();
}

void PrintCpu(const Options& o, const json::Value& extra = json::Value::object()) {
  const Cpu now = CpuNow();
  const double user = now.user_s - g_cpu_at_first_tick.user_s;
  const double sys = now.sys_s - g_cpu_at_first_tick.sys_s;
  const long nvcsw = now.voluntary - g_cpu_at_first_tick.voluntary;
  const long nivcsw = now.involuntary - g_cpu_at_first_tick.involuntary;
  json::Value line = {{"role", o.role},
                      {"leg", o.leg},
                      {"cpu_user_s", user},
                      {"cpu_sys_s", sys},
                      {"voluntary_switches", nvcsw},
                      {"involuntary_switches", nivcsw}};
  for (const auto& [k, v] : extra.items()) line[k] = v;
  std::printf("%s\n", json::Dump(line).c_str());
  std::fflush(stdout);
}

// Sensors topic as a leg sees it: its partition, or the whole topic through the leg filter.
struct LegSensorsIn {
  LegSensorsIn(const comm::Participant& p, const Options& o)
      : topic(o.partitions ? comm::Topic<hexa_msg_LegSensors>(p)
                           : comm::Topic<hexa_msg_LegSensors>::FilteredByLeg(
                                 p, static_cast<uint8_t>(o.leg))),
        reader(p, topic, comm::EndpointRole::kControlReader, LockstepQos(), 16,
               o.partitions ? std::vector<std::string>{comm::LegPartition(o.leg)}
                            : std::vector<std::string>{}) {}
  comm::Topic<hexa_msg_LegSensors> topic;
  comm::Reader<hexa_msg_LegSensors> reader;
};

// ---------------------------------------------------------------------------- leg
class Leg {
 public:
  Leg(const comm::Participant& p, const Options& o)
      : o_(o), in_(p, o), valve_topic_(p), valve_(p, valve_topic_, LockstepQos()) {
    command_.leg_id = static_cast<uint8_t>(o.leg);
  }
  // Answers every sample taken; true once the last tick was answered.
  bool Poll() {
    while (in_.reader.Take() > 0) {
      for (std::size_t k = 0; k < in_.reader.count(); ++k) {
        if (!in_.reader.info(k).valid_data) continue;
        const auto& s = in_.reader.sample(k);
        MarkFirstTick();
        command_.header = s.header;
        command_.valve_v = 5.0;
        valve_.WriteNow(command_);
        if (o_.batch) dds_write_flush(valve_.get());
        if (static_cast<long long>(s.header.tick) + 1 >= o_.ticks) done_ = true;
      }
    }
    return done_;
  }
  // Callbacks of different readers may come from different receive threads.
  static void OnData(void* self) {
    auto* node = static_cast<Leg*>(self);
    std::lock_guard<std::mutex> lock(node->mutex_);
    node->Poll();
  }
  std::mutex mutex_;
  comm::Reader<hexa_msg_LegSensors>& reader() { return in_.reader; }
  bool done() const { return done_; }

 private:
  Options o_;
  LegSensorsIn in_;
  comm::Topic<hexa_msg_ValveCommand> valve_topic_;
  comm::Writer<hexa_msg_ValveCommand> valve_;
  hexa_msg_ValveCommand command_{};
  std::atomic<bool> done_{false};
};

// ---------------------------------------------------------------------------- supervisor
class Supervisor {
 public:
  Supervisor(const comm::Participant& p, const Options& o)
      : o_(o),
        sensors_topic_(p),
        sensors_(p, sensors_topic_, comm::EndpointRole::kControlReader, LockstepQos(), 64,
                 o.partitions ? comm::AllLegPartitions() : std::vector<std::string>{}),
        setpoint_topic_(p),
        setpoints_(p, setpoint_topic_, LockstepQos()) {}
  bool Poll() {
    while (sensors_.Take() > 0) {
      for (std::size_t k = 0; k < sensors_.count(); ++k) {
        if (!sensors_.info(k).valid_data) continue;
        const auto& s = sensors_.sample(k);
        MarkFirstTick();
        if (s.header.tick % kSupervisorEvery != 0) continue;
        if (s.header.tick != tick_) {
          tick_ = s.header.tick;
          seen_ = 0;
        }
        if (++seen_ < kLegs) continue;
        for (int leg = 1; leg <= kLegs; ++leg) {
          hexa_msg_LegSetpoint sp{};
          sp.leg_id = static_cast<uint8_t>(leg);
          sp.header = s.header;
          setpoints_.WriteNow(sp);
        }
        if (o_.batch) dds_write_flush(setpoints_.get());
        if (static_cast<long long>(tick_) + kSupervisorEvery >= o_.ticks) done_ = true;
      }
    }
    return done_;
  }
  // Callbacks of different readers may come from different receive threads.
  static void OnData(void* self) {
    auto* node = static_cast<Supervisor*>(self);
    std::lock_guard<std::mutex> lock(node->mutex_);
    node->Poll();
  }
  std::mutex mutex_;
  comm::Reader<hexa_msg_LegSensors>& reader() { return sensors_; }
  bool done() const { return done_; }

 private:
  Options o_;
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Reader<hexa_msg_LegSensors> sensors_;
  comm::Topic<hexa_msg_LegSetpoint> setpoint_topic_;
  comm::Writer<hexa_msg_LegSetpoint> setpoints_;
  uint64_t tick_ = UINT64_MAX;
  int seen_ = 0;
  std::atomic<bool> done_{false};
};

// ---------------------------------------------------------------------------- plant
class Plant {
 public:
  Plant(const comm::Participant& p, const Options& o)
      : o_(o),
        sensors_topic_(p),
        valve_topic_(p),
        setpoint_topic_(p),
        valves_(p, valve_topic_, comm::EndpointRole::kControlReader, LockstepQos(), 64),
        setpoints_(p, setpoint_topic_, comm::EndpointRole::kControlReader, LockstepQos(), 64) {
    if (o.partitions) {
      for (int leg = 1; leg <= kLegs; ++leg)
        sensors_.push_back(std::make_unique<comm::Writer<hexa_msg_LegSensors>>(
            p, sensors_topic_, LockstepQos(), std::vector<std::string>{comm::LegPartition(leg)}));
    } else {
      sensors_.push_back(
          std::make_unique<comm::Writer<hexa_msg_LegSensors>>(p, sensors_topic_, LockstepQos()));
    }
    tick_ns_.reserve(static_cast<std::size_t>(o.ticks));
  }

  bool Matched() const {
    // Per writer: its leg (or the six legs), the supervisor and the recorder.
    const uint32_t per_writer = (o_.partitions ? 1u : 6u) + (o_.supervisor ? 1u : 0u) +
                                (o_.recorder ? 1u : 0u);
    for (const auto& w : sensors_)
      if (w->Snapshot().publication_matched_current < per_writer) return false;
    if (valves_.Snapshot().subscription_matched_current < kLegs) return false;
    if (o_.supervisor && setpoints_.Snapshot().subscription_matched_current < 1) return false;
    return true;
  }

  void WriteSensors() {
    start_ns_ = Mono_ns();
    for (int leg = 1; leg <= kLegs; ++leg) {
      hexa_msg_LegSensors s{};
      s.leg_id = static_cast<uint8_t>(leg);
      s.header.tick = static_cast<uint64_t>(tick_);
      s.header.sim_time_s = static_cast<double>(tick_) * 1e-3;
      s.length_m = 0.5;
      sensors_[o_.partitions ? static_cast<std::size_t>(leg - 1) : 0]->WriteNow(s);
    }
    if (o_.batch)
      for (auto& w : sensors_) dds_write_flush(w->get());
  }

  // Takes answers; when the tick is complete, records its time and starts the next one.
  // Returns true when every tick is done.
  bool Poll() {
    while (valves_.Take() > 0)
      for (std::size_t k = 0; k < valves_.count(); ++k)
        if (valves_.info(k).valid_data && valves_.sample(k).header.tick == static_cast<uint64_t>(tick_))
          ++valves_seen_;
    while (setpoints_.Take() > 0)
      for (std::size_t k = 0; k < setpoints_.count(); ++k)
        if (setpoints_.info(k).valid_data &&
            setpoints_.sample(k).header.tick == static_cast<uint64_t>(tick_))
          ++setpoints_seen_;
    const bool need_setpoints = o_.supervisor && tick_ % kSupervisorEvery == 0;
    if (valves_seen_ >= kLegs && (!need_setpoints || setpoints_seen_ >= kLegs)) {
      tick_ns_.push_back(Mono_ns() - start_ns_);
      valves_seen_ = setpoints_seen_ = 0;
      if (++tick_ >= o_.ticks) {
        done_ = true;
        return true;
      }
      WriteSensors();
    }
    return false;
  }
  // Callbacks of different readers may come from different receive threads.
  static void OnData(void* self) {
    auto* node = static_cast<Plant*>(self);
    std::lock_guard<std::mutex> lock(node->mutex_);
    node->Poll();
  }
  std::mutex mutex_;

  comm::Reader<hexa_msg_ValveCommand>& valves() { return valves_; }
  comm::Reader<hexa_msg_LegSetpoint>& setpoints() { return setpoints_; }
  bool done() const { return done_; }

  json::Value Summary() {
    std::vector<int64_t> t = tick_ns_;
    std::sort(t.begin(), t.end());
    auto q = [&](double f) {
      return t.empty() ? 0.0 : static_cast<double>(t[std::min(t.size() - 1, static_cast<std::size_t>(f * t.size()))]) * 1e-6;
    };
    return {{"ticks", t.size()},
            {"tick_ms_median", q(0.5)},
            {"tick_ms_p99", q(0.99)},
            {"tick_ms_max", t.empty() ? 0.0 : static_cast<double>(t.back()) * 1e-6},
            {"wall_s", static_cast<double>(Mono_ns() - run_start_ns_) * 1e-9}};
  }
  void StartRun() {
    run_start_ns_ = Mono_ns();
    MarkFirstTick();
  }

 private:
  Options o_;
  comm::Topic<hexa_msg_LegSensors> sensors_topic_;
  comm::Topic<hexa_msg_ValveCommand> valve_topic_;
  comm::Topic<hexa_msg_LegSetpoint> setpoint_topic_;
  std::vector<std::unique_ptr<comm::Writer<hexa_msg_LegSensors>>> sensors_;
  comm::Reader<hexa_msg_ValveCommand> valves_;
  comm::Reader<hexa_msg_LegSetpoint> setpoints_;
  long long tick_ = 0;
  int valves_seen_ = 0;
  int setpoints_seen_ = 0;
  int64_t start_ns_ = 0;
  int64_t run_start_ns_ = 0;
  std::vector<int64_t> tick_ns_;
  std::atomic<bool> done_{false};
};

// ---------------------------------------------------------------------------- recorder
int RunRecorder(const comm::Participant& p, const Options& o) {
  const auto legs = o.partitions ? comm::AllLegPartitions() : std::vector<std::string>{};
  comm::QosParams q;
  comm::Topic<hexa_msg_LegSensors> st(p);
  comm::Topic<hexa_msg_ValveCommand> vt(p);
  comm::Topic<hexa_msg_LegSetpoint> pt(p);
  comm::Reader<hexa_msg_LegSensors> s(p, st, comm::EndpointRole::kRecorderReader, q, 256, legs);
  comm::Reader<hexa_msg_ValveCommand> v(p, vt, comm::EndpointRole::kRecorderReader, q, 256);
  comm::Reader<hexa_msg_LegSetpoint> sp(p, pt, comm::EndpointRole::kRecorderReader, q, 256);
  long long samples = 0;
  int64_t last_data = Mono_ns();
  const long long expected = o.ticks * 12 + (o.supervisor ? (o.ticks / kSupervisorEvery) * 6 : 0);
  while (samples < expected && Mono_ns() - last_data < 5'000'000'000LL) {
    timespec ts{0, 2'000'000};  // the recorder's batch period
    nanosleep(&ts, nullptr);
    long long before = samples;
    if (samples > 0) MarkFirstTick();
    while (s.Take() > 0) samples += static_cast<long long>(s.count());
    while (v.Take() > 0) samples += static_cast<long long>(v.count());
    while (sp.Take() > 0) samples += static_cast<long long>(sp.count());
    if (samples != before) last_data = Mono_ns();
  }
  PrintCpu(o, {{"samples", samples}});
  return 0;
}

// Runs `node` until done: on the receive thread (listener) or from a WaitSet. `start` runs
// once the node is ready to receive (the plant writes tick 0 there).
template <typename Node, typename Start, typename... Readers>
void Drive(const comm::Participant& p, Node& node, bool listener, Start start,
           Readers&... readers) {
  if (listener) {
    (readers.OnDataAvailable(&Node::OnData, &node), ...);
    start();
    while (!node.done()) {
      timespec ts{0, 20'000'000};
      nanosleep(&ts, nullptr);
    }
    return;
  }
  comm::WaitSet ws(p);
  dds_attach_t token = 1;
  ((ws.Attach(readers.data_condition(), token++)), ...);
  start();
  while (!node.Poll()) ws.Wait(DDS_SECS(5));
}

}  // namespace

int main(int argc, char** argv) {
  cli::Parser cli("loop_fanout", "The system's lockstep DDS topology without physics (one role per process).");
  cli.AddChoice("role", {"plant", "leg", "supervisor", "recorder"}, "process role", "plant");
  cli.AddOption("leg", "N", "leg id 1..6 (role leg)", "1");
  cli.AddOption("domain", "id", "DDS domain id", "0");
  cli.AddOption("ticks", "N", "ticks to run", "5000");
  cli.AddChoice("routing", {"partition", "filter"},
                "leg routing: a partition per leg (writer side) or one topic with Cyclone's "
                "topic filter (reader side)", "partition");
  cli.AddChoice("delivery", {"waitset", "listener"},
                "answer from a WaitSet-woken thread or on Cyclone's receive thread", "waitset");
  cli.AddFlag("batch", "Cyclone WriteBatch, writers flushed after each tick's writes");
  cli.AddFlag("no-supervisor", "no supervisor role in this run");
  cli.AddFlag("no-recorder", "no recorder role in this run");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  Options o;
  o.role = cli.Get("role");
  const auto leg = cli.GetInt("leg", 1, 6);
  const auto domain = cli.GetInt("domain", 0, 230);
  const auto ticks = cli.GetInt("ticks", 10, 10'000'000);
  if (!leg || !domain || !ticks) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  o.leg = static_cast<int>(*leg);
  o.domain = static_cast<int>(*domain);
  o.ticks = *ticks;
  o.partitions = cli.Get("routing") == "partition";
  o.listener = cli.Get("delivery") == "listener";
  o.supervisor = !cli.Flag("no-supervisor");
  o.recorder = !cli.Flag("no-recorder");
  o.batch = cli.Flag("batch");
  try {
    comm::EnsureDdsConfig(std::nullopt);
    if (o.batch) {
      const std::string uri = std::string(std::getenv("CYCLONEDDS_URI")) +
                              ",<Internal><WriteBatch>true</WriteBatch></Internal>";
      setenv("CYCLONEDDS_URI", uri.c_str(), 1);
    }
    comm::Participant p(o.domain);
    if (o.role == "recorder") return RunRecorder(p, o);
    if (o.role == "leg") {
      Leg node(p, o);
      Drive(p, node, o.listener, [] {}, node.reader());
      PrintCpu(o);
      timespec ts{0, 200'000'000};  // let the last answer reach the plant and the recorder
      nanosleep(&ts, nullptr);
      return 0;
    }
    if (o.role == "supervisor") {
      Supervisor node(p, o);
      Drive(p, node, o.listener, [] {}, node.reader());
      PrintCpu(o);
      timespec ts{0, 200'000'000};
      nanosleep(&ts, nullptr);
      return 0;
    }
    Plant node(p, o);
    const int64_t give_up = Mono_ns() + 30'000'000'000LL;
    while (!node.Matched()) {
      if (Mono_ns() > give_up) {
        std::fprintf(stderr, "plant: peers not matched after 30 s\n");
        return 3;
      }
      timespec ts{0, 10'000'000};
      nanosleep(&ts, nullptr);
    }
    timespec settle{0, 500'000'000};  // the peers' own matches (recorder <- legs) settle
    nanosleep(&settle, nullptr);
    auto start = [&] {
      node.StartRun();
      node.WriteSensors();
    };
    if (o.supervisor) {
      Drive(p, node, o.listener, start, node.valves(), node.setpoints());
    } else {
      Drive(p, node, o.listener, start, node.valves());
    }
    PrintCpu(o, node.Summary());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "loop_fanout %s: %s\n", o.role.c_str(), e.what());
    return 1;
  }
}
