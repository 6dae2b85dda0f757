#include "hexa/services/text.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace hexa::text {
namespace {

// Length of the valid UTF-8 sequence starting at in[i], 0 if none starts there (RFC 3629,
// Table 3-7 of the Unicode standard: no overlong forms, no surrogates, <= U+10FFFF).
std::size_t SequenceLength(std::string_view in, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(in[i + k]); };
  const std::size_t left = in.size() - i;
  const unsigned char c = b(0);
  if (c < 0x80) return 1;
  auto cont = [&](std::size_t k, unsigned char lo = 0x80, unsigned char hi = 0xBF) {
    return k < left && b(k) >= lo && b(k) <= hi;
  };
  if (c >= 0xC2 && c <= 0xDF) return cont(1) ? 2 : 0;
  if (c == 0xE0) return cont(1, 0xA0) && cont(2) ? 3 : 0;
  if ((c >= 0xE1 && c <= 0xEC) || c == 0xEE || c == 0xEF) return cont(1) && cont(2) ? 3 : 0;
  if (c == 0xED) return cont(1, 0x80, 0x9F) && cont(2) ? 3 : 0;  // no surrogates
  if (c == 0xF0) return cont(1, 0x90) && cont(2) && cont(3) ? 4 : 0;
  if (c >= 0xF1 && c <= 0xF3) return cont(1) && cont(2) && cont(3) ? 4 : 0;
  if (c == 0xF4) return cont(1, 0x80, 0x8F) && cont(2) && cont(3) ? 4 : 0;
  return 0;
}

bool AllowedControl(unsigned char c, Newlines newlines) {
  return c == '\t' || (c == '\n' && newlines == Newlines::kKeep);
}

bool IsControl(unsigned char c) { return c < 0x20 || c == 0x7F; }

// Walks `in`, writing at most `max_bytes` bytes through `put(const char*, size_t)` and
// `truncate(size_t)`; returns the output length.
template <typename Put, typename Truncate>
std::size_t Walk(std::string_view in, std::size_t max_bytes, Newlines newlines, Put put,
                 Truncate truncate) {
  const std::size_t marker = std::min(kCutMarker.size(), max_bytes);
  const std::size_t keep_limit = max_bytes - marker;  // text kept in front of a marker
  std::size_t length = 0;
  std::size_t cut_at = 0;  // output length at the last unit boundary <= keep_limit
  for (std::size_t i = 0; i < in.size();) {
    std::size_t n = SequenceLength(in, i);
    const char* unit = in.data() + i;
    std::size_t unit_size = n;
    if (n == 0 || (n == 1 && IsControl(static_cast<unsigned char>(in[i])) &&
                   !AllowedControl(static_cast<unsigned char>(in[i]), newlines))) {
      unit = kReplacement.data();
      unit_size = kReplacement.size();
      n = 1;
    }
    if (length + unit_size > max_bytes) {  // does not fit: cut and mark
      truncate(cut_at);
      put(kCutMarker.data(), marker);
      return cut_at + marker;
    }
    put(unit, unit_size);
    length += unit_size;
    if (length <= keep_limit) cut_at = length;
    i += n;
  }
  return length;
}

}  // namespace

bool IsValidUtf8(std::string_view in) {
  for (std::size_t i = 0; i < in.size();) {
    const std::size_t n = SequenceLength(in, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

bool IsClean(std::string_view in, std::size_t max_bytes, Newlines newlines) {
  if (in.size() > max_bytes) return false;
  for (std::size_t i = 0; i < in.size();) {
    const std::size_t n = SequenceLength(in, i);
    if (n == 0) return false;
    const auto c = static_cast<unsigned char>(in[i]);
    if (n == 1 && IsControl(c) && !AllowedControl(c, newlines)) return false;
    i += n;
  }
  return true;
}

std::string RepairUtf8(std::string_view in) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size();) {
    const std::size_t n = SequenceLength(in, i);
    if (n == 0) {
      out.append(kReplacement);
      ++i;
    } else {
      out.append(in.data() + i, n);
      i += n;
    }
  }
  return out;
}

std::string Sanitize(std::string_view in, std::size_t max_bytes, Newlines newlines) {
  std::string out;
  out.reserve(std::min(in.size(), max_bytes));
  Walk(
      in, max_bytes, newlines, [&](const char* p, std::size_t n) { out.append(p, n); },
      [&](std::size_t n) { out.resize(n); });
  return out;
}

std::size_t SanitizeInto(std::string_view in, char* out, std::size_t capacity,
                         Newlines newlines) {
  if (capacity == 0) return 0;
  std::size_t pos = 0;
  const std::size_t length = Walk(
      in, capacity - 1, newlines,
      [&](const char* p, std::size_t n) {
        std::memcpy(out + pos, p, n);
        pos += n;
      },
      [&](std::size_t n) { pos = n; });
  out[length] = '\0';
  return length;
}

}  // namespace hexa::text
