// hexa_intruder: a process that is not one of a session's own and tries to command it (test
// tool of tests/integration/test_foreign_commands.cpp; docs/faults.md, "Foreign commands").
// It joins the domain with the loopback configuration, creates a writer of one command topic
// in the partition given, with the ownership strength and USER_DATA given (a forged "leg=3
// standby=0" by default), and writes:
//   --topic valve:     leg --leg's ValveCommand, --value V, ticks far ahead of any real one;
//   --topic setpoint:  leg --leg's LegSetpoint, a length 5 cm off home, every 1 ms;
//   --topic operator:  an OperatorCommand --kind (stop by default), every 50 ms;
// or with --copy, it reads the topic in that partition and writes back every sample a real
// process sent, tag and all (a replay from another participant); with --follow (valve), it
// answers every sensor sample of the leg at its tick, as the leg's controller does. Prints what it did
// ("intruder: ...") and runs until --duration ends or it is killed.
#include <time.h>

#include <cstdio>
#include <algorithm>
#include <cstring>
#include <limits>
#include <type_traits>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <chrono>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/services/cli.hpp"

namespace {

using namespace hexa;

int64_t Mono_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

void SleepUntil(int64_t t_ns) {
  timespec t{};
  t.tv_sec = t_ns / 1'000'000'000;
  t.tv_nsec = t_ns % 1'000'000'000;
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
}

struct Options {
  int domain = 0, leg = 3, strength = 1000;
  std::string partition, user_data, kind = "stop";
  double value_v = 9.88, duration_s = 60, period_s = 0.001;
  bool copy = false, follow = false;
};

template <typename T>
int Run(const Options& o, comm::Participant& p, T sample) {
  comm::Topic<T> topic(p);
  comm::QosParams q;
  // Offers what every reader of a session requests, in either mode: reliable, a deadline and a
  // liveliness lease shorter than any requested (an offer weaker than a request does not match).
  q.lockstep = true;
  q.deadline_period_s = 0.001;
  q.user_data = o.user_data;
  q.ownership_strength = o.strength;
  q.valve_liveliness_lease_s = 0.005;
  const std::vector<std::string> partitions{o.partition};
  comm::Writer<T> writer(p, topic, q, partitions);
  // Readers as the recorder reads: they match any writer (no deadline, any lease, keep-all).
  // Best effort: matches a reliable (lockstep) and a best-effort (real-time) writer alike.
  comm::QosParams rq;
  rq.lockstep = true;
  rq.recorder_periodic_best_effort = true;
  std::unique_ptr<comm::Reader<T>> reader;
  if (o.copy)
    reader = std::make_unique<comm::Reader<T>>(p, topic, comm::EndpointRole::kRecorderReader, rq, 64,
                                               partitions);
  std::unique_ptr<comm::Topic<hexa_msg_LegSensors>> sensor_topic;
  std::unique_ptr<comm::Reader<hexa_msg_LegSensors>> sensors;
  if constexpr (std::is_same_v<T, hexa_msg_ValveCommand>) {
    if (o.follow) {
      sensor_topic = std::make_unique<comm::Topic<hexa_msg_LegSensors>>(p);
      sensors = std::make_unique<comm::Reader<hexa_msg_LegSensors>>(
          p, *sensor_topic, comm::EndpointRole::kRecorderReader, rq, 64, partitions);
    }
  }
  const bool polling = reader || sensors;
  dds_instance_handle_t own = 0;  // the copy reader also receives this writer's own samples
  (void)dds_get_instance_handle(writer.get(), &own);
  std::printf("intruder: writer %s in partition '%s' strength %d user_data '%s'%s\n",
              comm::TopicName(comm::TopicTraits<T>::kKind).data(), o.partition.c_str(), o.strength,
              o.user_data.c_str(),
              o.copy ? " (copying the real samples)" : sensors ? " (answering every sensor tick)" : "");
  std::fflush(stdout);
  const int64_t end = Mono_ns() + static_cast<int64_t>(o.duration_s * 1e9);
  int64_t next = Mono_ns();
  uint64_t written = 0, copied = 0;
  uint32_t matched_max = 0;
  while (Mono_ns() < end) {
    next += static_cast<int64_t>((polling ? 1e-4 : o.period_s) * 1e9);
    SleepUntil(next);
    matched_max = std::max(matched_max, writer.Snapshot().publication_matched_current);
    if (polling) {
      const uint64_t before = copied;
      while (reader && reader->Take() > 0)
        for (std::size_t k = 0; k < reader->count(); ++k)
          if (reader->info(k).valid_data && reader->info(k).publication_handle != own) {
            writer.Write(reader->sample(k), comm::RealtimeNow_ns());
            ++copied;
          }
      if constexpr (std::is_same_v<T, hexa_msg_ValveCommand>) {
        while (sensors && sensors->Take() > 0)
          for (std::size_t k = 0; k < sensors->count(); ++k)
            if (sensors->info(k).valid_data && sensors->sample(k).leg_id == sample.leg_id) {
              sample.header.tick = sensors->sample(k).header.tick;  // the tick the plant awaits
              sample.header.sim_time_s = sensors->sample(k).header.sim_time_s;
              writer.WriteNow(sample);
              ++copied;
            }
      }
      if (copied / 1000 != before / 1000) {
        std::printf("intruder: %llu copied or answered, %u reader(s) matched\n",
                    static_cast<unsigned long long>(copied), writer.Snapshot().publication_matched_current);
        std::fflush(stdout);
      }
      continue;
    }
    if constexpr (std::is_same_v<T, hexa_msg_ValveCommand> || std::is_same_v<T, hexa_msg_LegSetpoint>)
      sample.header.tick += 1;
    if constexpr (std::is_same_v<T, hexa_msg_OperatorCommand>) sample.sequence += 1;
    writer.WriteNow(sample);
    if (++written % 1000 == 1) {
      std::printf("intruder: %llu written, %u reader(s) matched\n",
                  static_cast<unsigned long long>(written), writer.Snapshot().publication_matched_current);
      std::fflush(stdout);
    }
  }
  std::printf("intruder: done: %llu written, %llu copied, up to %u reader(s) matched\n",
              static_cast<unsigned long long>(written), static_cast<unsigned long long>(copied),
              matched_max);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Parser cli("hexa_intruder", "Tries to command a session from outside it (tests).");
  cli.AddOption("domain", "id", "DDS domain id", "0");
  cli.AddChoice("topic", {"valve", "setpoint", "operator"}, "the command topic", "valve");
  cli.AddOption("leg", "N", "the leg whose key is written (valve, setpoint)", "3");
  cli.AddOption("partition", "name", "the writer's partition (default: hexa.legN; operator: the default partition)");
  cli.AddOption("user-data", "text", "the writer's USER_DATA", "leg=3 standby=0");
  cli.AddOption("strength", "N", "ownership strength", "1000");
  cli.AddOption("value", "V", "valve voltage written", "9.88");
  cli.AddChoice("kind", {"start", "stop", "reset", "home", "shutdown"}, "operator command", "stop");
  cli.AddOption("duration", "s", "how long to write", "60");
  cli.AddOption("start-delay", "s", "wait this long before joining the domain (a session's "
                "launcher refuses a domain that already has participants on it)", "0");
  cli.AddOption("first-tick", "N", "valve, setpoint: the tick of the first sample, +1 per sample "
                "(default: far ahead of any real tick)", "1000000000");
  cli.AddFlag("copy", "write back the real samples read in the partition (a replay)");
  cli.AddFlag("follow", "valve: answer every LegSensors sample of the leg (read in the partition) "
              "with --value at its tick, as a controller would");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 230);
  const auto leg = cli.GetInt("leg", 1, 6);
  const auto strength = cli.GetInt("strength", 0, 1 << 30);
  const auto value = cli.GetDouble("value", -1e9, 1e9);
  const auto duration = cli.GetDouble("duration", 0, 3600);
  const auto start_delay = cli.GetDouble("start-delay", 0, 60);
  const auto first_tick = cli.GetInt("first-tick", 0, 1LL << 40);
  if (!domain || !leg || !strength || !value || !duration || !first_tick || !start_delay) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(*start_delay));
  Options o;
  o.domain = static_cast<int>(*domain);
  o.leg = static_cast<int>(*leg);
  o.strength = static_cast<int>(*strength);
  o.value_v = *value;
  o.duration_s = *duration;
  o.user_data = cli.Get("user-data");
  o.copy = cli.Flag("copy");
  o.follow = cli.Flag("follow");
  const std::string topic = cli.Get("topic");
  o.partition = cli.Has("partition") ? cli.Get("partition")
                                     : (topic == "operator" ? "" : comm::LegPartition(o.leg));
  try {
    comm::EnsureDdsConfig();
    comm::Participant p(static_cast<dds_domainid_t>(o.domain));
    if (topic == "valve") {
      hexa_msg_ValveCommand c{};
      c.leg_id = static_cast<uint8_t>(o.leg);
      c.header.tick = static_cast<uint64_t>(*first_tick);
      c.valve_v = o.value_v;
      c.controller = hexa_msg_CONTROLLER_BSSMC;
      return Run(o, p, c);
    }
    if (topic == "setpoint") {
      hexa_msg_LegSetpoint s{};
      s.leg_id = static_cast<uint8_t>(o.leg);
      s.header.tick = static_cast<uint64_t>(*first_tick);
      s.length_m = 0.70;
      return Run(o, p, s);
    }
    hexa_msg_OperatorCommand c{};
    const std::string kind = cli.Get("kind");
    c.kind = kind == "start"   ? hexa_msg_OPERATOR_START
             : kind == "reset" ? hexa_msg_OPERATOR_RESET
             : kind == "home"  ? hexa_msg_OPERATOR_HOME
             : kind == "shutdown" ? hexa_msg_OPERATOR_SHUTDOWN
                                  : hexa_msg_OPERATOR_STOP;
    std::strcpy(c.trajectory, "x");
    o.period_s = 0.05;
    return Run(o, p, c);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "intruder: %s\n", e.what());
    return 1;
  }
}
