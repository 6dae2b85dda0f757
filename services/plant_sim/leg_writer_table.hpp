// Which leg each of the plant's valve-command writers drives, and whether it is alive.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hexa/comm/comm.hpp"
#include "hexa/core/lockstep_protocol.hpp"

namespace hexa::plant_sim {

// The leg controllers' ValveCommand writers as the plant's six per-leg readers see them
// (one reader per leg partition, comm/leg_readers.hpp): which leg each writer drives (its
// USER_DATA, "leg=N standby=S") and whether it is alive (each reader's liveliness slots,
// comm/status.hpp). Only a writer in leg N's partition that names leg N counts for leg N; a
// writer elsewhere or naming another leg counts for none. Refresh() resolves writers seen for
// the first time (allocates, but only when a writer appears); Counts() reads atomics only.
// A writer whose USER_DATA cannot be read yet (discovery lags the liveliness callback that
// claimed its slot) is asked again on later refreshes; with `may_give_up` (the running loops)
// it counts as gone after 100 of them, without (the start-up wait, where discovery on a loaded
// machine can lag by seconds and no real-time loop pays for the retries) it is asked until the
// wait ends.
class LegWriterTable {
 public:
  void Refresh(const comm::LegReaders<hexa_msg_ValveCommand>& readers, bool may_give_up = true);
  LegWriterCounts Counts(int leg) const;
  // "leg1: 1 alive (primary) ..." for the log, and the slots not resolved to a leg (yet) or
  // given up on. Allocates.
  std::string Describe() const;

 private:
  static constexpr std::size_t kSlots = comm::StatusCounters::kMaxWriters;
  struct PerReader {
    const comm::StatusCounters* counters = nullptr;
    std::array<std::int8_t, kSlots> leg{};          // 0 unresolved, -1 not this leg's writer, 1..6
    std::array<bool, kSlots> standby{};
    std::array<std::uint8_t, kSlots> unresolved{};  // refreshes that could not resolve the slot
  };
  void RefreshOne(const comm::Reader<hexa_msg_ValveCommand>& reader, int reader_leg, bool may_give_up);
  LegArray<PerReader> readers_{};
};

}  // namespace hexa::plant_sim
