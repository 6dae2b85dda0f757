// Writer<T>: a data writer with the named QoS profile of T's topic and status counters.
// Writes always carry an explicit source timestamp (dds_write_ts).
#pragma once

#include <dds/dds.h>

#include <memory>
#include <string>
#include <vector>

#include "hexa/comm/command_auth.hpp"
#include "hexa/comm/error.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/status.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"

namespace hexa::comm {

// Write batching, process-wide (Cyclone's dds_write_set_batch): every writer created after
// this call keeps what it writes in its outgoing packet until it is flushed. Writer<T>::Write()
// flushes at once, so only WriteDeferred() + Flush() batch: the plant writes six legs' sensor
// samples and sends them to each reader in one datagram (on loopback every reader process
// gets its own datagram per send; docs/performance.md). Switched on through the Participant
// (WriteBatching::kOn), before any writer exists, in a process whose writers are all Writer<T>.
void EnableWriteBatching();
bool WriteBatchingEnabled();

// Readers matched by `writer` whose USER_DATA is exactly `user_data` (QosParams::user_data).
// Allocates: not for the cycle.
int CountMatchedReadersWithUserData(dds_entity_t writer, const std::string& user_data);

template <typename T>
concept HasHeader = requires(T t) { t.header.source_time_ns; };
template <typename T>
concept HasSourceTime = requires(T t) { t.source_time_ns; };

template <WireType T>
class Writer {
 public:
  static constexpr TopicKind kKind = TopicTraits<T>::kKind;

  // `partitions`: the writer's publisher partitions (partition.hpp); empty = the default
  // partition.
  Writer(const Participant& participant, const Topic<T>& topic, const QosParams& params = {},
         const std::vector<std::string>& partitions = {})
      : counters_(std::make_unique<StatusCounters>()),
        publisher_(CreatePublisher(participant, partitions)) {
    const Qos qos = MakeQos(kKind, EndpointRole::kWriter, params);
    dds_listener_t* listener = counters_->CreateListener();
    const dds_entity_t parent = publisher_ ? publisher_.get() : participant.get();
    const dds_entity_t w = dds_create_writer(parent, topic.get(), qos.get(), listener);
    dds_delete_listener(listener);
    entity_ = OwnedEntity(CheckDds(w, "cannot create writer on " + std::string(TopicName(kKind))));
    if constexpr (CommandType<T>) {
      // Command topics: every sample is signed with the session key (command_auth.hpp).
      mac_ = InstalledCommandMac();
      dds_guid_t guid{};
      if (mac_ != nullptr) CheckDds(dds_get_guid(entity_.get(), &guid), "cannot get a writer's GUID");
      prefix_ = PrefixOf(guid);
    }
  }

  // Publishes `sample` with source timestamp `source_time_ns` (CLOCK_REALTIME ns). Never
  // blocks for the keep-last profiles; returns DDS_RETCODE_OK or the error.
  dds_return_t Write(const T& sample, int64_t source_time_ns) {
    const dds_return_t rc = WriteDeferred(sample, source_time_ns);
    if (rc == DDS_RETCODE_OK && WriteBatchingEnabled()) Flush();
    return rc;
  }
  // With write batching on (EnableWriteBatching), queues the sample in this writer's packet
  // until Flush(): the samples written between two flushes reach each reader in one
  // datagram. Without batching it is Write(). A failed write is counted (status()).
  // A command sample is written with its auth_tag set (a copy: the caller's is unchanged).
  dds_return_t WriteDeferred(const T& sample, int64_t source_time_ns) {
    dds_return_t rc;
    if constexpr (CommandType<T>) {
      T signed_sample = sample;
      if (mac_ != nullptr) SignCommand(*mac_, prefix_, signed_sample);
      rc = dds_write_ts(entity_.get(), &signed_sample, source_time_ns);
    } else {
      rc = dds_write_ts(entity_.get(), &sample, source_time_ns);
    }
    if (rc != DDS_RETCODE_OK) counters_->CountWriteError(rc);
    return rc;
  }
  // Sends what WriteDeferred() queued (nothing to do without batching).
  void Flush() { dds_write_flush(entity_.get()); }
  // Blocks until every matched reliable reader has acknowledged everything written, or
  // `timeout` (DDS_RETCODE_TIMEOUT). Never from a receive-thread callback: the acknowledgements
  // arrive on that thread.
  dds_return_t WaitForAcks(dds_duration_t timeout) { return dds_wait_for_acks(entity_.get(), timeout); }

  // Stamps the sample's own source time field with the clock now and writes it with that
  // same timestamp, so the sample and the DDS source timestamp always agree.
  dds_return_t WriteNow(T& sample)
    requires(HasHeader<T> || HasSourceTime<T>)
  {
    const int64_t now_ns = RealtimeNow_ns();
    if constexpr (HasHeader<T>) {
      sample.header.source_time_ns = now_ns;
    } else {
      sample.source_time_ns = now_ns;
    }
    return Write(sample, now_ns);
  }

  // MANUAL_BY_TOPIC liveliness: a write also asserts it; call this in cycles that do not
  // write (e.g. holding) so the plant does not see the controller as dead.
  dds_return_t AssertLiveliness() { return dds_assert_liveliness(entity_.get()); }

  // Unregisters (without disposing, for ValveCommand) the instance of `key_sample`.
  dds_return_t Unregister(const T& key_sample) {
    return dds_unregister_instance(entity_.get(), &key_sample);
  }
  // Disposes the instance of `key_sample`: its readers see NOT_ALIVE_DISPOSED (a writer that
  // withdraws its data on purpose; a crashed one never disposes).
  dds_return_t Dispose(const T& key_sample) {
    const dds_return_t rc = dds_dispose(entity_.get(), &key_sample);
    if (rc != DDS_RETCODE_OK) counters_->CountWriteError(rc);
    return rc;
  }

  StatusSnapshot Snapshot() const { return counters_->Snapshot(); }
  const StatusCounters& status() const { return *counters_; }
  dds_entity_t get() const { return entity_.get(); }

 private:
  // Heap-allocated so the listener's pointer survives moves of the Writer. Declared before
  // entity_ so that it is destroyed after dds_delete (which waits for running callbacks).
  std::unique_ptr<StatusCounters> counters_;
  OwnedEntity publisher_;  // only with partitions; deleted after the writer
  OwnedEntity entity_;
  const CommandMac* mac_ = nullptr;  // command topics with a session key: signs
  ParticipantPrefix prefix_{};
};

// A leg-keyed topic (LegSensors, LegSetpoint) written for two kinds of reader at once:
// leg N's sample in partition LegPartition(N), where only leg N's controllers (primary and
// standby) read it, and all six in the default partition, where the supervisor, the recorder
// and any tool read the topic as one keyed stream. With write batching on (the plant, the
// supervisor) the six samples of the default partition leave in one datagram per reader.
// A leg controller then receives one datagram with one sample per tick: no topic filter
// (Cyclone 0.10 filters in the reader, after delivery, and each filtered-out sample costs a
// key-map entry freed by its garbage-collector thread: a wake-up per sample;
// docs/performance.md).
template <WireType T>
  requires LegKeyed<T>
class LegRoutedWriter {
 public:
  static constexpr int kLegs = 6;
  LegRoutedWriter(const Participant& participant, const Topic<T>& topic,
                  const QosParams& params = {})
      : all_(participant, topic, params) {
    legs_.reserve(kLegs);
    for (int leg = 1; leg <= kLegs; ++leg)
      legs_.emplace_back(participant, topic, params, std::vector<std::string>{LegPartition(leg)});
  }
  // Queues `sample` for its leg's controllers and for the all-legs readers; Flush() sends.
  dds_return_t WriteDeferred(const T& sample, int64_t source_time_ns) {
    dds_return_t rc = all_.WriteDeferred(sample, source_time_ns);
    if (sample.leg_id >= 1 && sample.leg_id <= kLegs) {
      const dds_return_t leg_rc = legs_[sample.leg_id - 1].WriteDeferred(sample, source_time_ns);
      if (rc == DDS_RETCODE_OK) rc = leg_rc;
    }
    return rc;
  }
  void Flush() {
    all_.Flush();
    for (auto& w : legs_) w.Flush();
  }
  // To the leg's controllers only (the lockstep re-ask of one silent leg), sent at once.
  dds_return_t WriteToLegOnly(const T& sample, int64_t source_time_ns) {
    if (sample.leg_id < 1 || sample.leg_id > kLegs) return DDS_RETCODE_BAD_PARAMETER;
    Writer<T>& w = legs_[sample.leg_id - 1];
    const dds_return_t rc = w.WriteDeferred(sample, source_time_ns);
    w.Flush();
    return rc;
  }
  // Disposes `key_sample`'s instance for the leg's controllers and the all-legs readers.
  dds_return_t Dispose(const T& key_sample) {
    dds_return_t rc = all_.Dispose(key_sample);
    if (key_sample.leg_id >= 1 && key_sample.leg_id <= kLegs) {
      const dds_return_t leg_rc = legs_[key_sample.leg_id - 1].Dispose(key_sample);
      if (rc == DDS_RETCODE_OK) rc = leg_rc;
    }
    Flush();
    return rc;
  }
  Writer<T>& all() { return all_; }
  Writer<T>& leg(int leg_id) { return legs_.at(static_cast<std::size_t>(leg_id - 1)); }
  uint32_t write_errors_total() const {
    uint32_t n = all_.Snapshot().write_errors_total;
    for (const auto& w : legs_) n += w.Snapshot().write_errors_total;
    return n;
  }

 private:
  Writer<T> all_;
  std::vector<Writer<T>> legs_;
};

}  // namespace hexa::comm
