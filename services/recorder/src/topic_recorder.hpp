// The recorder's side of a DDS topic, shared by `record` and `play --answers-out`: a reader
// with the recorder's QoS whose samples go to a RecordingWriter as protobuf, with the loss
// seen from tick numbers, refused command samples and the writers it matched.
#pragma once

#include <algorithm>
#include <array>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cli.hpp"
#include "hexa/comm/comm.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/reader.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder::cli {

template <typename T>
int64_t SourceTime_ns(const T& s) {
  if constexpr (requires { s.header.source_time_ns; }) {
    return s.header.source_time_ns;
  } else {
    return s.source_time_ns;
  }
}

// The QoS a profile gives, as channel metadata ("qos.writer.reliability" = "reliable", ...).
void DescribeQos(const dds_qos_t* q, const std::string& prefix,
                 std::map<std::string, std::string>& out);

struct TopicRecorderBase {
  virtual ~TopicRecorderBase() = default;
  virtual dds_entity_t condition() const = 0;
  virtual void Drain(RecordingWriter& w) = 0;
  virtual comm::StatusSnapshot Status() const = 0;
  // The reader, for its matched writers (NoteMatchedWriters).
  virtual dds_entity_t reader() const = 0;
  std::string name;
  uint16_t channel = 0;
  bool periodic = false;
  uint64_t received = 0;
  uint64_t refused = 0;  // command samples not authenticated with the session key
  uint64_t last_tick = 0;  // newest header.tick received (progress lines)
  TickLossTracker loss;
  // Writers this topic's reader could not match (incompatible QoS), as last reported.
  uint32_t incompatible_reported = 0;
  // Every writer this topic's reader has matched so far: GUID (32 hex digits, as on the
  // wire: GUID prefix then entity id) -> "reliable" / "best-effort" and, under exclusive
  // ownership, " strength N". Printed at the stop, so that the datagrams a link
  // dropped can be attributed to topics (bench/deployment/dropped_datagrams.py).
  std::map<std::string, std::string> matched_writers;
  // Called with each recorded message (play --answers-out watches the answers through it).
  std::function<void(const google::protobuf::Message&)> on_sample;
};

template <typename T, typename P>
class TopicRecorder final : public TopicRecorderBase {
 public:
  static constexpr std::size_t kCapacity = 256;
  // The leg controllers write ValveCommand in their leg's partition (docs/security.md, DDS
  // Security): the recorder subscribes to every leg partition and the default one.
  static std::vector<std::string> Partitions() {
    if constexpr (comm::TopicTraits<T>::kKind != comm::TopicKind::kValveCommand) return {};
    return comm::EveryLegPartitionAndDefault();
  }
  TopicRecorder(const comm::Participant& p, RecordingWriter& w, const comm::QosParams& params)
      : topic_(p),
        reader_(p, topic_, comm::EndpointRole::kRecorderReader, params, kCapacity, Partitions()) {
    const comm::TopicKind kind = comm::TopicTraits<T>::kKind;
    name = std::string(comm::TopicName(kind));
    const std::optional<double> period = comm::NominalPeriod_s(kind);
    periodic = period.has_value();
    std::map<std::string, std::string> meta;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", period.value_or(0.0));
    meta[kMetaPeriodS] = buf;
    meta["dds.topic"] = name;
    meta["dds.type"] = comm::TopicTraits<T>::Descriptor()->m_typename;
    DescribeQos(comm::MakeQos(kind, comm::EndpointRole::kWriter, params).get(), "qos.writer.", meta);
    DescribeQos(comm::MakeQos(kind, comm::EndpointRole::kRecorderReader, params).get(),
                "qos.recorder.", meta);
    channel = w.AddTopic(name, *P::descriptor(), std::move(meta));
  }
  dds_entity_t condition() const override { return reader_.data_condition(); }
  comm::StatusSnapshot Status() const override { return reader_.Snapshot(); }
  dds_entity_t reader() const override { return reader_.get(); }
  void Drain(RecordingWriter& w) override {
    for (;;) {
      const int n = reader_.Take();
      if (n <= 0) return;
      // Log time = when this batch was taken: at most --batch-ms after Cyclone received the
      // sample (Cyclone 0.10's sample info has no reception timestamp).
      const uint64_t log_ns = static_cast<uint64_t>(comm::RealtimeNow_ns());
      for (int i = 0; i < n; ++i) {
        if (!reader_.info(i).valid_data) continue;  // dispose / unregister: no sample
        // A command from a writer not of this session is not part of it (docs/faults.md,
        // "Foreign commands"): the plant and the legs refuse it, the recording leaves it out.
        if constexpr (comm::CommandType<T>) {
          if (!comm::Trusted(reader_.Authenticate(static_cast<std::size_t>(i)))) {
            ++refused;
            continue;
          }
        }
        const T& s = reader_.sample(i);
        ToProto(s, msg_);
        w.Write(channel, log_ns, static_cast<uint64_t>(SourceTime_ns(s)), msg_);
        ++received;
        if (on_sample) on_sample(msg_);
        if constexpr (requires { s.header.tick; }) {  // every periodic topic has a header
          if (periodic) loss.AddAt(StreamOf(s), s.header.tick);
          last_tick = std::max<uint64_t>(last_tick, s.header.tick);
        }
      }
      if (static_cast<std::size_t>(n) < kCapacity) return;
    }
  }

 private:
  // Loss-tracker stream of a sample: keyed by leg for the leg topics, one stream otherwise
  // (the keys MessageKey gives the recorded message, looked up once per key, no reflection).
  std::size_t StreamOf(const T& s) {
    std::size_t slot = kKeylessSlot;
    if constexpr (requires { s.leg_id; }) slot = s.leg_id;
    std::optional<std::size_t>& index = stream_of_key_[slot];
    if (!index) {
      index = loss.StreamIndex(slot == kKeylessSlot
                                   ? std::string()
                                   : LegStreamKey(static_cast<uint32_t>(slot)));
    }
    return *index;
  }

  comm::Topic<T> topic_;
  comm::Reader<T> reader_;
  P msg_;
  static constexpr std::size_t kKeylessSlot = 256;  // leg_id is a uint8_t
  std::array<std::optional<std::size_t>, kKeylessSlot + 1> stream_of_key_{};  // [leg_id]
};

// Adds the writers the topic's reader matches now to t.matched_writers (called every flush;
// a writer that comes and goes between two flushes is missed, none does in a session; at
// most 64 per topic are read, far above a deployment's 9 ValveCommand writers).
void NoteMatchedWriters(TopicRecorderBase& t);

// Says on stderr, once per new count, that writers of `t`'s topic do not match the recorder
// and why (Cyclone's requested-incompatible-QoS status names the last policy): their
// samples are not recorded. The usual cause: a real-time session's periodic writers offer
// BEST_EFFORT and the recorder was started without --periodic-reliability best-effort.
void ReportIncompatibleWriters(TopicRecorderBase& t, const std::string& periodic_reliability);

// --domain N (0..232, default 0).
dds_domainid_t ParseDomain(const Args& a);

}  // namespace hexa::recorder::cli
