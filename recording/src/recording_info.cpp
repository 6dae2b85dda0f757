// hexa_recorder info: what a recording holds (channels, counts, rates, gaps and loss per
// topic) and its text.

#include "hexa/recording/recording.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <sstream>

#include "hexa/core/param_checks.hpp"

namespace hexa::recorder {
namespace gp = google::protobuf;

RecordingInfo Inspect(const std::string& path, const McapScanOptions& options) {
  RecordingInfo info;
  info.path = path;
  std::map<uint16_t, ChannelInfo> channels;
  std::map<uint16_t, TickLossTracker> trackers;
  std::map<uint16_t, uint64_t> last_log;
  RecordingCatalog catalog;
  const McapScanResult r = ReadRecording(
      path,
      [&](const McapChannel& ch, const McapMessageView& m, const gp::Message& msg) {
        ChannelInfo& c = channels[ch.id];
        if (c.count == 0) {
          c.first_log_ns = c.last_log_ns = m.log_time_ns;
        } else {
          c.max_log_gap_ns = std::max(c.max_log_gap_ns,
                                      m.log_time_ns > last_log[ch.id] ? m.log_time_ns - last_log[ch.id] : 0);
        }
        last_log[ch.id] = m.log_time_ns;
        c.first_log_ns = std::min(c.first_log_ns, m.log_time_ns);
        c.last_log_ns = std::max(c.last_log_ns, m.log_time_ns);
        ++c.count;
        const auto message_tick = MessageTick(msg);
        if (message_tick) {
          c.first_tick = c.has_ticks ? std::min(c.first_tick, *message_tick) : *message_tick;
          c.last_tick = c.has_ticks ? std::max(c.last_tick, *message_tick) : *message_tick;
          c.has_ticks = true;
        }
        // Loss only for periodic topics: event topics (period 0) have no expected tick step.
        auto period = ch.metadata.find(kMetaPeriodS);
        const bool periodic =
            period == ch.metadata.end() ? true : std::strtod(period->second.c_str(), nullptr) > 0;
        if (!periodic) return;
        if (message_tick) trackers[ch.id].Add(MessageKey(msg), *message_tick);
      },
      options, &catalog);
  info.file_size = r.file_size;
  info.complete = r.complete;
  info.problems = r.problems;
  info.messages = r.messages;
  info.chunks = r.chunks;
  info.chunk_compression = r.chunk_compression;
  info.chunk_records_bytes = r.chunk_records_bytes;
  info.chunk_stored_bytes = r.chunk_stored_bytes;
  bool first = true;
  LossEventCounter events;
  for (const auto& [id, ch] : catalog.channels) {
    ChannelInfo c = channels.count(id) ? channels[id] : ChannelInfo{};
    c.id = id;
    c.topic = ch.topic;
    c.metadata = ch.metadata;
    auto s = catalog.schemas.find(ch.schema_id);
    c.schema_name = s == catalog.schemas.end() ? "" : s->second.name;
    if (c.count > 1 && c.last_log_ns > c.first_log_ns)
      c.rate_hz = static_cast<double>(c.count - 1) * 1e9 /
                  static_cast<double>(c.last_log_ns - c.first_log_ns);
    if (c.count > 1 && c.has_ticks && c.last_tick > c.first_tick)
      c.sim_rate_hz = static_cast<double>(c.count - 1) /
                      (static_cast<double>(c.last_tick - c.first_tick) * kPlantTick_s);
    if (trackers.count(id)) {
      c.loss_analysed = true;
      c.streams = trackers[id].Results();
      events.AddTopic(ch.topic, trackers[id].MissingTicks());
      for (const auto& l : c.streams) c.missing += l.missing;
      // Instances of one topic run on the same ticks: one that starts late or stops early
      // against its siblings is reported (a late-matched writer, a crashed node).
      for (auto& l : c.streams) {
        for (const auto& other : c.streams) {
          if (other.step_ticks != l.step_ticks || l.step_ticks == 0) continue;
          if (other.first_tick < l.first_tick)
            l.late_start_ticks = std::max(l.late_start_ticks, l.first_tick - other.first_tick);
          if (other.last_tick > l.last_tick)
            l.early_end_ticks = std::max(l.early_end_ticks, other.last_tick - l.last_tick);
        }
      }
    }
    if (c.count > 0) {
      if (first || c.first_log_ns < info.start_ns) info.start_ns = c.first_log_ns;
      if (first || c.last_log_ns > info.end_ns) info.end_ns = c.last_log_ns;
      first = false;
    }
    info.channels.push_back(std::move(c));
  }
  info.loss_events = events.Finish();
  return info;
}

std::string FormatInfo(const RecordingInfo& info) {
  std::ostringstream o;
  char line[512];
  o << "file:      " << info.path << " (" << info.file_size << " bytes)\n";
  o << "status:    "
    << (info.complete ? "complete (data end, summary, footer valid)"
                      : "INCOMPLETE (read up to the last intact chunk)")
    << "\n";
  for (const auto& p : info.problems) o << "problem:   " << p << "\n";
  const double duration_s =
      info.end_ns > info.start_ns ? static_cast<double>(info.end_ns - info.start_ns) * 1e-9 : 0.0;
  std::snprintf(line, sizeof line, "duration:  %.3f s of log (wall-clock) time (%" PRIu64 " .. %" PRIu64 " ns)\n",
                duration_s, info.start_ns, info.end_ns);
  o << line;
  bool any_ticks = false;
  uint64_t first_tick = 0, last_tick = 0;
  for (const auto& c : info.channels) {
    if (!c.has_ticks) continue;
    first_tick = any_ticks ? std::min(first_tick, c.first_tick) : c.first_tick;
    last_tick = any_ticks ? std::max(last_tick, c.last_tick) : c.last_tick;
    any_ticks = true;
  }
  if (any_ticks) {
    std::snprintf(line, sizeof line, "simulated: %.3f s (ticks %" PRIu64 " .. %" PRIu64 " of 1 ms)\n",
                  static_cast<double>(last_tick - first_tick) * kPlantTick_s, first_tick, last_tick);
    o << line;
  }
  o << "messages:  " << info.messages << " in " << info.chunks << " chunks, "
    << info.channels.size() << " channels\n";
  if (info.chunks > 0) {
    std::string kinds;
    for (const auto& [name, n] : info.chunk_compression)
      kinds += (kinds.empty() ? "" : ", ") + std::to_string(n) + " " + name;
    std::snprintf(line, sizeof line,
                  "chunks:    %s; records %.3f MB, stored %.3f MB (ratio %.2f)\n",
                  kinds.c_str(), static_cast<double>(info.chunk_records_bytes) * 1e-6,
                  static_cast<double>(info.chunk_stored_bytes) * 1e-6,
                  info.chunk_stored_bytes > 0 ? static_cast<double>(info.chunk_records_bytes) /
                                                    static_cast<double>(info.chunk_stored_bytes)
                                              : 0.0);
    o << line;
  }
  o << "\n";
  o << "rates: sim_hz per simulated second (from the messages' ticks; the topic's own rate), "
       "wall_hz per second of log time (lockstep runs the simulated clock faster or slower "
       "than the wall clock)\n";
  std::snprintf(line, sizeof line, "%-4s %-28s %-26s %10s %10s %10s %11s %9s %8s\n", "id", "topic",
                "type", "messages", "sim_hz", "wall_hz", "max_gap_ms", "missing", "loss_%");
  o << line;
  for (const auto& c : info.channels) {
    uint64_t expected = 0;
    for (const auto& l : c.streams) expected += l.expected;
    std::string missing = c.loss_analysed ? std::to_string(c.missing) : "-";
    char loss[32] = "-";
    if (c.loss_analysed && expected > 0)
      std::snprintf(loss, sizeof loss, "%.3f", 100.0 * static_cast<double>(c.missing) /
                                                   static_cast<double>(expected));
    char sim_hz[32] = "-";
    if (c.sim_rate_hz > 0) std::snprintf(sim_hz, sizeof sim_hz, "%.1f", c.sim_rate_hz);
    std::snprintf(line, sizeof line, "%-4u %-28s %-26s %10" PRIu64 " %10s %10.1f %11.3f %9s %8s\n",
                  c.id, c.topic.c_str(), c.schema_name.c_str(), c.count, sim_hz, c.rate_hz,
                  static_cast<double>(c.max_log_gap_ns) * 1e-6, missing.c_str(), loss);
    o << line;
  }
  if (info.loss_events.total_samples > 0) {
    o << "\nloss events (missing samples per producer and tick, one per lost batch): "
      << info.loss_events.total_events << " for " << info.loss_events.total_samples << " samples;";
    for (const auto& [producer, n] : info.loss_events.events)
      o << " " << producer << " " << n << " (" << info.loss_events.samples.at(producer) << " samples)";
    o << "\n";
  }
  o << "\nchannel metadata (QoS of the topic's writers and of the recorder's reader):\n";
  for (const auto& c : info.channels) {
    o << "  " << c.topic << ":";
    for (const auto& [k, v] : c.metadata) o << " " << k << "=" << v << ";";
    o << "\n";
  }
  bool header = false;
  for (const auto& c : info.channels) {
    for (const auto& l : c.streams) {
      if (!header) {
        o << "\nloss from tick numbers (per instance):\n";
        header = true;
      }
      std::snprintf(line, sizeof line,
                    "  %-28s %-12s ticks %" PRIu64 "..%" PRIu64 " step %" PRIu64
                    ": %" PRIu64 " received, %" PRIu64 " expected, %" PRIu64
                    " missing in %" PRIu64 " gaps (largest %" PRIu64 " ticks), %" PRIu64
                    " duplicate/reordered (%" PRIu64 " of them filled a hole)\n",
                    c.topic.c_str(), l.key.empty() ? "-" : l.key.c_str(), l.first_tick,
                    l.last_tick, l.step_ticks, l.count, l.expected, l.missing, l.gaps,
                    l.max_gap_ticks, l.not_increasing, l.filled_late);
      o << line;
      if (l.late_start_ticks > 0 || l.early_end_ticks > 0) {
        std::snprintf(line, sizeof line,
                      "  %-28s %-12s   PARTIAL: starts %" PRIu64 " ticks after and ends %" PRIu64
                      " ticks before the topic's other instances\n",
                      "", "", l.late_start_ticks, l.early_end_ticks);
        o << line;
      }
    }
  }
  return o.str();
}

}  // namespace hexa::recorder
