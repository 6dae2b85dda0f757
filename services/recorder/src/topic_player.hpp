// Playback writers of `play`: one per recorded topic, publishing the recorded protobuf
// messages as DDS samples with the comm profile's writer QoS (and in each leg's partition for
// the leg-keyed topics).
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hexa/comm/comm.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/recording/convert.hpp"

namespace hexa::recorder::cli {

struct TopicPlayerBase {
  virtual ~TopicPlayerBase() = default;
  // false: the message could not be converted (reported once per channel by the caller).
  virtual bool Publish(std::string_view data) = 0;
  // The decoded message (reused by the next call), nullptr if the bytes do not parse.
  virtual const google::protobuf::Message* Parse(std::string_view data) = 0;
  virtual comm::StatusSnapshot Status() const = 0;
  // Blocks until every matched reliable reader has acknowledged every sample written.
  virtual dds_return_t WaitForAcks(dds_duration_t timeout) = 0;
  std::string topic;
  uint64_t published = 0;
  uint64_t refused = 0;
};

template <typename T, typename P>
class TopicPlayer final : public TopicPlayerBase {
 public:
  // The comm profile's writer QoS; `keep_all` (lockstep replay) replaces the keep-last history
  // by KEEP_ALL so that a reliable reader that falls behind throttles the writer (Cyclone
  // blocks dds_write while too much is unacknowledged) instead of losing samples that the
  // keep-last history would have overwritten.
  TopicPlayer(const comm::Participant& p, const comm::QosParams& params, bool keep_all)
      : topic_(p) {
    const comm::TopicKind kind = comm::TopicTraits<T>::kKind;
    topic = std::string(comm::TopicName(kind));
    const comm::Qos qos = comm::MakeQos(kind, comm::EndpointRole::kWriter, params);
    if (keep_all) {
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    }
    writer_ = comm::OwnedEntity(comm::CheckDds(
        dds_create_writer(p.get(), topic_.get(), qos.get(), nullptr),
        "cannot create writer on " + topic));
    // Leg-keyed topics are also written in each leg's partition, as the plant and the
    // supervisor do (comm::LegRoutedWriter): that is where leg controllers read them.
    if constexpr (comm::LegKeyed<T>) {
      for (int leg = 1; leg <= kRoutedLegs; ++leg) {
        leg_publishers_[leg - 1] = comm::CreatePublisher(p, {comm::LegPartition(leg)});
        leg_writers_[leg - 1] = comm::OwnedEntity(comm::CheckDds(
            dds_create_writer(leg_publishers_[leg - 1].get(), topic_.get(), qos.get(), nullptr),
            "cannot create writer on " + topic + " for leg " + std::to_string(leg)));
      }
    }
  }
  const google::protobuf::Message* Parse(std::string_view data) override {
    return msg_.ParseFromArray(data.data(), static_cast<int>(data.size())) ? &msg_ : nullptr;
  }
  // Matched readers over the writers: a leg controller matches its leg's writer, the
  // recorder and the supervisor the default-partition one.
  comm::StatusSnapshot Status() const override {
    comm::StatusSnapshot s;
    for (dds_entity_t w : Writers()) {
      dds_publication_matched_status_t m{};
      if (dds_get_publication_matched_status(w, &m) == DDS_RETCODE_OK) {
        s.publication_matched_current += m.current_count;
        s.publication_matched_total += m.total_count;
      }
    }
    return s;
  }
  dds_return_t WaitForAcks(dds_duration_t timeout) override {
    dds_return_t rc = DDS_RETCODE_OK;
    for (dds_entity_t w : Writers()) {
      const dds_return_t r = dds_wait_for_acks(w, timeout);
      if (r != DDS_RETCODE_OK) rc = r;
    }
    return rc;
  }
  bool Publish(std::string_view data) override {
    T sample{};
    if (!msg_.ParseFromArray(data.data(), static_cast<int>(data.size())) ||
        !FromProto(msg_, sample)) {
      ++refused;
      return false;
    }
    // The sample keeps its recorded header; DDS gets the replay time as source timestamp.
    // A keep-all writer may time out while a reader catches up: try again (bounded).
    const int64_t now_ns = comm::RealtimeNow_ns();
    Write(writer_.get(), sample, now_ns);
    if constexpr (comm::LegKeyed<T>) {
      if (sample.leg_id >= 1 && sample.leg_id <= kRoutedLegs)
        Write(leg_writers_[sample.leg_id - 1].get(), sample, now_ns);
    }
    ++published;
    return true;
  }

 private:
  static constexpr int kRoutedLegs = 6;
  void Write(dds_entity_t writer, const T& sample, int64_t source_time_ns) {
    dds_return_t rc = DDS_RETCODE_TIMEOUT;
    for (int attempt = 0; attempt < 30 && rc == DDS_RETCODE_TIMEOUT; ++attempt)
      rc = dds_write_ts(writer, &sample, source_time_ns);
    if (rc < 0) throw std::runtime_error("write on " + topic + " failed: " +
                                         std::string(dds_strretcode(rc)));
  }
  std::vector<dds_entity_t> Writers() const {
    std::vector<dds_entity_t> all{writer_.get()};
    for (const auto& w : leg_writers_)
      if (w) all.push_back(w.get());
    return all;
  }
  comm::Topic<T> topic_;
  comm::OwnedEntity writer_;
  std::array<comm::OwnedEntity, kRoutedLegs> leg_publishers_;  // leg-keyed topics only
  std::array<comm::OwnedEntity, kRoutedLegs> leg_writers_;
  P msg_;
};

// Thrown out of a scan when SIGINT / SIGTERM asks playback to stop.
struct StopPlayback {};

}  // namespace hexa::recorder::cli
