// printf into a fixed char array where cutting the text is intended (text.hpp's companion for
// formatted text; header-only, no allocation).
#pragma once

#include <cstdarg>
#include <cstddef>
#include <cstdio>

namespace hexa::text {

// printf into a fixed char array where cutting the text to the array is intended: a NodeStatus
// or FaultEvent detail, whose DDS field is of fixed size, or a line that quotes another one.
// Always NUL-terminated, and a cut never splits a UTF-8 character; no allocation (usable in the
// 1 ms cycle); the format is checked as printf's. Returns true when the text was cut. (A plain
// snprintf into an array that a longer argument can overflow draws -Wformat-truncation; here
// the cut is the contract.)
[[gnu::format(printf, 3, 4)]] inline bool FormatCut(char* out, std::size_t capacity,
                                                    const char* format, ...) {
  if (capacity == 0) return true;
  std::va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(out, capacity, format, args);
  va_end(args);
  if (n < 0) {  // an encoding error: nothing of it
    out[0] = '\0';
    return true;
  }
  if (static_cast<std::size_t>(n) < capacity) return false;
  // Cut: drop the last character if the cut left only its first bytes.
  const std::size_t length = capacity - 1;
  std::size_t lead = length;
  while (lead > 0 && (static_cast<unsigned char>(out[lead - 1]) & 0xC0) == 0x80) --lead;
  if (lead > 0) {
    const unsigned char b = static_cast<unsigned char>(out[lead - 1]);
    const std::size_t size = b >= 0xF0 ? 4 : b >= 0xE0 ? 3 : b >= 0xC0 ? 2 : 1;
    if (length - (lead - 1) < size) out[lead - 1] = '\0';
  }
  return true;
}

}  // namespace hexa::text
