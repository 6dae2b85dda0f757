// hexa_recorder_link_writer: a leg controller's ValveCommand writer without the controller
// (test tool of RecorderLink.*, tests/netns/test_recorder_link.cpp). It writes leg --leg's
// commands in that leg's partition with the production real-time writer QoS
// (comm::MakeQos(kValveCommand, kWriter): BEST_EFFORT, keep-last history, 10 ms liveliness
// lease), or with --lockstep-writer the lockstep one (RELIABLE), once --readers readers
// matched (0: at once), after --settle-s (the test sets up its fault meanwhile), at
// --rate-hz, ticks 0..--samples-1; then waits --drain-s and prints the writer's Cyclone
// statistics: what the readers' acknowledgements made it do.
//   "matched N"  (before the settle pause)
//   "statistics: <every statistic Cyclone keeps for the writer>"
//   "written N write_errors E max_write_us M rexmit_bytes B throttle_count T"
// max_write_us is printed for the reader of the log, never asserted (no timed assertions).
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <string>

#include <dds/ddsc/dds_statistics.h>

#include "hexa/comm/comm.hpp"
#include "hexa/services/cli.hpp"

namespace {

using namespace hexa;

int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

void SleepUntil(int64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1000000000LL), static_cast<long>(t_ns % 1000000000LL)};
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

// -1 when Cyclone has no such statistic (the test then finds no number and fails).
long long Statistic(const dds_statistics* st, const char* name) {
  const dds_stat_keyvalue* kv = st ? dds_lookup_statistic(st, name) : nullptr;
  if (kv == nullptr) return -1;
  return static_cast<long long>(kv->kind == DDS_STAT_KIND_UINT32 ? kv->u.u32 : kv->u.u64);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Parser cli("hexa_recorder_link_writer", "A leg's ValveCommand writer for the recorder-link tests.");
  cli.AddOption("domain", "id", "DDS domain id", "0");
  cli.AddOption("leg", "N", "leg whose commands are written (its partition)", "3");
  cli.AddOption("samples", "N", "samples to write", "3000");
  cli.AddOption("rate-hz", "Hz", "write rate", "1000");
  cli.AddOption("readers", "N", "matched readers to wait for", "1");
  cli.AddOption("match-wait-s", "s", "wait up to this for the readers", "60");
  cli.AddOption("settle-s", "s", "pause between the match and the first write", "2");
  cli.AddOption("drain-s", "s", "pause after the last write before the statistics", "1");
  cli.AddOption("lease-s", "s", "the writer's liveliness lease (production: 0.010 in real time)", "0.010");
  cli.AddFlag("lockstep-writer", "the lockstep writer QoS (RELIABLE) instead of the real-time one (BEST_EFFORT)");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 230);
  const auto leg = cli.GetInt("leg", 1, 6);
  const auto samples = cli.GetInt("samples", 1, 10000000);
  const auto rate = cli.GetDouble("rate-hz", 1, 100000);
  const auto readers = cli.GetInt("readers", 0, 100);
  const auto match_wait = cli.GetDouble("match-wait-s", 0, 3600);
  const auto settle = cli.GetDouble("settle-s", 0, 3600);
  const auto drain = cli.GetDouble("drain-s", 0, 3600);
  const auto lease = cli.GetDouble("lease-s", 0.001, 3600);
  if (!domain || !leg || !samples || !rate || !readers || !match_wait || !settle || !drain || !lease) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  try {
    comm::EnsureDdsConfig(std::nullopt);
    comm::Participant participant(static_cast<dds_domainid_t>(*domain));
    comm::Topic<hexa_msg_ValveCommand> topic(participant);
    comm::QosParams params;
    params.valve_liveliness_lease_s = *lease;
    params.lockstep = cli.Flag("lockstep-writer");
    const comm::Qos qos = comm::MakeQos(comm::TopicKind::kValveCommand, comm::EndpointRole::kWriter, params);
    const comm::OwnedEntity publisher =
        comm::CreatePublisher(participant, {comm::LegPartition(static_cast<int>(*leg))});
    const comm::OwnedEntity writer(
        comm::CheckDds(dds_create_writer(publisher.get(), topic.get(), qos.get(), nullptr), "cannot create the writer"));
    auto matched = [&] {
      dds_publication_matched_status_t st{};
      dds_get_publication_matched_status(writer.get(), &st);
      return st.current_count;
    };
    const int64_t give_up = MonotonicNs() + static_cast<int64_t>(*match_wait * 1e9);
    while (matched() < static_cast<uint32_t>(*readers)) {
      if (MonotonicNs() > give_up) {
        std::fprintf(stderr, "no %lld readers after %.0f s\n", static_cast<long long>(*readers), *match_wait);
        return 3;
      }
      SleepUntil(MonotonicNs() + 10000000);
    }
    std::printf("matched %u\n", matched());
    std::fflush(stdout);
    SleepUntil(MonotonicNs() + static_cast<int64_t>(*settle * 1e9));
    hexa_msg_ValveCommand c{};
    c.leg_id = static_cast<uint8_t>(*leg);
    c.valve_v = 5.0;
    const int64_t period = static_cast<int64_t>(1e9 / *rate);
    int64_t next = MonotonicNs();
    int64_t max_write_ns = 0;
    long long errors = 0;
    for (long long i = 0; i < *samples; ++i) {
      SleepUntil(next);
      next += period;
      c.header.tick = static_cast<uint64_t>(i);
      c.header.sim_time_s = static_cast<double>(i) * 1e-3;
      const int64_t t0 = MonotonicNs();
      if (dds_write_ts(writer.get(), &c, comm::RealtimeNow_ns()) != DDS_RETCODE_OK) ++errors;
      max_write_ns = std::max(max_write_ns, MonotonicNs() - t0);
    }
    SleepUntil(MonotonicNs() + static_cast<int64_t>(*drain * 1e9));
    dds_statistics* st = dds_create_statistics(writer.get());
    if (st != nullptr) dds_refresh_statistics(st);
    if (st != nullptr) {
      std::printf("statistics:");
      for (std::size_t i = 0; i < st->count; ++i) std::printf(" %s %lld", st->kv[i].name, Statistic(st, st->kv[i].name));
      std::printf("\n");
    }
    std::printf("written %lld write_errors %lld max_write_us %lld rexmit_bytes %lld throttle_count %lld\n",
                static_cast<long long>(*samples), errors, static_cast<long long>(max_write_ns / 1000),
                Statistic(st, "rexmit_bytes"), Statistic(st, "throttle_count"));
    std::fflush(stdout);
    if (st != nullptr) dds_delete_statistics(st);
    return st != nullptr ? 0 : 4;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
