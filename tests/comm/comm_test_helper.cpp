// Helper processes for the comm integration tests (tests/comm/comm_process_test.cpp), one
// mode per role:
//   pub-all       publish every topic type (recording/topic_types.hpp) with Make<T>(seq), seq = 0, 1, ...
//   sub-all       receive every topic, compare every field with Make<T>(SeqOf(sample))
//   pub-legs      LegSensors legs 1..6 at a period; SIGUSR1 toggles a pause of one leg
//   pub-valve     ValveCommand of one leg with an ownership strength (hot standby tests)
//   wait-shutdown block in a WaitSet with a ShutdownGuard; exit 0 when a signal wakes it
// Every mode stops by itself after --max-s seconds so that no helper can outlive a test.
// Lines on stdout ("READY", "CONFIG ...", "RESULT ...") are read by the test.
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/recording/topic_types.hpp"
#include "wire_samples.hpp"

namespace {

using namespace hexa::comm;
namespace t = hexa::comm::test;

struct Args {
  std::map<std::string, std::string> values;
  std::string Get(const std::string& key, const std::string& fallback) const {
    auto it = values.find(key);
    return it == values.end() ? fallback : it->second;
  }
  double Num(const std::string& key, double fallback) const {
    auto it = values.find(key);
    return it == values.end() ? fallback : std::stod(it->second);
  }
};

Args Parse(int argc, char** argv) {
  Args a;
  for (int i = 2; i + 1 < argc; i += 2) {
    std::string key = argv[i];
    if (key.rfind("--", 0) == 0) key = key.substr(2);
    a.values[key] = argv[i + 1];
  }
  return a;
}

void Say(const std::string& line) {
  std::fputs((line + "\n").c_str(), stdout);
  std::fflush(stdout);
}

// Common start: loopback default config (+ optional trace), participant.
Participant Start(const Args& a) {
  const DdsConfigChoice choice = EnsureDdsConfig();
  const char* source = choice.source == DdsConfigSource::kDefault       ? "default"
                       : choice.source == DdsConfigSource::kEnvironment ? "environment"
                                                                         : "override";
  Say(std::string("CONFIG ") + source + " " + choice.uri);
  const std::string trace = a.Get("trace", "");
  if (!trace.empty()) AppendCycloneConfigTrace(trace);
  return Participant(static_cast<dds_domainid_t>(a.Num("domain", 40)));
}

void SleepUntil(timespec& next, int64_t period_ns) {
  next.tv_nsec += period_ns;
  while (next.tv_nsec >= 1000000000L) {
    next.tv_nsec -= 1000000000L;
    next.tv_sec += 1;
  }
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
  }
}

// One topic of every topic type (recording/topic_types.hpp, the one list): its writer of
// Make<T>(seq), or its reader that checks every sample against Make<T>(SeqOf(sample)).
class AnyWriter {
 public:
  virtual ~AnyWriter() = default;
  virtual dds_return_t Write(uint64_t seq) = 0;
};

template <typename T>
class TypedWriter final : public AnyWriter {
 public:
  TypedWriter(const Participant& p, const QosParams& params) : topic_(p), writer_(p, topic_, params) {}
  dds_return_t Write(uint64_t seq) override {
    T sample = t::Make<T>(seq);
    return writer_.WriteNow(sample);
  }

 private:
  Topic<T> topic_;
  Writer<T> writer_;
};

int PubAll(const Args& a) {
  Participant p = Start(a);
  ShutdownGuard guard(p);
  QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  // Reliable writers on every topic (the lockstep QoS): sub-all reads with the default,
  // reliable recorder QoS, which a real-time (best-effort) periodic writer does not match.
  params.lockstep = true;
  std::vector<std::unique_ptr<AnyWriter>> writers;
  hexa::recorder::ForEachTopicType([&](auto type) {
    writers.push_back(std::make_unique<TypedWriter<typename decltype(type)::Dds>>(p, params));
  });
  Say("READY");
  const int64_t period_ns = static_cast<int64_t>(a.Num("period-ms", 20) * 1e6);
  const double max_s = a.Num("max-s", 20);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const int64_t start_ns = MonotonicNow_ns();
  for (uint64_t seq = 0; !guard.requested(); ++seq) {
    if (MonotonicNow_ns() - start_ns > static_cast<int64_t>(max_s * 1e9)) return 0;
    for (auto& writer : writers) {
      const dds_return_t rc = writer->Write(seq);
      if (rc != DDS_RETCODE_OK) {
        Say("WRITE_ERROR " + std::to_string(rc));
        return 1;
      }
    }
    SleepUntil(next, period_ns);
  }
  return 0;
}

struct TopicTally {
  std::string name;
  uint64_t received = 0;
  uint64_t mismatches = 0;
  uint64_t bad_timestamps = 0;
  std::string first_diff;
};

class AnyReader {
 public:
  virtual ~AnyReader() = default;
  virtual dds_entity_t data_condition() const = 0;
  virtual void Check() = 0;
  TopicTally tally;
};

template <typename T>
class TypedReader final : public AnyReader {
 public:
  TypedReader(const Participant& p, EndpointRole role, const char* type_name)
      : topic_(p), reader_(p, topic_, role) {
    tally.name = type_name;
  }
  dds_entity_t data_condition() const override { return reader_.data_condition(); }
  void Check() override {
    if (reader_.Take() <= 0) return;
    for (std::size_t i = 0; i < reader_.count(); ++i) {
      const dds_sample_info_t& info = reader_.info(i);
      if (!info.valid_data) continue;
      const T& got = reader_.sample(i);
      ++tally.received;
      const std::string diff = t::Diff(got, t::Make<T>(t::SeqOf(got)));
      if (!diff.empty()) {
        if (tally.first_diff.empty()) tally.first_diff = diff;
        ++tally.mismatches;
      }
      // The sample's own source time must be the DDS source timestamp (dds_write_ts).
      if (t::SourceTimeOf(got) != info.source_timestamp || info.source_timestamp <= 0) {
        ++tally.bad_timestamps;
      }
    }
  }

 private:
  Topic<T> topic_;
  Reader<T> reader_;
};

int SubAll(const Args& a) {
  Participant p = Start(a);
  ShutdownGuard guard(p);
  std::vector<std::unique_ptr<AnyReader>> readers;
  hexa::recorder::ForEachTopicType([&](auto type) {
    readers.push_back(std::make_unique<TypedReader<typename decltype(type)::Dds>>(
        p, EndpointRole::kRecorderReader, type.descriptor()->m_typename));
  });
  WaitSet ws(p, 16);
  ws.Attach(guard.guard_condition(), 0);
  for (std::size_t i = 0; i < readers.size(); ++i)
    ws.Attach(readers[i]->data_condition(), static_cast<dds_attach_t>(i + 1));
  Say("READY");
  const uint64_t min_per_topic = static_cast<uint64_t>(a.Num("min-per-topic", 5));
  const dds_time_t give_up = dds_time() + static_cast<dds_time_t>(a.Num("max-s", 20) * 1e9);
  bool complete = false;
  while (!guard.requested() && !complete) {
    const dds_return_t n = ws.WaitUntil(give_up);
    if (n == 0) break;  // timeout
    complete = true;
    for (auto& reader : readers) {
      reader->Check();
      complete = complete && reader->tally.received >= min_per_topic;
    }
  }
  bool clean = true;
  for (const auto& reader : readers) {
    const TopicTally& tally = reader->tally;
    Say("RESULT " + tally.name + " received=" + std::to_string(tally.received) +
        " mismatches=" + std::to_string(tally.mismatches) +
        " bad_timestamps=" + std::to_string(tally.bad_timestamps) +
        (tally.first_diff.empty() ? "" : " first_diff=" + tally.first_diff));
    clean = clean && tally.mismatches == 0 && tally.bad_timestamps == 0;
  }
  if (!clean) return 1;
  return complete ? 0 : 2;
}

// SIGUSR1 toggles the pause of one leg (async-signal-safe: one lock-free atomic).
std::atomic<bool> g_pause_leg{false};
extern "C" void OnUsr1(int) { g_pause_leg.store(!g_pause_leg.load()); }

int PubLegs(const Args& a) {
  Participant p = Start(a);
  ShutdownGuard guard(p);
  struct sigaction action {};
  action.sa_handler = OnUsr1;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGUSR1, &action, nullptr);
  QosParams params;
  params.deadline_period_s = a.Num("deadline-ms", 100) * 1e-3;
  Topic<hexa_msg_LegSensors> topic(p);
  Writer<hexa_msg_LegSensors> writer(p, topic, params);
  const int pause_leg = static_cast<int>(a.Num("pause-leg", 3));
  const int64_t period_ns = static_cast<int64_t>(a.Num("period-ms", 20) * 1e6);
  const int64_t max_ns = static_cast<int64_t>(a.Num("max-s", 30) * 1e9);
  Say("READY");
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const int64_t start_ns = MonotonicNow_ns();
  for (uint64_t tick = 0; !guard.requested() && MonotonicNow_ns() - start_ns < max_ns; ++tick) {
    for (int leg = 1; leg <= 6; ++leg) {
      if (leg == pause_leg && g_pause_leg.load()) continue;
      hexa_msg_LegSensors s = t::Make<hexa_msg_LegSensors>(tick * 6 + (leg - 1));
      if (writer.WriteNow(s) != DDS_RETCODE_OK) return 1;
    }
    SleepUntil(next, period_ns);
  }
  return 0;
}

int PubValve(const Args& a) {
  Participant p = Start(a);
  ShutdownGuard guard(p);
  QosParams params;
  params.deadline_period_s = a.Num("deadline-ms", 100) * 1e-3;
  params.valve_liveliness_lease_s = a.Num("lease-ms", 10) * 1e-3;
  params.valve_liveliness = a.Get("liveliness", "auto") == "manual"
                                ? LivelinessKind::kManualByTopic
                                : LivelinessKind::kAutomatic;
  params.ownership_strength = static_cast<int32_t>(a.Num("strength", 20));
  const bool standby = a.Num("standby", 0) != 0;
  // SIGUSR1 toggles a "hung control thread": the process and Cyclone's threads live on,
  // only the writes stop.
  struct sigaction action {};
  action.sa_handler = OnUsr1;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGUSR1, &action, nullptr);
  const uint8_t leg = static_cast<uint8_t>(a.Num("leg", 1));
  Topic<hexa_msg_ValveCommand> topic(p);
  Writer<hexa_msg_ValveCommand> writer(p, topic, params);
  Say("READY " + EntityGuid(writer.get()));
  const int64_t period_ns = static_cast<int64_t>(a.Num("period-ms", 2) * 1e6);
  const int64_t max_ns = static_cast<int64_t>(a.Num("max-s", 30) * 1e9);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const int64_t start_ns = MonotonicNow_ns();
  for (uint64_t tick = 0; !guard.requested() && MonotonicNow_ns() - start_ns < max_ns; ++tick) {
    hexa_msg_ValveCommand s = t::Make<hexa_msg_ValveCommand>(tick);
    s.leg_id = leg;
    s.standby = standby;
    s.valve_v = standby ? 4.0 : 6.0;
    if (!g_pause_leg.load() && writer.WriteNow(s) != DDS_RETCODE_OK) return 1;
    SleepUntil(next, period_ns);
  }
  return 0;
}

int WaitShutdown(const Args& a) {
  Participant p = Start(a);
  ShutdownGuard guard(p);
  Topic<hexa_msg_OperatorCommand> topic(p);
  Reader<hexa_msg_OperatorCommand> reader(p, topic);
  WaitSet ws(p);
  ws.Attach(guard.guard_condition(), 1);
  ws.Attach(reader.data_condition(), 2);
  Say("READY");
  for (;;) {
    const dds_return_t n = ws.Wait(DDS_SECS(static_cast<int64_t>(a.Num("max-s", 30))));
    if (n <= 0) {
      Say("RESULT timeout");
      return 3;
    }
    if (ws.Triggered(1)) {
      Say("RESULT shutdown signal=" + std::to_string(guard.signal_number()));
      return 0;
    }
    reader.Take();
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s pub-all|sub-all|pub-legs|pub-valve|wait-shutdown [--key value]...\n",
                 argv[0]);
    return 64;
  }
  const std::string mode = argv[1];
  const Args args = Parse(argc, argv);
  try {
    if (mode == "pub-all") return PubAll(args);
    if (mode == "sub-all") return SubAll(args);
    if (mode == "pub-legs") return PubLegs(args);
    if (mode == "pub-valve") return PubValve(args);
    if (mode == "wait-shutdown") return WaitShutdown(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "comm_test_helper %s: %s\n", mode.c_str(), e.what());
    return 70;
  }
  std::fprintf(stderr, "unknown mode %s\n", mode.c_str());
  return 64;
}
