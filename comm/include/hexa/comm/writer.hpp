// Writer<T>: a data writer with the named QoS profile of T's topic and status counters.
// Writes always carry an explicit source timestamp (dds_write_ts).
#pragma once

#include <dds/dds.h>

#include <memory>
#include <string>

#include "hexa/comm/error.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/status.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"

namespace hexa::comm {

template <typename T>
concept HasHeader = requires(T t) { t.header.source_time_ns; };
template <typename T>
concept HasSourceTime = requires(T t) { t.source_time_ns; };

template <WireType T>
class Writer {
 public:
  static constexpr TopicKind kKind = TopicTraits<T>::kKind;

  Writer(const Participant& participant, const Topic<T>& topic, const QosParams& params = {})
      : counters_(std::make_unique<StatusCounters>()) {
    const Qos qos = MakeQos(kKind, EndpointRole::kWriter, params);
    dds_listener_t* listener = counters_->CreateListener();
    const dds_entity_t w = dds_create_writer(participant.get(), topic.get(), qos.get(), listener);
    dds_delete_listener(listener);
    entity_ = OwnedEntity(CheckDds(w, "cannot create writer on " + std::string(TopicName(kKind))));
  }

  // Publishes `sample` with source timestamp `source_time_ns` (CLOCK_REALTIME ns). Never
  // blocks for the keep-last profiles; returns DDS_RETCODE_OK or the error.
  dds_return_t Write(const T& sample, int64_t source_time_ns) {
    return dds_write_ts(entity_.get(), &sample, source_time_ns);
  }

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

  StatusSnapshot Snapshot() const { return counters_->Snapshot(); }
  const StatusCounters& status() const { return *counters_; }
  dds_entity_t get() const { return entity_.get(); }

 private:
  // Heap-allocated so the listener's pointer survives moves of the Writer. Declared before
  // entity_ so that it is destroyed after dds_delete (which waits for running callbacks).
  std::unique_ptr<StatusCounters> counters_;
  OwnedEntity entity_;
};

}  // namespace hexa::comm
