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
  sources_[slot] = Source{};
  sources_[slot].writer = writer;
  sources_[slot].standby = standby;
  sources_[slot].first_seen = ++seen_;
  states_[slot] = SourceLiveliness::kUnknown;
  if (slot == owner_) owner_ = kMaxSources;  // the slot's old writer is no longer the owner
  return slot;
}

void CommandSourceSelector::Remember(std::size_t source, const Command& command) {
  Source& s = sources_[source];
  s.recent[s.recent_next] = command;
  s.recent_next = (s.recent_next + 1) % kRecent;
  if (s.recent_count < kRecent) ++s.recent_count;
}

bool CommandSourceSelector::Commanded(std::size_t source, const Command& command) const {
  const Source& s = sources_[source];
  for (std::size_t k = 0; k < s.recent_count; ++k)
    if (s.recent[k].tick == command.tick) return s.recent[k].value == command.value;
  return false;
}

bool CommandSourceSelector::Decide(std::size_t self, const Command& command) {
  // In step again: a command of a writer that is out of step equals the owner's for the same
  // tick (whichever of the two arrives second makes the check).
  if (owner_ < count_ && owner_ != self) {
    if (sources_[self].out_of_step && Commanded(owner_, command)) sources_[self].out_of_step = false;
  } else if (owner_ == self) {
    for (std::size_t i = 0; i < count_; ++i)
      if (i != self && sources_[i].out_of_step && Commanded(i, command)) sources_[i].out_of_step = false;
  }
  const std::size_t owner = Owner();
  // The owner lost the leg because it is not alive (crashed, hung, silent, stopped): it gets
  // it back only once in step again.
  if (owner_ < count_ && owner != owner_ && !Alive(states_[owner_])) sources_[owner_].out_of_step = true;
  owner_ = owner;
  return owner == self;
}

bool CommandSourceSelector::OutOfStep(std::uint64_t writer) const {
  for (std::size_t i = 0; i < count_; ++i)
    if (sources_[i].writer == writer) return sources_[i].out_of_step;
  return false;
}

std::size_t CommandSourceSelector::Owner() const {
  // Among the live writers in step; without one, among every live writer.
  std::size_t owner = kMaxSources;
  bool any_in_step = false;
  for (std::size_t i = 0; i < count_; ++i)
    any_in_step = any_in_step || (Alive(states_[i]) && !sources_[i].out_of_step);
  for (std::size_t i = 0; i < count_; ++i) {
    if (!Alive(states_[i]) || (any_in_step && sources_[i].out_of_step)) continue;
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
