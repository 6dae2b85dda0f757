// WaitSet: blocks a service thread until data, a guard condition (shutdown) or a timeout.
// The service loop is event-driven: no polling sleeps anywhere.
#pragma once

#include <dds/dds.h>

#include <cstddef>
#include <span>
#include <vector>

#include "hexa/comm/participant.hpp"

namespace hexa::comm {

class WaitSet {
 public:
  // `max_triggered`: how many triggered attachments one Wait() reports.
  explicit WaitSet(const Participant& participant, std::size_t max_triggered = 8);

  // Attaches a reader's data_condition(), a guard condition, a reader or writer (status
  // condition) with a token returned by triggered(). Throws DdsError (setup time).
  void Attach(dds_entity_t entity, dds_attach_t token);
  void Detach(dds_entity_t entity);

  // Blocks until at least one attachment triggers or `timeout` elapses. Returns the number of
  // triggered attachments (0 on timeout) or a negative dds_return_t. Never allocates.
  dds_return_t Wait(dds_duration_t timeout = DDS_INFINITY);
  // Same with an absolute CLOCK_REALTIME deadline (dds_time_t).
  dds_return_t WaitUntil(dds_time_t abs_timeout);

  // Tokens of the attachments that triggered in the last Wait().
  std::span<const dds_attach_t> triggered() const { return {triggered_.data(), count_}; }
  bool Triggered(dds_attach_t token) const;

  dds_entity_t get() const { return entity_.get(); }

 private:
  dds_return_t Store(dds_return_t n);
  std::vector<dds_attach_t> triggered_;
  std::size_t count_ = 0;
  OwnedEntity entity_;
};

// A guard condition owned by this object; Set() wakes every WaitSet it is attached to.
class GuardCondition {
 public:
  explicit GuardCondition(const Participant& participant);
  dds_return_t Set(bool triggered = true) { return dds_set_guardcondition(entity_.get(), triggered); }
  bool IsSet() const;
  dds_entity_t get() const { return entity_.get(); }

 private:
  OwnedEntity entity_;
};

}  // namespace hexa::comm
