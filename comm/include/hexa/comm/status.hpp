// Communication status counters a service reads and reports (NodeStatus, FaultEvent).
// Cyclone's listeners write them from its own threads: the callbacks only store into
// lock-free atomics and claim fixed slots with compare-and-swap, no lock, no allocation.
// Instance handles (leg) and publication handles (which writer) are resolved to keys /
// GUIDs later, outside the callbacks (Reader<T>::DeadlineMissedForLeg, DescribeWriter).
#pragma once

#include <dds/dds.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace hexa::comm {

// Counts attributed to one instance (reader: a leg's key; writer: an instance it writes).
struct InstanceSlot {
  std::atomic<dds_instance_handle_t> handle{0};  // 0 = free
  std::atomic<uint32_t> deadline_missed{0};
  std::atomic<int64_t> last_miss_mono_ns{0};
};

enum class WriterLiveliness : int32_t { kUnknown = 0, kAlive = 1, kNotAlive = 2, kGone = 3 };

// Liveliness as seen by a reader for one matched writer (publication handle).
struct WriterSlot {
  std::atomic<dds_instance_handle_t> publication{0};  // 0 = free
  std::atomic<int32_t> state{0};                      // WriterLiveliness
  std::atomic<uint32_t> became_alive{0};
  std::atomic<uint32_t> became_not_alive{0};
  std::atomic<int64_t> last_change_mono_ns{0};
};

// Plain copy of the totals, for reporting.
struct StatusSnapshot {
  // Reader side.
  uint32_t requested_deadline_missed_total = 0;
  uint32_t requested_incompatible_qos_total = 0;
  // The policy that made the latest incompatible writer not match (dds_qos_policy_id_t;
  // QosPolicyName in qos.hpp names it), 0 = none yet.
  uint32_t requested_incompatible_qos_last_policy = 0;
  // Of the total, the writers refused for another policy than PARTITION. A partition
  // mismatch is by design here (a reader of the default partition and a leg's writer in its
  // leg partition: comm::LegRoutedWriter), and Cyclone reports it as incompatible QoS too.
  uint32_t requested_incompatible_qos_not_partition_total = 0;
  uint32_t sample_lost_total = 0;
  uint32_t sample_rejected_total = 0;
  uint32_t liveliness_alive_count = 0;      // writers currently alive
  uint32_t liveliness_not_alive_count = 0;  // writers matched but not alive
  uint32_t liveliness_changed_events = 0;
  uint32_t liveliness_lost_events = 0;      // alive -> not alive transitions seen
  dds_instance_handle_t last_liveliness_publication = 0;
  int64_t last_liveliness_change_mono_ns = 0;
  uint32_t subscription_matched_current = 0;
  uint32_t subscription_matched_total = 0;
  // Writer side.
  uint32_t offered_deadline_missed_total = 0;
  uint32_t offered_incompatible_qos_total = 0;
  uint32_t liveliness_lost_total = 0;  // this writer failed to assert its liveliness
  uint32_t publication_matched_current = 0;
  uint32_t publication_matched_total = 0;
  uint32_t write_errors_total = 0;     // dds_write returned an error
  int32_t last_write_error = 0;        // its dds_return_t
  // Instances whose misses did not fit in the slot table (counted in the totals only).
  uint32_t instance_slot_overflow = 0;
};

// A reader's data callback (Reader::OnDataAvailable), called on Cyclone's receive thread.
using DataCallback = void (*)(void* arg);

class StatusCounters {
 public:
  static constexpr std::size_t kMaxInstances = 16;
  // Writers a reader tracks liveliness of: six primaries and six hot standbys of the
  // ValveCommand topic, with room for restarted ones (a slot is never reused).
  static constexpr std::size_t kMaxWriters = 32;

  StatusCounters() = default;
  StatusCounters(const StatusCounters&) = delete;
  StatusCounters& operator=(const StatusCounters&) = delete;

  // A listener whose callbacks update this object; the caller owns and deletes it
  // (dds_delete_listener) after handing it to dds_create_reader / dds_create_writer, which
  // copy it. The object must outlive the entity.
  // `with_data`: also on_data_available (SetDataCallback), for Reader::OnDataAvailable.
  dds_listener_t* CreateListener(bool with_data = false);

  StatusSnapshot Snapshot() const;
  // The callback of the on_data_available that CreateListener(true) installs.
  void SetDataCallback(DataCallback callback, void* arg) {
    data_callback_ = callback;
    data_arg_ = arg;
  }
  void OnDataAvailable() const {
    if (data_callback_ != nullptr) data_callback_(data_arg_);
  }
  const std::array<InstanceSlot, kMaxInstances>& instances() const { return instances_; }
  const std::array<WriterSlot, kMaxWriters>& writers() const { return writers_; }
  // The liveliness this reader last saw of writer `publication` (kUnknown: no change seen yet,
  // or past the slots). Reads atomics only.
  WriterLiveliness LivelinessOf(dds_instance_handle_t publication) const {
    for (const WriterSlot& slot : writers_) {
      const dds_instance_handle_t h = slot.publication.load(std::memory_order_acquire);
      if (h == 0) break;  // slots are claimed in order
      if (h == publication) return static_cast<WriterLiveliness>(slot.state.load(std::memory_order_relaxed));
    }
    return WriterLiveliness::kUnknown;
  }

  // Callback bodies (public for the C trampolines; also usable in tests).
  void OnRequestedDeadlineMissed(const dds_requested_deadline_missed_status_t& s);
  void OnOfferedDeadlineMissed(const dds_offered_deadline_missed_status_t& s);
  void OnLivelinessChanged(const dds_liveliness_changed_status_t& s);
  void OnLivelinessLost(const dds_liveliness_lost_status_t& s);
  void OnSampleLost(const dds_sample_lost_status_t& s);
  void OnSampleRejected(const dds_sample_rejected_status_t& s);
  void OnSubscriptionMatched(const dds_subscription_matched_status_t& s);
  void OnPublicationMatched(const dds_publication_matched_status_t& s);
  void OnRequestedIncompatibleQos(const dds_requested_incompatible_qos_status_t& s);
  void OnOfferedIncompatibleQos(const dds_offered_incompatible_qos_status_t& s);
  void CountWriteError(dds_return_t rc) {
    write_errors_total_.fetch_add(1, std::memory_order_relaxed);
    last_write_error_.store(rc, std::memory_order_relaxed);
  }

 private:
  InstanceSlot* ClaimInstance(dds_instance_handle_t handle);
  // Adds a deadline status's total_count_change to the instance's slot (or to the overflow).
  void CountInstanceMisses(dds_instance_handle_t handle, int32_t total_count_change);
  WriterSlot* ClaimWriter(dds_instance_handle_t publication);

  std::atomic<uint32_t> requested_deadline_missed_total_{0};
  std::atomic<uint32_t> requested_incompatible_qos_total_{0};
  std::atomic<uint32_t> requested_incompatible_qos_last_policy_{0};
  std::atomic<uint32_t> requested_incompatible_qos_not_partition_total_{0};
  std::atomic<uint32_t> sample_lost_total_{0};
  std::atomic<uint32_t> sample_rejected_total_{0};
  std::atomic<uint32_t> liveliness_alive_count_{0};
  std::atomic<uint32_t> liveliness_not_alive_count_{0};
  std::atomic<uint32_t> liveliness_changed_events_{0};
  std::atomic<uint32_t> liveliness_lost_events_{0};
  std::atomic<dds_instance_handle_t> last_liveliness_publication_{0};
  std::atomic<int64_t> last_liveliness_change_mono_ns_{0};
  std::atomic<uint32_t> subscription_matched_current_{0};
  std::atomic<uint32_t> subscription_matched_total_{0};
  std::atomic<uint32_t> offered_deadline_missed_total_{0};
  std::atomic<uint32_t> offered_incompatible_qos_total_{0};
  std::atomic<uint32_t> liveliness_lost_total_{0};
  std::atomic<uint32_t> publication_matched_current_{0};
  std::atomic<uint32_t> publication_matched_total_{0};
  std::atomic<uint32_t> instance_slot_overflow_{0};
  std::atomic<uint32_t> write_errors_total_{0};
  std::atomic<int32_t> last_write_error_{0};
  DataCallback data_callback_ = nullptr;  // set before the listener that calls it
  void* data_arg_ = nullptr;
  std::array<InstanceSlot, kMaxInstances> instances_{};
  std::array<WriterSlot, kMaxWriters> writers_{};
};

// CLOCK_MONOTONIC in ns (async-signal-safe, used for event times in the callbacks).
int64_t MonotonicNow_ns();

}  // namespace hexa::comm
