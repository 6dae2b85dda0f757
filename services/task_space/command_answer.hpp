// The supervisor's answer to an operator command, carried in its NodeStatus detail (reliable,
// transient-local): "command #<sequence> <kind>: accepted", "... refused: <why>" or
// "... rejected: <why>". hexa_operator waits for the answer to its own sequence number and
// exits with it (docs/exit_codes.md). One place for the format: the supervisor
// writes it, the operator reads it.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace hexa::task_space {

enum class CommandAnswer { kNone, kAccepted, kRefused, kRejected };

// Writes the answer into `out` (NUL-terminated, cut to its size). `why` may be empty.
template <std::size_t N>
void FormatCommandAnswer(char (&out)[N], std::uint32_t sequence, const char* kind,
                         CommandAnswer answer, const char* why) {
  const char* word = answer == CommandAnswer::kAccepted   ? "accepted"
                     : answer == CommandAnswer::kRejected ? "rejected"
                                                          : "refused";
  std::snprintf(out, N, "command #%u %s: %s%s%s", static_cast<unsigned>(sequence), kind, word,
                (why != nullptr && *why != '\0') ? ": " : "", why != nullptr ? why : "");
}

// The answer to command `sequence` in a NodeStatus detail; kNone if the detail is about
// something else.
inline CommandAnswer ParseCommandAnswer(const std::string& detail, std::uint32_t sequence) {
  const std::string prefix = "command #" + std::to_string(sequence) + " ";
  if (detail.rfind(prefix, 0) != 0) return CommandAnswer::kNone;
  const auto colon = detail.find(": ", prefix.size());
  if (colon == std::string::npos) return CommandAnswer::kNone;
  const std::string rest = detail.substr(colon + 2);
  if (rest.rfind("accepted", 0) == 0) return CommandAnswer::kAccepted;
  if (rest.rfind("rejected", 0) == 0) return CommandAnswer::kRejected;
  if (rest.rfind("refused", 0) == 0) return CommandAnswer::kRefused;
  return CommandAnswer::kNone;
}

}  // namespace hexa::task_space
