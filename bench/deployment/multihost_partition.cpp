// hexa_multihost_bench's partition scenario (multihost_session.hpp): a real-time session
// driven by the operator; legs-a is cut off for --partition-ms, healed, the session reset and
// started again; the detection delay, HOLD and resumption from the plant's log and the
// recording.
#include <algorithm>
#include <cstdio>
#include <regex>
#include <thread>
#include <vector>

#include "hexa/recording/recording.hpp"
#include "multihost_session.hpp"
#include "recording.pb.h"

namespace hexa::deploy::multihost {

namespace rec = hexa::rec;

void Partition(const LabSessionOptions& base, double partition_ms, const std::string& operator_bin) {
  LabSessionOptions o = base;
  o.realtime = true;
  o.supervisor_args = {"--trajectory", "z", "--periods", "1"};
  std::string err;
  auto s = LabSession::Create(o, err);
  if (!s) {
    std::printf("partition: setup failed: %s\n", err.c_str());
    return;
  }
  if (!s->StartAll(err)) {
    std::printf("partition: start failed: %s\n", err.c_str());
    return;
  }
  const std::string load = LoadAverage();
  for (int i = 0; i < 600 && !s->units().Seen("hexa-plant").ready; ++i) {
    s->Wait(200ms);
    s->units().Poll();
  }
  const std::string config = s->DdsConfigOf("io-sup");
  auto op = [&](const std::string& what) {
    // The deployment's session key lies beside its DDS configuration (hexa_deploy generate).
    std::map<std::string, std::string> env{
        {"HEXA_IDENTITY", "operator"},
        {"HEXA_SESSION_KEY", config.substr(0, config.rfind('/')) + "/session.key"}};
    const int rc = RunToCompletion(s->group(), "operator-" + what,
                                   s->lab().InHost("io-sup", {operator_bin, "--domain", std::to_string(o.domain),
                                                              "--dds-config", config, "--trajectory", "z",
                                                              "--wait", "20", what}),
                                   s->work_dir() + "/operator-" + what + ".log", 30s, env);
    std::printf("partition: operator %s -> exit %d\n", what.c_str(), rc);
  };
  auto sleep_for = [&](double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      s->Wait(100ms);
      s->units().Poll();
    }
  };
  sleep_for(2.0);  // the pose estimate settles
  op("start");
  sleep_for(5.0);  // blending, then tracking
  const long long before = s->lab().DroppedByPartition("legs-a");
  (void)before;
  if (!s->lab().Partition("legs-a", err)) std::printf("partition: %s\n", err.c_str());
  std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(partition_ms));
  const long long dropped = s->lab().DroppedByPartition("legs-a");
  if (!s->lab().Heal("legs-a", err)) std::printf("heal: %s\n", err.c_str());
  sleep_for(1.5);
  op("reset");
  sleep_for(1.0);
  op("start");
  sleep_for(16.0);  // blend + one 10 s period + stop
  s->StopAll();

  // What the recording says: the plant's first fault after the cut, the last command of
  // legs 1-3 before it, the supervisor's states.
  const std::string mcap = s->Recording();
  struct Fault {
    std::uint64_t tick;
    std::uint32_t leg;
    std::string source, reason;
  };
  std::vector<Fault> faults;
  std::vector<std::pair<std::uint64_t, int>> states;  // tick, state (changes only)
  hexa::recorder::ReadRecording(mcap, [&](const hexa::recorder::McapChannel& ch,
                                          const hexa::recorder::McapMessageView&,
                                          const google::protobuf::Message& msg) {
    // The decoded messages are dynamic (built from the recording's schema): re-parse them
    // into the generated types.
    if (ch.topic == "hexa_FaultEvent") {
      rec::FaultEvent f;
      f.ParseFromString(msg.SerializeAsString());
      faults.push_back({f.tick(), f.leg_id(), f.source_node(), rec::FaultReason_Name(f.reason())});
    } else if (ch.topic == "hexa_PoseReport") {
      rec::PoseReport p;
      p.ParseFromString(msg.SerializeAsString());
      if (states.empty() || states.back().second != static_cast<int>(p.state()))
        states.emplace_back(p.header().tick(), static_cast<int>(p.state()));
    }
  });
  std::printf("partition of legs-a for %.0f ms (%s, load %s): %lld packets dropped by the cut\n", partition_ms,
              o.secure ? "secured" : "plain", load.c_str(), dropped);
  // Detection: the plant's first stale-command fault of a leg on the cut host, and the tick
  // its last command answered (from the plant's log: the recording on another host also got
  // retransmissions after the heal, so it cannot say what reached the plant when).
  const std::string plant_log = Slurp(s->units().LogOf("hexa-plant"));
  std::smatch m;
  // Either the command ages past the tolerance ("stale", answers tick N) or, first since the
  // 10 ms valve lease, its writer lapses ("liveliness lost", last answer: tick N).
  if (std::regex_search(plant_log, m, std::regex("leg ([123]) tick ([0-9]+): (?:valve command stale \\([^,]*, answers|liveliness lost: [^(]*\\(last answer:) tick ([0-9]+)\\)"))) {
    const long long at = std::stoll(m[2]), answered = std::stoll(m[3]);
    std::printf("  plant: leg %s stale or lapsed at tick %lld, its newest command answered tick %lld: detected %lld ticks "
                "(ms) after the last command that arrived (tolerance --stale-ticks %d: a command older than "
                "that is stale)\n",
                m[1].str().c_str(), at, answered, at - answered, o.stale_ticks > 0 ? o.stale_ticks : 15);
  } else {
    std::printf("  no stale-command or liveliness fault of legs 1-3 in the plant's log\n");
  }
  if (std::regex_search(plant_log, m, std::regex("leg ([123]) tick ([0-9]+): valve command valid again")))
    std::printf("  plant: leg %s valid again at tick %s\n", m[1].str().c_str(), m[2].str().c_str());
  static const char* kNames[] = {"IDLE", "BLENDING", "TRACKING", "STOPPING", "HOLD"};
  std::printf("  supervisor states (tick: state; a HOLD after the last IDLE comes from stopping the processes):");
  for (const auto& [t, st] : states) std::printf(" %llu:%s", static_cast<unsigned long long>(t), kNames[st]);
  std::printf("\n  faults recorded: %zu (first few:", faults.size());
  for (std::size_t i = 0; i < std::min<std::size_t>(faults.size(), 6); ++i)
    std::printf(" [%s leg %u tick %llu %s]", faults[i].source.c_str(), faults[i].leg,
                static_cast<unsigned long long>(faults[i].tick), faults[i].reason.c_str());
  std::printf(")\n  logs: %s\n", s->work_dir().c_str());
}

}  // namespace hexa::deploy::multihost
