#include "hexa/core/command_source.hpp"

namespace hexa {

std::size_t CommandSourceSelector::Record(std::uint64_t writer, bool standby) {
  for (std::size_t i = 0; i < count_; ++i) {
    if (sources_[i].writer == writer) {
      sources_[i].standby = standby;  // authenticated: the writer says what it is
      return i;
    }
  }
  std::size_t slot = count_;
  if (count_ < kMaxSources) {
    ++count_;
  } else {
    // Full: a gone writer's slot, else the oldest.
    slot = 0;
    for (std::size_t i = 0; i < count_; ++i) {
      if (states_[i] == SourceLiveliness::kGone) {
        slot = i;
        break;
      }
      if (sources_[i].first_seen < sources_[slot].first_seen) slot = i;
    }
  }
  sources_[slot] = Source{writer, standby, ++seen_};
  states_[slot] = SourceLiveliness::kUnknown;
  return slot;
}

std::size_t CommandSourceSelector::Owner() const {
  std::size_t owner = kMaxSources;
  for (std::size_t i = 0; i < count_; ++i) {
    if (!Alive(states_[i])) continue;
    if (owner == kMaxSources) {
      owner = i;
      continue;
    }
    const Source& a = sources_[i];
    const Source& b = sources_[owner];
    // Primary before standby; among equals the first seen.
    if (a.standby != b.standby ? !a.standby : a.first_seen < b.first_seen) owner = i;
  }
  return owner;
}

}  // namespace hexa
