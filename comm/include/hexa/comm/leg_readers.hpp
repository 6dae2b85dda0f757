// LegReaders<T>: one reader per leg partition (LegPartition(1..6), partition.hpp) of a
// leg-keyed topic. The plant reads ValveCommand this way: EXCLUSIVE ownership is decided
// per reader and instance, so with one reader per leg only leg N's writers (with DDS Security:
// only leg N's identities, docs/security.md) compete for leg N's instance. With a single
// reader of every partition, a writer allowed in some other leg's partition could write
// leg N's key with a higher strength and take leg N's instance over: its samples would be
// refused, but the real controller's would no longer arrive either.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "hexa/comm/participant.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/reader.hpp"
#include "hexa/comm/topic.hpp"

namespace hexa::comm {

// What a reader that wants every leg's ValveCommand subscribes to: the default partition
// (tools and tests writing several legs from one writer) and every leg's partition (the leg
// controllers). The recorder and the Foxglove bridge read ValveCommand this way.
inline std::vector<std::string> EveryLegPartitionAndDefault() {
  std::vector<std::string> all{""};
  for (const auto& leg : AllLegPartitions()) all.push_back(leg);
  return all;
}

template <WireType T>
  requires LegKeyed<T>
class LegReaders {
 public:
  static constexpr int kLegs = 6;

  LegReaders(const Participant& participant, const Topic<T>& topic, EndpointRole role,
             const QosParams& params, std::size_t capacity = 16) {
    readers_.reserve(kLegs);
    for (int leg = 1; leg <= kLegs; ++leg) {
      readers_.emplace_back(participant, topic, role, params, capacity,
                            std::vector<std::string>{LegPartition(leg)});
    }
  }

  // The same data callback on every leg's reader (Reader::OnDataAvailable).
  void OnDataAvailable(DataCallback callback, void* arg) {
    for (auto& r : readers_) r.OnDataAvailable(callback, arg);
  }

  // The reader of leg `leg` (1..6). A sample it returns whose leg_id is not `leg` came from
  // a writer in leg `leg`'s partition that wrote another leg's key: refuse it.
  Reader<T>& leg(int leg) { return readers_[static_cast<std::size_t>(leg - 1)]; }
  const Reader<T>& leg(int leg) const { return readers_[static_cast<std::size_t>(leg - 1)]; }

  // Counters summed over the six readers (the reader-side totals and match counts).
  StatusSnapshot Snapshot() const {
    StatusSnapshot sum;
    for (const auto& r : readers_) {
      const StatusSnapshot s = r.Snapshot();
      sum.requested_deadline_missed_total += s.requested_deadline_missed_total;
      sum.requested_incompatible_qos_total += s.requested_incompatible_qos_total;
      sum.sample_lost_total += s.sample_lost_total;
      sum.sample_rejected_total += s.sample_rejected_total;
      sum.liveliness_alive_count += s.liveliness_alive_count;
      sum.liveliness_not_alive_count += s.liveliness_not_alive_count;
      sum.liveliness_changed_events += s.liveliness_changed_events;
      sum.liveliness_lost_events += s.liveliness_lost_events;
      sum.subscription_matched_current += s.subscription_matched_current;
      sum.subscription_matched_total += s.subscription_matched_total;
      sum.instance_slot_overflow += s.instance_slot_overflow;
    }
    return sum;
  }

 private:
  std::vector<Reader<T>> readers_;
};

}  // namespace hexa::comm
