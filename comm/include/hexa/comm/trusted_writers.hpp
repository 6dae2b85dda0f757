// The writers of a command topic that a reader has seen authenticated (command_auth.hpp):
// what a reader judges by a writer's presence (a leg controller: is the supervisor still
// there?) counts only these, by the rule that decides whether a sample is taken. A writer
// that never delivered an authenticated sample (a foreign process with the same topic and
// partition, alive for as long as it likes) keeps no one believing that the session's writer
// is there. Fixed size, no allocation; when full, the oldest entry goes.
#pragma once

#include <dds/dds.h>

#include <algorithm>
#include <array>
#include <cstddef>

#include "hexa/comm/command_auth.hpp"
#include "hexa/comm/status.hpp"

namespace hexa::comm {

class TrustedWriters {
 public:
  static constexpr std::size_t kEntries = 4;

  // Sample of `publication` taken with `trust`: an authenticated one (or any, without a
  // session key) makes its writer trusted.
  void Note(dds_instance_handle_t publication, CommandTrust trust) {
    if (!Trusted(trust) || publication == 0 || Contains(publication)) return;
    handles_[next_] = publication;
    next_ = (next_ + 1) % handles_.size();
  }
  bool Contains(dds_instance_handle_t publication) const {
    return publication != 0 && std::find(handles_.begin(), handles_.end(), publication) != handles_.end();
  }
  bool any() const { return handles_[0] != 0; }  // filled in order
  // Trusted writers still matched by the reader whose `status` this is (alive, or with a
  // lapsed lease: not alive but not gone).
  std::size_t Present(const StatusCounters& status) const {
    std::size_t n = 0;
    for (const dds_instance_handle_t h : handles_) {
      if (h == 0) continue;
      const WriterLiveliness l = status.LivelinessOf(h);
      n += l == WriterLiveliness::kAlive || l == WriterLiveliness::kNotAlive ? 1 : 0;
    }
    return n;
  }

 private:
  std::array<dds_instance_handle_t, kEntries> handles_{};
  std::size_t next_ = 0;
};

}  // namespace hexa::comm
