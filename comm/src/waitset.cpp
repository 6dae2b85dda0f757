#include "hexa/comm/waitset.hpp"

#include <algorithm>
#include <stdexcept>

#include "hexa/comm/error.hpp"

namespace hexa::comm {

WaitSet::WaitSet(const Participant& participant, std::size_t max_triggered)
    : triggered_(std::max<std::size_t>(max_triggered, 1)) {
  entity_ = OwnedEntity(CheckDds(dds_create_waitset(participant.get()), "cannot create waitset"));
}

void WaitSet::Attach(dds_entity_t entity, dds_attach_t token) {
  CheckDds(dds_waitset_attach(entity_.get(), entity, token),
           "cannot attach entity " + std::to_string(entity) + " to waitset");
}

void WaitSet::Detach(dds_entity_t entity) { (void)dds_waitset_detach(entity_.get(), entity); }

dds_return_t WaitSet::Store(dds_return_t n) {
  count_ = n > 0 ? std::min<std::size_t>(static_cast<std::size_t>(n), triggered_.size()) : 0;
  return n;
}

dds_return_t WaitSet::Wait(dds_duration_t timeout) {
  return Store(dds_waitset_wait(entity_.get(), triggered_.data(), triggered_.size(), timeout));
}

dds_return_t WaitSet::WaitUntil(dds_time_t abs_timeout) {
  return Store(
      dds_waitset_wait_until(entity_.get(), triggered_.data(), triggered_.size(), abs_timeout));
}

bool WaitSet::Triggered(dds_attach_t token) const {
  for (std::size_t i = 0; i < count_; ++i) {
    if (triggered_[i] == token) return true;
  }
  return false;
}

GuardCondition::GuardCondition(const Participant& participant) {
  entity_ = OwnedEntity(
      CheckDds(dds_create_guardcondition(participant.get()), "cannot create guard condition"));
}

bool GuardCondition::IsSet() const {
  bool triggered = false;
  return dds_read_guardcondition(entity_.get(), &triggered) == DDS_RETCODE_OK && triggered;
}

}  // namespace hexa::comm
