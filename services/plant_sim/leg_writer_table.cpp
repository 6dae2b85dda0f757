#include "leg_writer_table.hpp"

#include <algorithm>

namespace hexa::plant_sim {
namespace {

// A leg controller's valve writer says which leg it drives (comm::LegEndpointUserData); false
// for anything else, a leg beyond the rig's too.
bool ParseLegUserData(const std::string& text, int& leg, bool& standby) {
  return comm::ParseLegEndpointUserData(text, leg, standby) && leg <= static_cast<int>(kNumLegs);
}

}  // namespace

void LegWriterTable::Refresh(const comm::LegReaders<hexa_msg_ValveCommand>& readers, bool may_give_up) {
  for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) RefreshOne(readers.leg(leg), leg, may_give_up);
}

void LegWriterTable::RefreshOne(const comm::Reader<hexa_msg_ValveCommand>& reader, int reader_leg,
                                bool may_give_up) {
  PerReader& r = readers_[static_cast<std::size_t>(reader_leg - 1)];
  r.counters = &reader.status();
  const auto& slots = r.counters->writers();
  for (std::size_t k = 0; k < kSlots; ++k) {
    const dds_instance_handle_t h = slots[k].publication.load(std::memory_order_acquire);
    if (h == 0) break;  // slots are claimed in order
    if (r.leg[k] != 0) continue;
    // What the writer says it is counts only when the session key vouches for it, by the rule
    // of the valve commands (comm::MatchedWriterClaim): a foreign writer that claims to be
    // leg N's controller is not counted as one.
    std::string claim;
    const comm::CommandTrust trust = comm::MatchedWriterClaim(reader.get(), h, claim);
    int leg = 0;
    bool standby = false;
    if (trust == comm::CommandTrust::kUnknownWriter) {
      // Not (yet) known as a matched publication: discovery may lag the liveliness callback
      // that claimed the slot, so ask again on later refreshes; a writer still unknown after
      // 100 of them is gone (it cannot count as alive, and no leg can claim it). Not while
      // waiting for the peers: there, a loaded machine's discovery may take longer than 100
      // refreshes, and giving up left a live leg's writer unresolved for good (the start-up
      // never completed: "legs with a live writer 5/6").
      if (r.unresolved[k] < 255) ++r.unresolved[k];
      if (may_give_up && r.unresolved[k] >= 100) r.leg[k] = -1;
    } else if (comm::Trusted(trust) && ParseLegUserData(claim, leg, standby) && leg == reader_leg) {
      r.leg[k] = static_cast<std::int8_t>(leg);
      r.standby[k] = standby;
    } else {
      // A tool's writer (replay), one that names another leg than its partition's, or one
      // whose claim the session key does not vouch for: not this leg's controller
      // (RejectCommand and the command check refuse its samples).
      r.leg[k] = -1;
    }
  }
}

LegWriterCounts LegWriterTable::Counts(int leg) const {
  LegWriterCounts c;
  const PerReader& r = readers_[static_cast<std::size_t>(leg - 1)];
  if (r.counters == nullptr) return c;
  const auto& slots = r.counters->writers();
  for (std::size_t k = 0; k < kSlots; ++k) {
    if (r.leg[k] != leg) continue;
    switch (static_cast<comm::WriterLiveliness>(slots[k].state.load(std::memory_order_relaxed))) {
      case comm::WriterLiveliness::kAlive: ++c.alive; break;
      case comm::WriterLiveliness::kNotAlive: ++c.not_alive; break;
      case comm::WriterLiveliness::kGone: ++c.gone; break;
      case comm::WriterLiveliness::kUnknown: break;
    }
  }
  return c;
}

std::string LegWriterTable::Describe() const {
  std::string text;
  static const char* kState[] = {"unknown", "alive", "not alive", "gone"};
  for (const PerReader& r : readers_) {
    if (r.counters == nullptr) continue;
    const auto& slots = r.counters->writers();
    for (std::size_t k = 0; k < kSlots; ++k) {
      if (slots[k].publication.load(std::memory_order_acquire) == 0) break;
      if (r.leg[k] <= 0) {
        // Unresolved, or given up on; a writer resolved to another leg is not listed.
        const bool given_up = r.leg[k] < 0 && r.unresolved[k] >= 100;
        if (r.leg[k] == 0 || given_up) {
          text += " a writer in leg" + std::to_string(&r - readers_.data() + 1) + "'s partition " +
                  (given_up ? std::string("never resolved (given up)")
                            : "not resolved yet (" + std::to_string(r.unresolved[k]) + " refreshes)") +
                  ";";
        }
        continue;
      }
      const int state = slots[k].state.load(std::memory_order_relaxed);
      text += " leg" + std::to_string(r.leg[k]) + (r.standby[k] ? " standby " : " primary ") +
              kState[std::clamp(state, 0, 3)] + ";";
    }
  }
  return text;
}

}  // namespace hexa::plant_sim
