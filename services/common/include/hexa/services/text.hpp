// Free text made safe for every place it leaves a process: DDS string fields (FaultEvent.detail,
// NodeStatus.detail, OperatorCommand.csv_path, ...), protobuf string fields of a recording
// (proto3 parsers reject invalid UTF-8, so one bad byte makes a message unreadable), and log
// lines (a 10 MB CSV field must not become a 10 MB log line). docs/robustness.md.
//
// The output is always valid UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing above
// U+10FFFF), has no control characters other than tab (and line feed where allowed), and is
// at most `max_bytes` long. Each byte that does not start a valid sequence, and each control
// character, becomes U+FFFD. Text that does not fit is cut at a character boundary and ends
// with kCutMarker, so a reader sees that something was cut.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace hexa::text {

inline constexpr std::string_view kCutMarker = "[...]";
inline constexpr std::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD
// Bounds used across the system (docs/robustness.md).
inline constexpr std::size_t kMaxLogLineBytes = 16 * 1024;  // one log message
inline constexpr std::size_t kMaxExcerptBytes = 64;         // a user value quoted in a message

enum class Newlines { kReplace, kKeep };

// True when `in` is valid UTF-8 (control characters are not checked).
bool IsValidUtf8(std::string_view in);
// True when Sanitize would return `in` unchanged (valid UTF-8, no control characters other
// than tab / line feed as allowed, not longer than max_bytes).
bool IsClean(std::string_view in, std::size_t max_bytes, Newlines newlines = Newlines::kReplace);

std::string Sanitize(std::string_view in, std::size_t max_bytes,
                     Newlines newlines = Newlines::kReplace);

// Into a fixed char array of `capacity` bytes (the NUL included: at most capacity - 1 bytes of
// text), always NUL-terminated; no allocation (usable in the 1 ms cycle). Returns the length.
std::size_t SanitizeInto(std::string_view in, char* out, std::size_t capacity,
                         Newlines newlines = Newlines::kReplace);
template <std::size_t N>
std::size_t SanitizeInto(std::string_view in, char (&out)[N]) {
  return SanitizeInto(in, out, N);
}

// Only the UTF-8 repair of Sanitize: each byte that does not start a valid sequence becomes
// U+FFFD; control characters and length are left alone (for repairing recorded strings).
std::string RepairUtf8(std::string_view in);

// A user value quoted in an error message: sanitised and cut to kMaxExcerptBytes.
inline std::string Excerpt(std::string_view in) { return Sanitize(in, kMaxExcerptBytes); }

}  // namespace hexa::text
