// The answer to an operator command, carried in the answering node's NodeStatus detail
// (reliable, transient-local): "command #<sequence> <kind>: accepted", "... refused: <why>" or
// "... rejected: <why>". The supervisor answers every command; the plant answers the
// activation a start or home asks for (docs/faults.md, "Hardware lifecycle"). hexa_operator
// waits for the supervisor's answer to its own sequence number and exits with it
// (docs/exit_codes.md). One place for the format: the nodes write it, the others read it.
//
// The plant's status also says its hardware lifecycle state: "... hardware <state>" (the
// periodic detail, e.g. "lockstep; hardware inactive") or an activation's answer
// ("command #3 start: accepted: hardware active").
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "hexa/services/format_cut.hpp"

namespace hexa::services {

// The USER_DATA of the plant's OperatorCommand reader: hexa_operator waits for it too before
// it writes a start or home (the plant answers their activation), as for the supervisor's
// (comm::kSupervisorCommandReader); a command written before a reader matched never reaches it.
inline constexpr const char* kPlantCommandReader = "role=plant";

enum class CommandAnswer { kNone, kAccepted, kRefused, kRejected };

// Writes the answer into `out` (NUL-terminated, cut to its size: the NodeStatus detail is a
// fixed field). `why` may be empty.
template <std::size_t N>
void FormatCommandAnswer(char (&out)[N], std::uint32_t sequence, const char* kind,
                         CommandAnswer answer, const char* why) {
  const char* word = answer == CommandAnswer::kAccepted   ? "accepted"
                     : answer == CommandAnswer::kRejected ? "rejected"
                                                          : "refused";
  text::FormatCut(out, N, "command #%u %s: %s%s%s", static_cast<unsigned>(sequence), kind, word,
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

// What follows the answer's word ("refused: e-stop open ..." -> "e-stop open ..."); "" if none.
inline std::string CommandAnswerReason(const std::string& detail) {
  for (const char* word : {": accepted: ", ": refused: ", ": rejected: "}) {
    const auto at = detail.find(word);
    if (at != std::string::npos) return detail.substr(at + std::strlen(word));
  }
  return {};
}

// The plant's hardware lifecycle state in its NodeStatus detail.
enum class HardwareStatus { kUnknown, kUnconfigured, kInactive, kActive };
inline HardwareStatus ParseHardwareStatus(const std::string& detail) {
  if (detail.find("hardware active") != std::string::npos ||
      detail.find("hardware already active") != std::string::npos)
    return HardwareStatus::kActive;
  if (detail.find("hardware inactive") != std::string::npos) return HardwareStatus::kInactive;
  if (detail.find("hardware unconfigured") != std::string::npos) return HardwareStatus::kUnconfigured;
  return HardwareStatus::kUnknown;
}

}  // namespace hexa::services
