// hexa_rogue: a participant that tries to command legs it has no right to (test tool of the
// multi-host security tests, docs/security.md "Rogue participants"). It joins the domain
// with whatever Cyclone configuration CYCLONEDDS_URI gives it (no security, a foreign CA, or
// a valid identity of another leg) and, per --valve PART:KEY, creates a ValveCommand writer in
// partition "leg<PART>" and writes leg KEY's commands with a high ownership strength; with
// --sensors it also tries to publish LegSensors. Every attempt and its outcome is printed
// ("rogue: ..."): refused by DDS Security at creation, or created and how many readers it
// matched and how many samples it wrote.
#include <time.h>

#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/services/cli.hpp"

namespace {

using namespace hexa;

struct ValveAttempt {
  int partition_leg = 0;
  int key_leg = 0;
  std::unique_ptr<comm::Writer<hexa_msg_ValveCommand>> writer;
  uint64_t written = 0;
};

}  // namespace

int main(int argc, char** argv) {
  cli::Parser cli("hexa_rogue", "Tries to command legs without the right to (security tests).");
  cli.AddOption("domain", "id", "DDS domain id", "0");
  cli.AddOption("valve", "PART:KEY",
                "ValveCommand writer in partition legPART writing leg KEY (repeatable as a "
                "comma list, e.g. 4:4,3:4)", "");
  cli.AddFlag("sensors", "also try to publish LegSensors");
  cli.AddOption("strength", "N", "ownership strength of the ValveCommand writers", "1000");
  cli.AddOption("value", "V", "valve voltage written (a value no controller produces)", "9.8765432");
  cli.AddOption("duration", "s", "how long to write (1 kHz)", "2");
  cli.AddOption("match-wait", "s", "wait up to this for readers before writing", "3");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 230);
  const auto strength = cli.GetInt("strength", 0, 1 << 30);
  const auto value = cli.GetDouble("value", -1e9, 1e9);
  const auto duration = cli.GetDouble("duration", 0, 3600);
  const auto match_wait = cli.GetDouble("match-wait", 0, 3600);
  if (!domain || !strength || !value || !duration || !match_wait) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  std::vector<ValveAttempt> valves;
  const std::string spec = cli.Get("valve");
  for (std::size_t pos = 0; pos < spec.size();) {
    const auto comma = spec.find(',', pos);
    const std::string item = spec.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    int p = 0, k = 0;
    if (std::sscanf(item.c_str(), "%d:%d", &p, &k) != 2 || p < 1 || p > 6 || k < 1 || k > 6) {
      std::fprintf(stderr, "error: --valve '%s': expected PART:KEY with legs 1..6\n", item.c_str());
      return 2;
    }
    valves.push_back(ValveAttempt{p, k, nullptr, 0});
    pos = comma == std::string::npos ? spec.size() : comma + 1;
  }

  try {
    comm::EnsureDdsConfig();
  } catch (const std::exception& e) {
    std::printf("rogue: no DDS configuration: %s\n", e.what());
    return 1;
  }
  std::unique_ptr<comm::Participant> participant;
  try {
    participant = std::make_unique<comm::Participant>(static_cast<dds_domainid_t>(*domain));
    std::printf("rogue: participant created on domain %lld\n", *domain);
  } catch (const std::exception& e) {
    std::printf("rogue: participant REFUSED: %s\n", e.what());
    return 3;
  }
  comm::Topic<hexa_msg_ValveCommand> valve_topic(*participant);
  for (auto& v : valves) {
    comm::QosParams q;
    q.ownership_strength = static_cast<int32_t>(*strength);
    // RELIABLE (the lockstep writer QoS: a reliable offer matches reliable and best-effort
    // requests), the default deadline (the nominal 1 ms) and a 10 ms lease: compatible with
    // what the plant's and the recorder's readers request in either mode, so only security
    // decides.
    q.lockstep = true;
    try {
      v.writer = std::make_unique<comm::Writer<hexa_msg_ValveCommand>>(
          *participant, valve_topic, q, std::vector<std::string>{comm::LegPartition(v.partition_leg)});
      std::printf("rogue: ValveCommand writer in partition %s for leg %d: created\n",
                  comm::LegPartition(v.partition_leg).c_str(), v.key_leg);
    } catch (const std::exception& e) {
      std::printf("rogue: ValveCommand writer in partition %s for leg %d: REFUSED (%s)\n",
                  comm::LegPartition(v.partition_leg).c_str(), v.key_leg, e.what());
    }
  }
  std::unique_ptr<comm::Topic<hexa_msg_LegSensors>> sensors_topic;
  std::unique_ptr<comm::Writer<hexa_msg_LegSensors>> sensors;
  if (cli.Flag("sensors")) {
    try {
      sensors_topic = std::make_unique<comm::Topic<hexa_msg_LegSensors>>(*participant);
      comm::QosParams q;
      q.lockstep = true;  // RELIABLE: matches the readers of either mode (above)
      sensors = std::make_unique<comm::Writer<hexa_msg_LegSensors>>(*participant, *sensors_topic, q);
      std::printf("rogue: LegSensors writer: created\n");
    } catch (const std::exception& e) {
      std::printf("rogue: LegSensors writer: REFUSED (%s)\n", e.what());
    }
  }
  std::fflush(stdout);

  comm::WaitSet ws(*participant);
  const int64_t wait_end = comm::RealtimeNow_ns() + static_cast<int64_t>(*match_wait * 1e9);
  auto matched = [&] {
    uint32_t n = 0;
    for (const auto& v : valves)
      if (v.writer) n += v.writer->Snapshot().publication_matched_current;
    if (sensors) n += sensors->Snapshot().publication_matched_current;
    return n;
  };
  while (matched() == 0 && comm::RealtimeNow_ns() < wait_end) ws.Wait(DDS_MSECS(20));

  const int64_t end = comm::RealtimeNow_ns() + static_cast<int64_t>(*duration * 1e9);
  uint64_t tick = 0;
  uint64_t sensors_written = 0;
  while (comm::RealtimeNow_ns() < end) {
    for (auto& v : valves) {
      if (!v.writer) continue;
      hexa_msg_ValveCommand c{};
      c.leg_id = static_cast<uint8_t>(v.key_leg);
      comm::FillHeader(c.header, tick, static_cast<double>(tick) * 1e-3, 0);
      c.valve_v = *value;
      if (v.writer->WriteNow(c) == DDS_RETCODE_OK) ++v.written;
    }
    if (sensors) {
      hexa_msg_LegSensors s{};
      s.leg_id = 4;
      comm::FillHeader(s.header, tick, static_cast<double>(tick) * 1e-3, 0);
      s.length_m = 0.9;
      if (sensors->WriteNow(s) == DDS_RETCODE_OK) ++sensors_written;
    }
    ++tick;
    const timespec period{0, 1'000'000};  // 1 kHz, like a controller
    nanosleep(&period, nullptr);
  }
  for (const auto& v : valves) {
    if (!v.writer) continue;
    std::printf("rogue: ValveCommand partition %s key leg %d: matched %u readers, wrote %llu "
                "samples of %.7g V\n",
                comm::LegPartition(v.partition_leg).c_str(), v.key_leg, v.writer->Snapshot().publication_matched_current,
                static_cast<unsigned long long>(v.written), *value);
  }
  if (sensors)
    std::printf("rogue: LegSensors: matched %u readers, wrote %llu samples\n",
                sensors->Snapshot().publication_matched_current,
                static_cast<unsigned long long>(sensors_written));
  return 0;
}
