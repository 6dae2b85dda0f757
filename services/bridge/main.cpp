// hexa_bridge: serves a running session's DDS topics, and the 3-D scene, to Foxglove over the
// Foxglove WebSocket protocol (docs/foxglove.md). A topic is read from DDS only while some
// client subscribes to it (or to the scene, which needs ground truth, pose reports, valve
// commands and fault events), through best-effort keep-last readers: an idle bridge costs
// the control loop nothing, a watched one one more datagram per watched sample, and a slow
// client only its own drops (ws_server.hpp).
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <cinttypes>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/scene.hpp"
#include "hexa/recording/topic_types.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/logging.hpp"
#include "hexa/services/scheduling.hpp"
#include "operator_forward.hpp"
#include "ws_server.hpp"

namespace {

using hexa::bridge::ChannelInfo;
using hexa::bridge::Server;
namespace comm = hexa::comm;
namespace recorder = hexa::recorder;
namespace rec = hexa::rec;

// After the topic channels (1 + TopicKind).
constexpr uint32_t kSceneChannel = 1 + comm::kTopicKindCount;
constexpr uint32_t kTransformsChannel = kSceneChannel + 1;
constexpr std::size_t kTake = 64;  // samples per dds_take

// Channel id of a DDS topic: 1 + its TopicKind.
uint32_t ChannelOf(comm::TopicKind kind) { return 1 + static_cast<uint32_t>(kind); }

bool SceneInput(comm::TopicKind k) {
  return k == comm::TopicKind::kGroundTruth || k == comm::TopicKind::kPoseReport ||
         k == comm::TopicKind::kValveCommand || k == comm::TopicKind::kFaultEvent;
}

struct Context {
  Server* server = nullptr;
  recorder::SceneBuilder* scene = nullptr;
  bool scene_watched = false;
  std::string buffer;
  uint64_t samples = 0;
};

struct SourceBase {
  virtual ~SourceBase() = default;
  virtual void Create(const comm::Participant& p, comm::WaitSet& ws) = 0;
  virtual void Destroy(comm::WaitSet& ws) = 0;
  virtual bool active() const = 0;
  virtual void Drain(Context& ctx) = 0;
  virtual const google::protobuf::Descriptor* descriptor() const = 0;
  comm::TopicKind kind{};
};

template <typename T, typename P>
class Source final : public SourceBase {
 public:
  explicit Source(const comm::Participant& p) : topic_(p) {
    kind = comm::TopicTraits<T>::kKind;
    for (std::size_t i = 0; i < kTake; ++i) buffers_[i] = &storage_[i];
  }
  ~Source() override { Release(); }
  const google::protobuf::Descriptor* descriptor() const override { return P::descriptor(); }
  bool active() const override { return reader_ != 0; }
  void Create(const comm::Participant& p, comm::WaitSet& ws) override {
    if (reader_ != 0) return;
    // The recorder's reader QoS (matches every writer: no deadline, exclusive ownership for
    // valve commands, ...) made lighter for the periodic topics: best effort, keep-last, volatile.
    // The writers then keep nothing for the bridge and never resend to it.
    comm::Qos qos = comm::MakeQos(kind, comm::EndpointRole::kRecorderReader);
    if (comm::NominalPeriod_s(kind).has_value()) {
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 32);
      dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
    }
    if (kind == comm::TopicKind::kValveCommand) {
      // The leg controllers write in their leg's partition (docs/security.md).
      const auto partitions = comm::EveryLegPartitionAndDefault();
      std::vector<const char*> names;
      for (const auto& n : partitions) names.push_back(n.c_str());
      dds_qset_partition(qos.get(), static_cast<uint32_t>(names.size()), names.data());
    }
    reader_ = comm::CheckDds(dds_create_reader(p.get(), topic_.get(), qos.get(), nullptr),
                             "cannot create reader on " + std::string(comm::TopicName(kind)));
    condition_ = comm::CheckDds(
        dds_create_readcondition(reader_, DDS_ANY_SAMPLE_STATE | DDS_ANY_VIEW_STATE |
                                              DDS_ANY_INSTANCE_STATE),
        "cannot create read condition");
    ws.Attach(condition_, 2 + static_cast<dds_attach_t>(kind));
  }
  void Destroy(comm::WaitSet& ws) override {
    if (reader_ == 0) return;
    ws.Detach(condition_);
    Release();
  }
  void Drain(Context& ctx) override {
    if (reader_ == 0) return;
    const uint32_t channel = ChannelOf(kind);
    for (;;) {
      const dds_return_t n = dds_take(reader_, buffers_.data(), infos_.data(), kTake, kTake);
      if (n <= 0) return;
      const auto now = static_cast<uint64_t>(comm::RealtimeNow_ns());
      const bool watched = ctx.server->Watched(channel);
      for (dds_return_t i = 0; i < n; ++i) {
        if (!infos_[i].valid_data) continue;
        ++ctx.samples;
        recorder::ToProto(storage_[i], msg_);
        if (watched) {
          ctx.buffer.clear();
          msg_.AppendToString(&ctx.buffer);
          ctx.server->Publish(channel, now, ctx.buffer);
        }
        if (ctx.scene_watched && ctx.scene->Add(msg_)) {
          ctx.scene->Build(now);
          if (ctx.server->Watched(kTransformsChannel))
            ctx.server->Publish(kTransformsChannel, now, ctx.scene->transforms().SerializeAsString());
          if (ctx.server->Watched(kSceneChannel))
            ctx.server->Publish(kSceneChannel, now, ctx.scene->scene().SerializeAsString());
        }
      }
      if (static_cast<std::size_t>(n) < kTake) return;
    }
  }

 private:
  void Release() {
    if (reader_ != 0) dds_delete(reader_);  // deletes the read condition too
    reader_ = condition_ = 0;
  }
  comm::Topic<T> topic_;
  dds_entity_t reader_ = 0, condition_ = 0;
  std::array<T, kTake> storage_{};
  std::array<void*, kTake> buffers_{};
  std::array<dds_sample_info_t, kTake> infos_{};
  P msg_;
};

// CPU affinity and niceness for the whole process, logged; a refusal leaves it as it was.
void SchedulePolitely(const std::vector<int>& cpus, int nice, spdlog::logger& log) {
  std::string message;
  if (!cpus.empty()) {
    const bool ok = hexa::sched::SetCpuAffinity(cpus, message);
    if (ok) log.info("{}", message);
    else log.warn("{}", message);
  }
  if (nice > 0 && setpriority(PRIO_PROCESS, 0, nice) != 0)
    log.warn("niceness {} not applied: {}", nice, std::strerror(errno));
  else if (nice > 0)
    log.info("niceness {}", nice);
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_bridge",
                        "Serves the DDS topics of a running session and its 3-D scene over the "
                        "Foxglove WebSocket protocol (open ws://HOST:PORT in Foxglove).");
  cli.AddOption("domain", "id", "DDS domain id of the session", "0");
  cli.AddOption("dds-config", "file", "Cyclone DDS configuration (default: loopback only)");
  cli.AddOption("listen", "address",
                "IP address to serve on; the default serves this machine only. Give the "
                "control network's address to let other hosts connect", "127.0.0.1");
  cli.AddOption("port", "n", "TCP port (0 = any free port, printed at start)", "8765");
  cli.AddOption("client-queue-kb", "n",
                "per client: KiB of messages waiting for its socket (counted with their "
                "allocation overhead) before messages are dropped for that client (and counted)",
                "4096");
  cli.AddOption("max-clients", "n",
                "clients served at once; more connections are refused with HTTP 503 (logged)",
                "32");
  cli.AddOption("total-queue-mb", "n",
                "MiB of messages waiting for all clients together: each client's queue is "
                "capped at min(--client-queue-kb, this / --max-clients)", "128");
  cli.AddOption("cpus", "list|auto|none",
                "pin the bridge (every thread) to these CPUs; auto: off the CPU a session's "
                "control loop takes by default (hexa_session --cpus-control auto)", "auto");
  cli.AddOption("nice", "n", "scheduling niceness of every thread (0 = normal, 19 = lowest)",
                "10");
  cli.AddOption("stats-s", "s", "log every client's sent / dropped counts this often (0 = only "
                "when a client leaves)", "5");
  cli.AddFlag("operator-input",
              "accept the operator's commands (start stop reset home) from Foxglove clients on "
              "topic hexa_OperatorInput and forward them to the supervisor: whoever can connect "
              "can then move the platform (docs/foxglove.md, \"Operator input\")");
  cli.AddOption("operator-input-rate-hz", "hz",
                "per client: operator inputs a second beyond which they are refused", "10");
  cli.AddFlag("operator-input-any-host",
              "allow --operator-input with a --listen address other than loopback");
  cli.AddOption("rig", "file", "rig file whose joints the 3-D scene draws",
                hexa::config::DefaultRigFile());
  cli.AddOption("profile", "name", "disturbance profile of the simulated plant (with --seed)");
  cli.AddOption("seed", "n", "seed of the simulated plant: the scene draws its true joints");
  cli.AddOption("scene-hz", "hz", "3-D scene frames per simulated second", "50");
  cli.AddOption("log-file", "file", "also log to this file");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 232);
  const auto port = cli.GetInt("port", 0, 65535);
  const auto queue_kb = cli.GetInt("client-queue-kb", 1, 1 << 20);
  const auto max_clients = cli.GetInt("max-clients", 1, 4096);
  const auto total_queue_mb = cli.GetInt("total-queue-mb", 1, 1 << 16);
  const auto nice = cli.GetInt("nice", 0, 19);
  const auto operator_rate_hz = cli.GetDouble("operator-input-rate-hz", 0.1, 100);
  const auto stats_s = cli.GetDouble("stats-s", 0, 3600);
  const auto scene_hz = cli.GetDouble("scene-hz", 1, 1000);
  std::optional<long long> seed;
  if (cli.Has("seed")) seed = cli.GetInt("seed", 0, 1LL << 62);
  std::vector<int> cpus;
  if (cli.Get("cpus") == "auto") {
    cpus = hexa::sched::AutoCpuSplit().others;
  } else if (cli.Get("cpus") != "none" && !hexa::sched::ParseCpuList(cli.Get("cpus"), cpus)) {
    std::fprintf(stderr, "hexa_bridge: error: --cpus '%s': expected CPU numbers such as 1, 0,1 "
                 "or 0-1, auto or none\n", cli.Get("cpus").c_str());
    return 2;
  }
  if (!domain || !port || !queue_kb || !max_clients || !total_queue_mb || !nice || !stats_s ||
      !scene_hz || !operator_rate_hz || (cli.Has("seed") && !seed)) {
    std::fprintf(stderr, "hexa_bridge: error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
  }
  const bool operator_input = cli.Flag("operator-input");
  const bool loopback = cli.Get("listen").rfind("127.", 0) == 0 || cli.Get("listen") == "::1";
  if (operator_input && !loopback && !cli.Flag("operator-input-any-host")) {
    std::fprintf(stderr, "hexa_bridge: error: --operator-input with --listen %s: every host that "
                 "can reach it could move the platform; add --operator-input-any-host to mean "
                 "it (docs/foxglove.md)\n", cli.Get("listen").c_str());
    return 2;
  }
  auto log = hexa::logging::Init("bridge", cli.Has("log-file") ? cli.Get("log-file") : "");
  // Before any thread exists (Cyclone's, the WebSocket I/O thread): they inherit both.
  SchedulePolitely(cpus, static_cast<int>(*nice), *log);
  try {
    std::optional<std::string> dds_config;
    if (cli.Has("dds-config")) dds_config = cli.Get("dds-config");
    comm::EnsureDdsConfig(dds_config);
    // The session key (HEXA_SESSION_KEY, set by hexa_session): the operator commands this
    // bridge forwards are signed with it, or the supervisor refuses them (docs/faults.md).
    if (const char* key_path = std::getenv(comm::kSessionKeyEnvironment); key_path != nullptr && *key_path) {
      std::string error;
      const auto key = comm::ReadSessionKey(key_path, error);
      if (!key) {
        log->error("{} ({})", error, comm::kSessionKeyEnvironment);
        return 2;
      }
      comm::InstallSessionKey(*key);
    } else if (operator_input) {
      log->warn("no session key ($HEXA_SESSION_KEY): forwarded operator commands are not signed "
                "and a supervisor with a key refuses them");
    }

    recorder::SceneOptions scene_options = recorder::SceneOptionsFromRig(
        cli.Get("rig"), cli.Has("profile") ? cli.Get("profile") : "",
        seed ? std::optional<uint64_t>(static_cast<uint64_t>(*seed)) : std::nullopt);
    scene_options.period_ticks = static_cast<uint64_t>(std::llround(1000.0 / *scene_hz));
    recorder::SceneBuilder scene(scene_options);

    comm::Participant participant(static_cast<dds_domainid_t>(*domain));
    comm::ShutdownGuard shutdown(participant);
    comm::GuardCondition demand(participant);
    comm::WaitSet waitset(participant, 16);
    waitset.Attach(shutdown.guard_condition(), 0);
    waitset.Attach(demand.get(), 1);
    constexpr dds_attach_t kOperatorToken = 100;
    comm::GuardCondition operator_wake(participant);
    std::unique_ptr<hexa::bridge::OperatorForwarder> forwarder;
    if (operator_input) {
      forwarder = std::make_unique<hexa::bridge::OperatorForwarder>(participant, operator_wake, log);
      waitset.Attach(operator_wake.get(), kOperatorToken);
    }

    std::vector<std::unique_ptr<SourceBase>> sources;
    recorder::ForEachTopicType([&](auto type) {
      using Type = decltype(type);
      sources.push_back(std::make_unique<Source<typename Type::Dds, typename Type::Proto>>(participant));
    });

    std::vector<ChannelInfo> channels;
    for (const auto& s : sources) {
      channels.push_back({ChannelOf(s->kind), std::string(comm::TopicName(s->kind)),
                          s->descriptor()->full_name(),
                          recorder::FileDescriptorSetFor(*s->descriptor())});
    }
    channels.push_back({kSceneChannel, recorder::kSceneTopic,
                        foxglove::SceneUpdate::descriptor()->full_name(),
                        recorder::FileDescriptorSetFor(*foxglove::SceneUpdate::descriptor())});
    channels.push_back({kTransformsChannel, recorder::kTransformsTopic,
                        foxglove::FrameTransforms::descriptor()->full_name(),
                        recorder::FileDescriptorSetFor(*foxglove::FrameTransforms::descriptor())});

    hexa::bridge::ServerConfig sc;
    sc.listen_address = cli.Get("listen");
    sc.port = static_cast<uint16_t>(*port);
    sc.client_queue_bytes = static_cast<std::size_t>(*queue_kb) * 1024;
    sc.max_clients = static_cast<std::size_t>(*max_clients);
    sc.total_queue_bytes = static_cast<std::size_t>(*total_queue_mb) << 20;
    sc.operator_input = operator_input;
    sc.operator_input_rate_hz = *operator_rate_hz;
    sc.operator_input_burst = std::max(1.0, *operator_rate_hz);
    Server server(sc, channels, log);
    server.OnDemandChange([&demand] { demand.Set(true); });
    if (forwarder) {
      server.OnOperatorInput([&forwarder](uint64_t id, const std::string& remote,
                                          const hexa::bridge::OperatorInput& input) {
        return forwarder->Submit(id, remote, input);
      });
    }
    server.Start();
    log->info("serving {} channels on ws://{}:{} (Foxglove WebSocket protocol), DDS domain {}; "
              "scene joints: {}", channels.size(), sc.listen_address, server.port(), *domain,
              scene_options.geometry_note);
    log->info("at most {} clients, each queue capped at {} KiB (charged with allocation "
              "overhead), {} MiB for all together", sc.max_clients,
              sc.EffectiveClientQueueBytes() >> 10, sc.total_queue_bytes >> 20);
    if (!loopback)
      log->warn("--listen {}: other hosts can connect (no authentication)", sc.listen_address);
    if (operator_input)
      log->warn("operator input ON: any client that can connect to ws://{}:{} can start, stop, "
                "reset and home the platform (topic {}, at most {} a second per client)",
                sc.listen_address, server.port(), hexa::bridge::kOperatorInputTopic,
                *operator_rate_hz);

    Context ctx;
    ctx.server = &server;
    ctx.scene = &scene;
    auto update_readers = [&] {
      ctx.scene_watched = server.Watched(kSceneChannel) || server.Watched(kTransformsChannel);
      for (auto& s : sources) {
        const bool want = server.Watched(ChannelOf(s->kind)) ||
                          (ctx.scene_watched && SceneInput(s->kind));
        if (want && !s->active()) {
          s->Create(participant, waitset);
          log->info("reading {} from DDS", comm::TopicName(s->kind));
        } else if (!want && s->active()) {
          s->Destroy(waitset);
          log->info("no client watches {}: its DDS reader is deleted", comm::TopicName(s->kind));
        }
      }
    };
    const int64_t stats_ns = static_cast<int64_t>(*stats_s * 1e9);
    int64_t next_stats = comm::RealtimeNow_ns() + (stats_ns > 0 ? stats_ns : INT64_MAX / 2);
    while (!shutdown.requested()) {
      const dds_return_t rc = waitset.WaitUntil(static_cast<dds_time_t>(next_stats));
      if (rc < 0) throw std::runtime_error("waitset failed: " + std::string(dds_strretcode(rc)));
      if (waitset.Triggered(1)) {
        demand.Set(false);
        update_readers();
      }
      if (forwarder) {
        if (waitset.Triggered(kOperatorToken)) operator_wake.Set(false);
        forwarder->WritePending();
      }
      for (auto& s : sources) s->Drain(ctx);
      const int64_t now = comm::RealtimeNow_ns();
      if (stats_ns > 0 && now >= next_stats) {
        next_stats = now + stats_ns;
        const auto stats = server.Stats();
        for (const auto& c : stats)
          log->info("client {} ({}): {} subscriptions, sent {} messages ({} bytes), dropped {} "
                    "(queue full), {} messages ({} bytes) queued", c.id, c.remote,
                    c.subscriptions, c.sent, c.sent_bytes, c.dropped, c.queued_messages,
                    c.queued_bytes);
        if (!stats.empty() || server.refused_connections() > 0)
          log->info("{} clients, {} bytes queued for all (peak {}), {} connections refused",
                    stats.size(), server.queued_bytes(), server.queued_peak_bytes(),
                    server.refused_connections());
        if (server.inbox_drops() > 0)
          log->warn("{} messages dropped before reaching any client (inbox full)",
                    server.inbox_drops());
      }
      // Take in batches (as the recorder does): one wake-up per 2 ms, not per sample.
      const timespec pause{0, 2'000'000};
      nanosleep(&pause, nullptr);
    }
    log->info("stopping: {} DDS samples read, {} protocol errors, {} inbox drops", ctx.samples,
              server.protocol_errors(), server.inbox_drops());
    server.Stop();
    for (auto& s : sources) s->Destroy(waitset);
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  return 0;
}
