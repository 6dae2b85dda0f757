// Reader<T>: a data reader with the named QoS profile of T's topic, status counters and
// preallocated sample storage. Take()/Read() deserialize into that storage: the wire types
// of idl/hexa.idl are flat (bounded strings are char arrays), so the steady state allocates
// nothing. TakeLatestForLeg() reads one leg's newest sample through a cached instance handle.
#pragma once

#include <dds/dds.h>

#include <array>
#include <cstddef>
#include <cstring>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hexa/comm/command_auth.hpp"
#include "hexa/comm/error.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/status.hpp"
#include "hexa/comm/topic.hpp"

namespace hexa::comm {

// Describes a matched writer seen by `reader`: "guid=... participant=... strength=N";
// empty if it is no longer matched. Allocates: not for the cycle.
std::string DescribeMatchedWriter(dds_entity_t reader, dds_instance_handle_t publication);
// Who a matched writer is, for a refused command: "guid G partition 'P' strength N
// user_data 'U'" (USER_DATA's printable bytes only, at most 64). Allocates: not for the cycle.
std::string DescribeWriterIdentity(dds_entity_t reader, dds_instance_handle_t publication);
// Ownership strength of a matched writer, -1 if unknown.
int32_t MatchedWriterStrength(dds_entity_t reader, dds_instance_handle_t publication);
// USER_DATA of a matched writer (QosParams::user_data); nullopt when it is no longer matched.
// Allocates: not for the cycle.
std::optional<std::string> MatchedWriterUserData(dds_entity_t reader,
                                                 dds_instance_handle_t publication);

template <WireType T>
class Reader {
 public:
  static constexpr TopicKind kKind = TopicTraits<T>::kKind;
  static constexpr uint32_t kMaxLegs = 16;

  // `capacity`: the most samples one Take()/Read() returns (the recorder wants more).
  // `partitions`: the reader's subscriber partitions (partition.hpp); empty = the default
  // partition.
  Reader(const Participant& participant, const Topic<T>& topic,
         EndpointRole role = EndpointRole::kControlReader, const QosParams& params = {},
         std::size_t capacity = 16, const std::vector<std::string>& partitions = {})
      : counters_(std::make_unique<StatusCounters>()),
        subscriber_(CreateSubscriber(participant, partitions)),
        storage_(capacity),
        buffers_(capacity),
        infos_(capacity) {
    if (capacity == 0) throw std::invalid_argument("Reader capacity must be >= 1");
    for (std::size_t i = 0; i < capacity; ++i) buffers_[i] = &storage_[i];
    const Qos qos = MakeQos(kKind, role, params);
    dds_listener_t* listener = counters_->CreateListener();
    const dds_entity_t parent = subscriber_ ? subscriber_.get() : participant.get();
    const dds_entity_t r = dds_create_reader(parent, topic.get(), qos.get(), listener);
    dds_delete_listener(listener);
    entity_ = OwnedEntity(CheckDds(r, "cannot create reader on " + std::string(TopicName(kKind))));
    // Triggers while unread samples exist; attach it to a WaitSet to wake on data.
    data_condition_ = OwnedEntity(CheckDds(
        dds_create_readcondition(entity_.get(), DDS_NOT_READ_SAMPLE_STATE | DDS_ANY_VIEW_STATE |
                                                    DDS_ANY_INSTANCE_STATE),
        "cannot create read condition on " + std::string(TopicName(kKind))));
    resolved_leg_.fill(-1);
  }

  // Calls `callback(arg)` from Cyclone's receive thread each time data arrives, before any
  // WaitSet wakes: the work then runs without a hand-over to another thread (one context
  // switch less per sample; docs/performance.md). The callback must not block for long;
  // samples already in the reader when it is installed do not trigger it (take them once
  // after). `callback` nullptr removes it: on return no call is running or will start
  // (Cyclone's dds_set_listener waits for a running listener). Setup time only (allocates).
  void OnDataAvailable(DataCallback callback, void* arg) {
    if (callback != nullptr) counters_->SetDataCallback(callback, arg);
    dds_listener_t* listener = counters_->CreateListener(callback != nullptr);
    const dds_return_t rc = dds_set_listener(entity_.get(), listener);
    dds_delete_listener(listener);
    CheckDds(rc, "cannot set data listener on " + std::string(TopicName(kKind)));
    if (callback == nullptr) counters_->SetDataCallback(nullptr, nullptr);
  }

  // Takes (removes) up to capacity samples. Returns the count (>= 0) or a negative
  // dds_return_t. Samples with info(i).valid_data == false carry only a key (dispose,
  // unregister).
  int Take() { return Store(dds_take(entity_.get(), buffers_.data(), infos_.data(),
                                     buffers_.size(), static_cast<uint32_t>(buffers_.size()))); }
  // Like Take() but leaves the samples in the reader (marked read).
  int Read() { return Store(dds_read(entity_.get(), buffers_.data(), infos_.data(),
                                     buffers_.size(), static_cast<uint32_t>(buffers_.size()))); }

  // Command topics: whether sample i of the last Take()/Read() comes from one of the
  // session's processes (command_auth.hpp). No allocation except the first sample of a writer
  // not seen before (its GUID prefix is looked up).
  CommandTrust Authenticate(std::size_t i)
    requires CommandType<T>
  {
    if (mac_ == nullptr) return CommandTrust::kUnchecked;
    ParticipantPrefix writer{};
    if (!prefixes_.Find(entity_.get(), infos_[i].publication_handle, writer))
      return CommandTrust::kUnknownWriter;
    return VerifyCommand(*mac_, writer, storage_[i]) ? CommandTrust::kAuthenticated
                                                     : CommandTrust::kBadTag;
  }

  std::size_t count() const { return count_; }
  const T& sample(std::size_t i) const { return storage_[i]; }
  const dds_sample_info_t& info(std::size_t i) const { return infos_[i]; }
  std::span<const T> samples() const { return {storage_.data(), count_}; }
  std::span<const dds_sample_info_t> infos() const { return {infos_.data(), count_}; }

  // Newest valid sample of leg `leg_id` (take: removes that leg's samples; read: keeps them).
  // Returns 1 when `out` was filled, 0 when there is none, a negative dds_return_t on error.
  // The instance handle is looked up (an allocating call) only until the leg's first sample
  // has arrived; afterwards each call is one dds_take_instance into preallocated storage.
  int TakeLatestForLeg(uint8_t leg_id, T& out, dds_sample_info_t* info = nullptr)
    requires LegKeyed<T>
  {
    return LatestForLeg(leg_id, out, info, true);
  }
  int ReadLatestForLeg(uint8_t leg_id, T& out, dds_sample_info_t* info = nullptr)
    requires LegKeyed<T>
  {
    return LatestForLeg(leg_id, out, info, false);
  }

  // Requested-deadline misses attributed to leg `leg_id` (resolves instance handles to keys;
  // not for the cycle: dds_instance_get_key may allocate the first time).
  uint32_t DeadlineMissedForLeg(uint8_t leg_id)
    requires LegKeyed<T>
  {
    uint32_t total = 0;
    const auto& slots = counters_->instances();
    for (std::size_t i = 0; i < slots.size(); ++i) {
      const dds_instance_handle_t handle = slots[i].handle.load(std::memory_order_acquire);
      if (handle == 0) break;  // slots are claimed in order
      if (resolved_leg_[i] < 0) {
        T key{};
        if (dds_instance_get_key(entity_.get(), handle, &key) == DDS_RETCODE_OK) {
          resolved_leg_[i] = key.leg_id;
        }
      }
      if (resolved_leg_[i] == leg_id) {
        total += slots[i].deadline_missed.load(std::memory_order_relaxed);
      }
    }
    return total;
  }

  std::string DescribeWriter(dds_instance_handle_t publication) const {
    return DescribeMatchedWriter(entity_.get(), publication);
  }

  StatusSnapshot Snapshot() const { return counters_->Snapshot(); }
  const StatusCounters& status() const { return *counters_; }
  dds_entity_t get() const { return entity_.get(); }
  dds_entity_t data_condition() const { return data_condition_.get(); }

 private:
  int Store(dds_return_t n) {
    count_ = n > 0 ? static_cast<std::size_t>(n) : 0;
    return n;
  }

  int LatestForLeg(uint8_t leg_id, T& out, dds_sample_info_t* info, bool take) {
    const uint32_t slot = leg_id % kMaxLegs;
    if (leg_handles_[slot] == 0 || leg_ids_[slot] != leg_id) {
      T key{};
      key.leg_id = leg_id;
      const dds_instance_handle_t h = dds_lookup_instance(entity_.get(), &key);
      if (h == DDS_HANDLE_NIL) return 0;  // nothing of this leg has arrived yet
      leg_handles_[slot] = h;
      leg_ids_[slot] = leg_id;
    }
    const uint32_t maxs = static_cast<uint32_t>(buffers_.size());
    const dds_return_t n =
        take ? dds_take_instance(entity_.get(), buffers_.data(), infos_.data(), buffers_.size(),
                                 maxs, leg_handles_[slot])
             : dds_read_instance(entity_.get(), buffers_.data(), infos_.data(), buffers_.size(),
                                 maxs, leg_handles_[slot]);
    if (n < 0) {
      // The instance may have been purged; look it up again next time.
      if (n == DDS_RETCODE_PRECONDITION_NOT_MET || n == DDS_RETCODE_BAD_PARAMETER) {
        leg_handles_[slot] = 0;
        Store(0);
        return 0;
      }
      Store(0);
      return n;
    }
    Store(n);
    for (int i = n - 1; i >= 0; --i) {  // samples come oldest first
      if (infos_[i].valid_data) {
        out = storage_[i];
        if (info != nullptr) *info = infos_[i];
        return 1;
      }
    }
    return 0;
  }

  // Destroyed after the entities (declared first): dds_delete waits for running callbacks.
  std::unique_ptr<StatusCounters> counters_;
  OwnedEntity subscriber_;  // only with partitions; deleted after the reader
  std::vector<T> storage_;
  std::vector<void*> buffers_;
  std::vector<dds_sample_info_t> infos_;
  std::size_t count_ = 0;
  std::array<dds_instance_handle_t, kMaxLegs> leg_handles_{};
  std::array<uint8_t, kMaxLegs> leg_ids_{};
  std::array<int16_t, StatusCounters::kMaxInstances> resolved_leg_{};
  const CommandMac* mac_ = InstalledCommandMac();  // command topics: verifies when set
  PublicationPrefixCache prefixes_;
  OwnedEntity entity_;
  OwnedEntity data_condition_;
};

}  // namespace hexa::comm
