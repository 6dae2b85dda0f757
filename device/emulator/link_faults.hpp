// Link faults of the emulated board (hexa_board_emulator --link-fault): what a real link and
// a misbehaving board do to the datagrams, injected deterministically so that the host's
// handling of each can be tested in lockstep. Every Nth sensor frame (board ticks
// [from, to)) with a bad CRC, an old protocol version, a potentiometer reading out of its
// calibrated range, or held back and sent after the next frame (out of order); and datagram
// loss in both directions, drawn from a seeded generator. Pure: no socket, no clock; main.cpp
// delivers the fates.
#pragma once

#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

namespace hexa::device {

enum class LinkFaultKind { kDrop, kBadCrc, kOldVersion, kOutOfRange, kReorder };
const char* ToString(LinkFaultKind kind);  // "drop", "bad-crc", ... as on the command line

struct LinkFault {
  LinkFaultKind kind = LinkFaultKind::kDrop;
  double drop_fraction = 0.0;  // kDrop: each datagram, either way, lost with this probability
  std::uint64_t every = 1;     // the others: every Nth sensor frame of the window
  std::uint64_t from_tick = 0;
  std::uint64_t to_tick = std::numeric_limits<std::uint64_t>::max();
};

// "drop:PERCENT" or "KIND:N[:FROM[:TO]]" (KIND bad-crc, old-version, out-of-range, reorder;
// board ticks [FROM, TO)). False with `error` naming the text and what is expected.
bool ParseLinkFault(const std::string& text, LinkFault& out, std::string& error);

struct LinkFaultCounts {
  std::uint64_t commands_dropped = 0;
  std::uint64_t frames_dropped = 0;
  std::uint64_t bad_crc = 0;
  std::uint64_t old_version = 0;
  std::uint64_t out_of_range = 0;
  std::uint64_t reordered = 0;
  bool any() const;
  // "commands dropped 12, frames dropped 9, bad_crc 4" (zero counts left out; "none").
  std::string Describe() const;
};

// What becomes of one sensor frame.
enum class FrameFate {
  kSend,         // sent now as the board made it
  kSendAltered,  // sent now, altered (bad CRC, old version, a value out of range)
  kDrop,  // lost
  kHold,  // held back: sent after the next frame
};

class LinkFaultInjector {
 public:
  LinkFaultInjector(std::vector<LinkFault> faults, std::uint64_t seed);

  // A command received at board tick `tick`: true when the link loses it (not delivered).
  bool DropCommand(std::uint64_t tick);
  // The sensor frame of board tick `tick`, altered in place (a valid CRC kept where the fault
  // is not the CRC itself). `holding`: a frame is already held back (only one is).
  FrameFate Apply(std::uint64_t tick, std::span<std::uint8_t> frame, bool holding);

  bool empty() const { return faults_.empty(); }
  const LinkFaultCounts& counts() const { return counts_; }
  std::string Describe() const;  // the faults configured, for the log

 private:
  bool Draw(double fraction);
  static bool Due(const LinkFault& f, std::uint64_t tick);

  std::vector<LinkFault> faults_;
  std::mt19937_64 rng_;
  LinkFaultCounts counts_;
};

}  // namespace hexa::device
