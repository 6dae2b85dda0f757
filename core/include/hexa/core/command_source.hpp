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
// (10): a primary whose liveliness lapses (crashed, hung, silent) hands the leg to its standby.
// Unlike EXCLUSIVE ownership, a writer that lost the leg because it was not alive gets it back
// only once its commands are the owner's again: a command of it for some tick equals, bit for
// bit, the owner's command for that tick (both compute every tick). A primary that was stopped
// longer than its queue of ticks (lockstep: 1000) missed ticks and computes from another state:
// its commands differ and the standby keeps the leg; one that only lagged catches up to the
// same commands and takes the leg back. (In real time the two seldom agree bit for bit: a
// standby that took over keeps the leg.) Without any other live writer, a live writer that is
// not in step is applied all the same (better than none).
// A writer's liveliness is the reader's (Cyclone's per-writer liveliness changes); a writer
// that has just delivered a sample and whose state is not known yet counts as alive. Pure: no
// DDS, no clock, no allocation.
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

  // What a command says, for the in-step check: the tick it answers and its value.
  struct Command {
    std::uint64_t tick = 0;
    double value = 0.0;
  };

  // An authenticated sample of `writer` (a nonzero id, e.g. its publication handle) that says
  // `standby` and carries `command`; `liveliness`: each known writer's state, looked up by id.
  // Records the writer (the first kMaxSources; a later one replaces a gone writer, else the
  // oldest) and says whether its sample is applied.
  template <typename LivelinessOf>
  Verdict Offer(std::uint64_t writer, bool standby, const Command& command, LivelinessOf&& liveliness) {
    const std::size_t self = Record(writer, standby);
    Remember(self, command);
    for (std::size_t i = 0; i < count_; ++i) states_[i] = liveliness(sources_[i].writer);
    states_[self] = Alive(states_[self]) ? states_[self] : SourceLiveliness::kAlive;  // it just wrote
    return Decide(self, command) ? Verdict::kApply : Verdict::kNotOwner;
  }

  std::size_t count() const { return count_; }
  // Whether `writer` lost the leg while not alive and its commands have not been the owner's
  // since (false for a writer not known).
  bool OutOfStep(std::uint64_t writer) const;

 private:
  static constexpr std::size_t kRecent = 16;  // commands kept per writer for the in-step check
  struct Source {
    std::uint64_t writer = 0;
    bool standby = false;
    std::uint64_t first_seen = 0;  // order of first sample
    bool out_of_step = false;      // lost the leg while not alive; not in step since
    std::array<Command, kRecent> recent{};
    std::size_t recent_count = 0, recent_next = 0;
  };
  static bool Alive(SourceLiveliness s) {
    return s == SourceLiveliness::kAlive || s == SourceLiveliness::kUnknown;
  }
  std::size_t Record(std::uint64_t writer, bool standby);
  void Remember(std::size_t source, const Command& command);
  // Whether `source` commanded `command.tick` with exactly `command.value`.
  bool Commanded(std::size_t source, const Command& command) const;
  // The in-step check, the owner, and the mark of an owner that lost the leg while not alive;
  // true when `self` owns the leg.
  bool Decide(std::size_t self, const Command& command);
  std::size_t Owner() const;

  std::array<Source, kMaxSources> sources_{};
  std::array<SourceLiveliness, kMaxSources> states_{};
  std::size_t count_ = 0;
  std::uint64_t seen_ = 0;
  std::size_t owner_ = kMaxSources;  // the owner at the last offer (kMaxSources: none)
};

}  // namespace hexa
