#include "hexa/comm/status.hpp"

#include <time.h>

namespace hexa::comm {
namespace {

StatusCounters* Self(void* arg) { return static_cast<StatusCounters*>(arg); }

// C trampolines: Cyclone calls these from its event / receive threads.
void RequestedDeadlineMissed(dds_entity_t, const dds_requested_deadline_missed_status_t s,
                             void* arg) {
  Self(arg)->OnRequestedDeadlineMissed(s);
}
void OfferedDeadlineMissed(dds_entity_t, const dds_offered_deadline_missed_status_t s,
                           void* arg) {
  Self(arg)->OnOfferedDeadlineMissed(s);
}
void LivelinessChanged(dds_entity_t, const dds_liveliness_changed_status_t s, void* arg) {
  Self(arg)->OnLivelinessChanged(s);
}
void LivelinessLost(dds_entity_t, const dds_liveliness_lost_status_t s, void* arg) {
  Self(arg)->OnLivelinessLost(s);
}
void SampleLost(dds_entity_t, const dds_sample_lost_status_t s, void* arg) {
  Self(arg)->OnSampleLost(s);
}
void SampleRejected(dds_entity_t, const dds_sample_rejected_status_t s, void* arg) {
  Self(arg)->OnSampleRejected(s);
}
void SubscriptionMatched(dds_entity_t, const dds_subscription_matched_status_t s, void* arg) {
  Self(arg)->OnSubscriptionMatched(s);
}
void PublicationMatched(dds_entity_t, const dds_publication_matched_status_t s, void* arg) {
  Self(arg)->OnPublicationMatched(s);
}
void RequestedIncompatibleQos(dds_entity_t, const dds_requested_incompatible_qos_status_t s,
                              void* arg) {
  Self(arg)->OnRequestedIncompatibleQos(s);
}
void OfferedIncompatibleQos(dds_entity_t, const dds_offered_incompatible_qos_status_t s,
                            void* arg) {
  Self(arg)->OnOfferedIncompatibleQos(s);
}

void DataAvailable(dds_entity_t, void* arg) { Self(arg)->OnDataAvailable(); }

constexpr auto kRelaxed = std::memory_order_relaxed;

}  // namespace

int64_t MonotonicNow_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

dds_listener_t* StatusCounters::CreateListener(bool with_data) {
  dds_listener_t* l = dds_create_listener(this);
  dds_lset_requested_deadline_missed(l, RequestedDeadlineMissed);
  dds_lset_offered_deadline_missed(l, OfferedDeadlineMissed);
  dds_lset_liveliness_changed(l, LivelinessChanged);
  dds_lset_liveliness_lost(l, LivelinessLost);
  dds_lset_sample_lost(l, SampleLost);
  dds_lset_sample_rejected(l, SampleRejected);
  dds_lset_subscription_matched(l, SubscriptionMatched);
  dds_lset_publication_matched(l, PublicationMatched);
  dds_lset_requested_incompatible_qos(l, RequestedIncompatibleQos);
  dds_lset_offered_incompatible_qos(l, OfferedIncompatibleQos);
  if (with_data) dds_lset_data_available(l, DataAvailable);
  return l;
}

InstanceSlot* StatusCounters::ClaimInstance(dds_instance_handle_t handle) {
  if (handle == 0) return nullptr;
  for (InstanceSlot& slot : instances_) {
    dds_instance_handle_t current = slot.handle.load(std::memory_order_acquire);
    if (current == handle) return &slot;
    if (current == 0) {
      dds_instance_handle_t expected = 0;
      if (slot.handle.compare_exchange_strong(expected, handle, std::memory_order_acq_rel) ||
          expected == handle) {
        return &slot;
      }
    }
  }
  return nullptr;
}

WriterSlot* StatusCounters::ClaimWriter(dds_instance_handle_t publication) {
  if (publication == 0) return nullptr;
  for (WriterSlot& slot : writers_) {
    dds_instance_handle_t current = slot.publication.load(std::memory_order_acquire);
    if (current == publication) return &slot;
    if (current == 0) {
      dds_instance_handle_t expected = 0;
      if (slot.publication.compare_exchange_strong(expected, publication,
                                                   std::memory_order_acq_rel) ||
          expected == publication) {
        return &slot;
      }
    }
  }
  return nullptr;
}

void StatusCounters::CountInstanceMisses(dds_instance_handle_t handle,
                                         int32_t total_count_change) {
  const uint32_t change = total_count_change > 0 ? static_cast<uint32_t>(total_count_change) : 0u;
  if (InstanceSlot* slot = ClaimInstance(handle)) {
    slot->deadline_missed.fetch_add(change, kRelaxed);
    slot->last_miss_mono_ns.store(MonotonicNow_ns(), kRelaxed);
  } else {
    instance_slot_overflow_.fetch_add(change, kRelaxed);
  }
}

void StatusCounters::OnRequestedDeadlineMissed(const dds_requested_deadline_missed_status_t& s) {
  requested_deadline_missed_total_.store(s.total_count, kRelaxed);
  CountInstanceMisses(s.last_instance_handle, s.total_count_change);
}

void StatusCounters::OnOfferedDeadlineMissed(const dds_offered_deadline_missed_status_t& s) {
  offered_deadline_missed_total_.store(s.total_count, kRelaxed);
  CountInstanceMisses(s.last_instance_handle, s.total_count_change);
}

void StatusCounters::OnLivelinessChanged(const dds_liveliness_changed_status_t& s) {
  const int64_t now_ns = MonotonicNow_ns();
  liveliness_alive_count_.store(s.alive_count, kRelaxed);
  liveliness_not_alive_count_.store(s.not_alive_count, kRelaxed);
  last_liveliness_publication_.store(s.last_publication_handle, kRelaxed);
  last_liveliness_change_mono_ns_.store(now_ns, kRelaxed);
  liveliness_changed_events_.fetch_add(1, kRelaxed);
  // One callback per writer transition: alive -> not alive moves one from alive_count to
  // not_alive_count; a new or recovered writer adds to alive_count; an unmatched writer
  // leaves both.
  WriterLiveliness state = WriterLiveliness::kUnknown;
  if (s.alive_count_change > 0) {
    state = WriterLiveliness::kAlive;
  } else if (s.not_alive_count_change > 0) {
    state = WriterLiveliness::kNotAlive;
    liveliness_lost_events_.fetch_add(1, kRelaxed);
  } else if (s.alive_count_change < 0 || s.not_alive_count_change < 0) {
    state = WriterLiveliness::kGone;
  }
  if (WriterSlot* slot = ClaimWriter(s.last_publication_handle)) {
    if (state == WriterLiveliness::kAlive) slot->became_alive.fetch_add(1, kRelaxed);
    if (state == WriterLiveliness::kNotAlive) slot->became_not_alive.fetch_add(1, kRelaxed);
    slot->state.store(static_cast<int32_t>(state), kRelaxed);
    slot->last_change_mono_ns.store(now_ns, kRelaxed);
  }
}

void StatusCounters::OnLivelinessLost(const dds_liveliness_lost_status_t& s) {
  liveliness_lost_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnSampleLost(const dds_sample_lost_status_t& s) {
  sample_lost_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnSampleRejected(const dds_sample_rejected_status_t& s) {
  sample_rejected_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnSubscriptionMatched(const dds_subscription_matched_status_t& s) {
  subscription_matched_current_.store(s.current_count, kRelaxed);
  subscription_matched_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnPublicationMatched(const dds_publication_matched_status_t& s) {
  publication_matched_current_.store(s.current_count, kRelaxed);
  publication_matched_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnRequestedIncompatibleQos(
    const dds_requested_incompatible_qos_status_t& s) {
  requested_incompatible_qos_last_policy_.store(s.last_policy_id, kRelaxed);
  if (s.last_policy_id != DDS_PARTITION_QOS_POLICY_ID && s.total_count_change > 0)
    requested_incompatible_qos_not_partition_total_.fetch_add(static_cast<uint32_t>(s.total_count_change), kRelaxed);
  requested_incompatible_qos_total_.store(s.total_count, kRelaxed);
}
void StatusCounters::OnOfferedIncompatibleQos(const dds_offered_incompatible_qos_status_t& s) {
  offered_incompatible_qos_total_.store(s.total_count, kRelaxed);
}

StatusSnapshot StatusCounters::Snapshot() const {
  StatusSnapshot s;
  s.requested_deadline_missed_total = requested_deadline_missed_total_.load(kRelaxed);
  s.requested_incompatible_qos_total = requested_incompatible_qos_total_.load(kRelaxed);
  s.requested_incompatible_qos_last_policy = requested_incompatible_qos_last_policy_.load(kRelaxed);
  s.requested_incompatible_qos_not_partition_total =
      requested_incompatible_qos_not_partition_total_.load(kRelaxed);
  s.sample_lost_total = sample_lost_total_.load(kRelaxed);
  s.sample_rejected_total = sample_rejected_total_.load(kRelaxed);
  s.liveliness_alive_count = liveliness_alive_count_.load(kRelaxed);
  s.liveliness_not_alive_count = liveliness_not_alive_count_.load(kRelaxed);
  s.liveliness_changed_events = liveliness_changed_events_.load(kRelaxed);
  s.liveliness_lost_events = liveliness_lost_events_.load(kRelaxed);
  s.last_liveliness_publication = last_liveliness_publication_.load(kRelaxed);
  s.last_liveliness_change_mono_ns = last_liveliness_change_mono_ns_.load(kRelaxed);
  s.subscription_matched_current = subscription_matched_current_.load(kRelaxed);
  s.subscription_matched_total = subscription_matched_total_.load(kRelaxed);
  s.offered_deadline_missed_total = offered_deadline_missed_total_.load(kRelaxed);
  s.offered_incompatible_qos_total = offered_incompatible_qos_total_.load(kRelaxed);
  s.liveliness_lost_total = liveliness_lost_total_.load(kRelaxed);
  s.publication_matched_current = publication_matched_current_.load(kRelaxed);
  s.publication_matched_total = publication_matched_total_.load(kRelaxed);
  s.instance_slot_overflow = instance_slot_overflow_.load(kRelaxed);
  s.write_errors_total = write_errors_total_.load(kRelaxed);
  s.last_write_error = last_write_error_.load(kRelaxed);
  return s;
}

}  // namespace hexa::comm
