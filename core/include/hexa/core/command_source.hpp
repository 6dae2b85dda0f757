// Which writer's commands a leg applies: the reader's own ownership decision (docs/faults.md,
// "Foreign commands"). The command topics use SHARED ownership: with EXCLUSIVE ownership the
// middleware lets the strongest live writer own the instance, so a foreign writer with a
// higher strength would hide the real controller's samples, and refusing the foreign samples
// would leave the leg without commands. Instead every sample reaches the reader, which
// refuses those that are not authenticated and, among the authenticated writers of the leg,
// applies the owner's only:
//
//   the owner is the live primary (a writer whose authenticated samples say standby = false);
//   without one, the live standby; among equals, the writer seen first.
//
// This is what EXCLUSIVE ownership did with the primary's strength (20) above the standby's
// (10): a primary whose liveliness lapses (crashed, hung, silent) hands the leg to its standby,
// and takes it back once alive again. A writer's liveliness is the reader's (Cyclone's
// per-writer liveliness changes); a writer that has just delivered a sample and whose state
// is not known yet counts as alive. Pure: no DDS, no clock, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace hexa {

enum class SourceLiveliness : std::uint8_t { kUnknown, kAlive, kNotAlive, kGone };

class CommandSourceSelector {
 public:
  static constexpr std::size_t kMaxSources = 8;  // per leg: primary, standby, restarts

  enum class Verdict : std::uint8_t {
    kApply,     // the owner's sample
    kNotOwner,  // an authenticated writer that does not own the leg now (a standby's sample)
  };

  // An authenticated sample of `writer` (a nonzero id, e.g. its publication handle) that says
  // `standby`; `liveliness`: each known writer's state, looked up by id. Records the writer
  // (the first kMaxSources; a later one replaces a gone writer, else the oldest) and says
  // whether its sample is applied.
  template <typename LivelinessOf>
  Verdict Offer(std::uint64_t writer, bool standby, LivelinessOf&& liveliness) {
    const std::size_t self = Record(writer, standby);
    for (std::size_t i = 0; i < count_; ++i) states_[i] = liveliness(sources_[i].writer);
    states_[self] = Alive(states_[self]) ? states_[self] : SourceLiveliness::kAlive;  // it just wrote
    return Owner() == self ? Verdict::kApply : Verdict::kNotOwner;
  }

  std::size_t count() const { return count_; }

 private:
  struct Source {
    std::uint64_t writer = 0;
    bool standby = false;
    std::uint64_t first_seen = 0;  // order of first sample
  };
  static bool Alive(SourceLiveliness s) {
    return s == SourceLiveliness::kAlive || s == SourceLiveliness::kUnknown;
  }
  std::size_t Record(std::uint64_t writer, bool standby);
  std::size_t Owner() const;

  std::array<Source, kMaxSources> sources_{};
  std::array<SourceLiveliness, kMaxSources> states_{};
  std::size_t count_ = 0;
  std::uint64_t seen_ = 0;
};

}  // namespace hexa
