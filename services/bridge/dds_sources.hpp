// The DDS side of hexa_bridge: one source per topic, whose reader exists only while some
// client watches its channel (or the scene, which needs ground truth, pose reports, valve
// commands and fault events). Best-effort keep-last readers: an idle bridge costs the control
// loop nothing, a watched one one more datagram per watched sample. Drain() takes in batches
// into preallocated storage and hands each sample to the server and the scene builder.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/scene.hpp"
#include "ws_server.hpp"

namespace hexa::bridge {

// After the topic channels (1 + TopicKind).
inline constexpr uint32_t kSceneChannel = 1 + comm::kTopicKindCount;
inline constexpr uint32_t kTransformsChannel = kSceneChannel + 1;
inline constexpr std::size_t kTake = 64;  // samples per dds_take

// Channel id of a DDS topic: 1 + its TopicKind.
inline uint32_t ChannelOf(comm::TopicKind kind) { return 1 + static_cast<uint32_t>(kind); }

inline bool SceneInput(comm::TopicKind k) {
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

}  // namespace hexa::bridge
