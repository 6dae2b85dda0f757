// Link faults of the emulated board (link_faults.hpp).
#include "link_faults.hpp"

#include <cstdio>

#include "hexa_board/protocol.h"

namespace hexa::device {
namespace {

void PutCrc(std::span<std::uint8_t> frame) {
  const std::uint32_t crc = hb_crc32c(frame.data(), frame.size() - HB_CRC_SIZE);
  for (std::size_t k = 0; k < HB_CRC_SIZE; ++k)
    frame[frame.size() - HB_CRC_SIZE + k] = static_cast<std::uint8_t>(crc >> (8 * k));
}

}  // namespace

const char* ToString(LinkFaultKind kind) {
  switch (kind) {
    case LinkFaultKind::kDrop: return "drop";
    case LinkFaultKind::kBadCrc: return "bad-crc";
    case LinkFaultKind::kOldVersion: return "old-version";
    case LinkFaultKind::kOutOfRange: return "out-of-range";
    case LinkFaultKind::kReorder: return "reorder";
  }
  return "?";
}

bool ParseLinkFault(const std::string& text, LinkFault& out, std::string& error) {
  const std::size_t colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : text.substr(colon + 1);
  LinkFault f;
  char extra = 0;
  if (kind == "drop") {
    double percent = -1.0;
    if (std::sscanf(rest.c_str(), "%lf%c", &percent, &extra) != 1 || !(percent >= 0.0 && percent <= 100.0)) {
      error = "--link-fault '" + text + "': expected drop:PERCENT with PERCENT in [0, 100]";
      return false;
    }
    f.kind = LinkFaultKind::kDrop;
    f.drop_fraction = percent / 100.0;
    out = f;
    return true;
  }
  if (kind == "bad-crc") f.kind = LinkFaultKind::kBadCrc;
  else if (kind == "old-version") f.kind = LinkFaultKind::kOldVersion;
  else if (kind == "out-of-range") f.kind = LinkFaultKind::kOutOfRange;
  else if (kind == "reorder") f.kind = LinkFaultKind::kReorder;
  else {
    error = "--link-fault '" + text + "': unknown kind '" + kind +
            "' (drop, bad-crc, old-version, out-of-range, reorder)";
    return false;
  }
  unsigned long long every = 0, from = 0, to = 0;
  const int n = std::sscanf(rest.c_str(), "%llu:%llu:%llu%c", &every, &from, &to, &extra);
  const bool ok = (n == 1 || n == 2 || n == 3) && every >= 1 && (n < 3 || to > from) &&
                  rest.find_first_not_of("0123456789:") == std::string::npos;
  if (!ok) {
    error = "--link-fault '" + text + "': expected " + kind + ":N[:FROM[:TO]] (every Nth sensor frame, N >= 1, " +
            "in board ticks [FROM, TO))";
    return false;
  }
  f.every = every;
  if (n >= 2) f.from_tick = from;
  if (n == 3) f.to_tick = to;
  out = f;
  return true;
}

bool LinkFaultCounts::any() const {
  return commands_dropped + frames_dropped + bad_crc + old_version + out_of_range + reordered > 0;
}

std::string LinkFaultCounts::Describe() const {
  std::string text;
  auto add = [&](const char* name, std::uint64_t n) {
    if (n > 0) text += (text.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(n);
  };
  add("commands dropped", commands_dropped);
  add("frames dropped", frames_dropped);
  add("bad_crc", bad_crc);
  add("old_version", old_version);
  add("out_of_range", out_of_range);
  add("reordered", reordered);
  return text.empty() ? "none" : text;
}

LinkFaultInjector::LinkFaultInjector(std::vector<LinkFault> faults, std::uint64_t seed)
    : faults_(std::move(faults)), rng_(seed) {}

bool LinkFaultInjector::Draw(double fraction) {
  // 53 random bits: uniform in [0, 1), the same on every platform (std distributions are not).
  const double u = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
  return u < fraction;
}

bool LinkFaultInjector::Due(const LinkFault& f, std::uint64_t tick) {
  return tick >= f.from_tick && tick < f.to_tick && (tick - f.from_tick) % f.every == f.every - 1;
}

bool LinkFaultInjector::DropCommand(std::uint64_t tick) {
  for (const LinkFault& f : faults_) {
    if (f.kind != LinkFaultKind::kDrop || tick < f.from_tick || tick >= f.to_tick) continue;
    if (Draw(f.drop_fraction)) {
      ++counts_.commands_dropped;
      return true;
    }
  }
  return false;
}

FrameFate LinkFaultInjector::Apply(std::uint64_t tick, std::span<std::uint8_t> frame, bool holding) {
  for (const LinkFault& f : faults_) {
    if (f.kind == LinkFaultKind::kDrop) {
      if (tick < f.from_tick || tick >= f.to_tick || !Draw(f.drop_fraction)) continue;
      ++counts_.frames_dropped;
      return FrameFate::kDrop;
    }
    if (!Due(f, tick)) continue;
    switch (f.kind) {
      case LinkFaultKind::kBadCrc:
        frame[40] ^= 0x80u;  // an ADC bit flipped on the way: the CRC no longer matches
        ++counts_.bad_crc;
        return FrameFate::kSendAltered;
      case LinkFaultKind::kOldVersion:
        frame[2] = static_cast<std::uint8_t>(HB_VERSION - 1);  // a board with older firmware
        PutCrc(frame);
        ++counts_.old_version;
        return FrameFate::kSendAltered;
      case LinkFaultKind::kOutOfRange: {
        // Leg 1's potentiometer reads 0 counts (a wiper off its track, a cut wire): intact
        // and newer, but below the channel's calibrated range.
        hb_sensor_frame s{};
        if (hb_decode_sensor(frame.data(), frame.size(), &s) != HB_FRAME_OK) return FrameFate::kSend;
        s.adc[HB_ADC_POT(0)] = 0;
        hb_encode_sensor(&s, frame.data());
        ++counts_.out_of_range;
        return FrameFate::kSendAltered;
      }
      case LinkFaultKind::kReorder:
        if (holding) continue;
        ++counts_.reordered;
        return FrameFate::kHold;
      case LinkFaultKind::kDrop:
        break;
    }
  }
  return FrameFate::kSend;
}

std::string LinkFaultInjector::Describe() const {
  std::string text;
  for (const LinkFault& f : faults_) {
    char one[160];
    if (f.kind == LinkFaultKind::kDrop) {
      std::snprintf(one, sizeof one, "drop %.3g %% of the datagrams either way", f.drop_fraction * 100.0);
    } else {
      std::snprintf(one, sizeof one, "%s every %llu frames from board tick %llu", ToString(f.kind),
                    static_cast<unsigned long long>(f.every), static_cast<unsigned long long>(f.from_tick));
    }
    text += (text.empty() ? "" : "; ") + std::string(one);
    if (f.kind != LinkFaultKind::kDrop && f.to_tick != std::numeric_limits<std::uint64_t>::max())
      text += " to " + std::to_string(f.to_tick);
  }
  return text;
}

}  // namespace hexa::device
