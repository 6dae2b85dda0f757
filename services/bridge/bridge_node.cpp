#include "bridge_node.hpp"

#include <time.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

#include "hexa/comm/command_auth.hpp"
#include "hexa/recording/topic_types.hpp"
#include "hexa/services/exit_code.hpp"

namespace hexa::bridge {
namespace {

// The bridge's own wait set (room for every source's read condition): tokens 0 shutdown,
// 1 demand, 2 + TopicKind a source's data (dds_sources.hpp), 100 an operator input.
constexpr dds_attach_t kShutdownToken = 0;
constexpr dds_attach_t kDemandToken = 1;
constexpr dds_attach_t kOperatorToken = 100;

node::CommonOptions RuntimeOptions(const BridgeOptions& o) {
  node::CommonOptions common;
  common.domain_id = o.domain_id;
  common.dds_config = o.dds_config;
  common.log_file = o.log_file;
  return common;
}

recorder::SceneOptions SceneOptionsOf(const BridgeOptions& o) {
  recorder::SceneOptions scene = recorder::SceneOptionsFromRig(o.rig_path, o.profile, o.seed);
  scene.period_ticks = static_cast<uint64_t>(std::llround(1000.0 / o.scene_hz));
  return scene;
}

template <typename T, typename P>
void AddSource(std::vector<std::unique_ptr<SourceBase>>& sources, const comm::Participant& p) {
  sources.push_back(std::make_unique<Source<T, P>>(p));
}

}  // namespace

bool InstallSessionKey(const BridgeOptions& options, spdlog::logger& log) {
  const char* key_path = std::getenv(comm::kSessionKeyEnvironment);
  if (key_path != nullptr && *key_path) {
    std::string error;
    const auto key = comm::ReadSessionKey(key_path, error);
    if (!key) {
      log.error("{} ({})", error, comm::kSessionKeyEnvironment);
      return false;
    }
    comm::InstallSessionKey(*key);
  } else if (options.server.operator_input) {
    log.warn("no session key ($HEXA_SESSION_KEY): forwarded operator commands are not signed "
             "and a supervisor with a key refuses them");
  }
  return true;
}

BridgeNode::BridgeNode(const BridgeOptions& options, std::shared_ptr<spdlog::logger> log)
    : options_(options),
      log_(log),
      runtime_(RuntimeOptions(options), "bridge", std::move(log), comm::WriteBatching::kOff,
               services::StatusTopic::kNone),
      scene_options_(SceneOptionsOf(options)),
      scene_(scene_options_),
      demand_(runtime_.participant()),
      operator_wake_(runtime_.participant()),
      waitset_(runtime_.participant(), 16) {
  const comm::Participant& participant = runtime_.participant();
  waitset_.Attach(runtime_.shutdown().guard_condition(), kShutdownToken);
  waitset_.Attach(demand_.get(), kDemandToken);
  if (options.server.operator_input) {
    forwarder_ = std::make_unique<OperatorForwarder>(participant, operator_wake_, log_);
    waitset_.Attach(operator_wake_.get(), kOperatorToken);
  }
  recorder::ForEachTopicType([&](auto type) {
    using Type = decltype(type);
    AddSource<typename Type::Dds, typename Type::Proto>(sources_, participant);
  });
  server_ = std::make_unique<Server>(options.server, Channels(), log_);
  server_->OnDemandChange([this] { demand_.Set(true); });
  if (forwarder_) {
    server_->OnOperatorInput([this](uint64_t id, const std::string& remote,
                                    const OperatorInput& input) {
      return forwarder_->Submit(id, remote, input);
    });
  }
  context_.server = server_.get();
  context_.scene = &scene_;
}

std::vector<ChannelInfo> BridgeNode::Channels() const {
  std::vector<ChannelInfo> channels;
  for (const auto& s : sources_) {
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
  return channels;
}

void BridgeNode::UpdateReaders() {
  Server& server = *server_;
  context_.scene_watched = server.Watched(kSceneChannel) || server.Watched(kTransformsChannel);
  for (auto& s : sources_) {
    const bool want = server.Watched(ChannelOf(s->kind)) ||
                      (context_.scene_watched && SceneInput(s->kind));
    if (want && !s->active()) {
      s->Create(runtime_.participant(), waitset_);
      log_->info("reading {} from DDS", comm::TopicName(s->kind));
    } else if (!want && s->active()) {
      s->Destroy(waitset_);
      log_->info("no client watches {}: its DDS reader is deleted", comm::TopicName(s->kind));
    }
  }
}

void BridgeNode::LogStats() {
  const Server& server = *server_;
  const auto stats = server.Stats();
  for (const auto& c : stats)
    log_->info("client {} ({}): {} subscriptions, sent {} messages ({} bytes), dropped {} "
               "(queue full), {} messages ({} bytes) queued", c.id, c.remote,
               c.subscriptions, c.sent, c.sent_bytes, c.dropped, c.queued_messages,
               c.queued_bytes);
  if (!stats.empty() || server.refused_connections() > 0)
    log_->info("{} clients, {} bytes queued for all (peak {}), {} connections refused",
               stats.size(), server.queued_bytes(), server.queued_peak_bytes(),
               server.refused_connections());
  if (server.inbox_drops() > 0)
    log_->warn("{} messages dropped before reaching any client (inbox full)",
               server.inbox_drops());
}

void BridgeNode::LogServing() {
  const ServerConfig& sc = options_.server;
  log_->info("serving {} channels on ws://{}:{} (Foxglove WebSocket protocol), DDS domain {}; "
             "scene joints: {}", sources_.size() + 2, sc.listen_address, server_->port(),
             options_.domain_id, scene_options_.geometry_note);
  log_->info("at most {} clients, each queue capped at {} KiB (charged with allocation "
             "overhead), {} MiB for all together", sc.max_clients,
             sc.EffectiveClientQueueBytes() >> 10, sc.total_queue_bytes >> 20);
  if (!options_.loopback())
    log_->warn("--listen {}: other hosts can connect (no authentication)", sc.listen_address);
  if (sc.operator_input)
    log_->warn("operator input ON: any client that can connect to ws://{}:{} can start, stop, "
               "reset and home the platform (topic {}, at most {} a second per client)",
               sc.listen_address, server_->port(), kOperatorInputTopic,
               sc.operator_input_rate_hz);
}

int BridgeNode::Run() {
  runtime_.Start({}, "starting");
  runtime_.NoPeersToWaitFor();
  server_->Start();
  runtime_.Running({}, "serving", "serving");
  LogServing();
  const int64_t stats_ns = static_cast<int64_t>(options_.stats_s * 1e9);
  int64_t next_stats = comm::RealtimeNow_ns() + (stats_ns > 0 ? stats_ns : INT64_MAX / 2);
  while (!runtime_.shutdown_requested()) {
    const dds_return_t rc = waitset_.WaitUntil(static_cast<dds_time_t>(next_stats));
    if (rc < 0) throw std::runtime_error("waitset failed: " + std::string(dds_strretcode(rc)));
    if (waitset_.Triggered(kDemandToken)) {
      demand_.Set(false);
      UpdateReaders();
    }
    if (forwarder_) {
      if (waitset_.Triggered(kOperatorToken)) operator_wake_.Set(false);
      forwarder_->WritePending();
    }
    for (auto& s : sources_) s->Drain(context_);
    const int64_t now = comm::RealtimeNow_ns();
    if (stats_ns > 0 && now >= next_stats) {
      next_stats = now + stats_ns;
      LogStats();
    }
    // Take in batches (as the recorder does): one wake-up per 2 ms, not per sample.
    const timespec pause{0, 2'000'000};
    nanosleep(&pause, nullptr);
  }
  runtime_.Stop({}, "stopped");
  log_->info("stopping: {} DDS samples read, {} protocol errors, {} inbox drops", context_.samples,
             server_->protocol_errors(), server_->inbox_drops());
  server_->Stop();
  for (auto& s : sources_) s->Destroy(waitset_);
  return exit_code::kOk;
}

}  // namespace hexa::bridge
