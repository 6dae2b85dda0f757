// Ticks, keys and loss: which tick and stream a recorded message belongs to, the holes in each
// stream's ticks, and loss events per producer.

#include "hexa/recording/recording.hpp"

#include <algorithm>

namespace hexa::recorder {
namespace gp = google::protobuf;

std::optional<uint64_t> MessageTick(const gp::Message& message) {
  const gp::Descriptor* d = message.GetDescriptor();
  const gp::Reflection* r = message.GetReflection();
  auto as_uint = [](const gp::Message& m, const gp::FieldDescriptor* f) -> std::optional<uint64_t> {
    if (f == nullptr || f->is_repeated()) return std::nullopt;
    const gp::Reflection* rr = m.GetReflection();
    switch (f->cpp_type()) {
      case gp::FieldDescriptor::CPPTYPE_UINT64: return rr->GetUInt64(m, f);
      case gp::FieldDescriptor::CPPTYPE_UINT32: return rr->GetUInt32(m, f);
      case gp::FieldDescriptor::CPPTYPE_INT64: return static_cast<uint64_t>(rr->GetInt64(m, f));
      case gp::FieldDescriptor::CPPTYPE_INT32: return static_cast<uint64_t>(rr->GetInt32(m, f));
      default: return std::nullopt;
    }
  };
  const gp::FieldDescriptor* header = d->FindFieldByName("header");
  if (header != nullptr && !header->is_repeated() &&
      header->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE) {
    const gp::Message& h = r->GetMessage(message, header);
    if (auto t = as_uint(h, h.GetDescriptor()->FindFieldByName("tick"))) return t;
  }
  if (auto t = as_uint(message, d->FindFieldByName("tick"))) return t;
  return as_uint(message, d->FindFieldByName("sequence"));
}

std::string LegStreamKey(uint32_t leg) { return "leg " + std::to_string(leg); }

uint32_t LegOfKey(const std::string& key) {
  if (key.rfind("leg ", 0) != 0 || key.size() == 4 || key.size() > 13) return 0;
  uint64_t leg = 0;
  for (std::size_t i = 4; i < key.size(); ++i) {
    if (key[i] < '0' || key[i] > '9') return 0;
    leg = leg * 10 + static_cast<uint64_t>(key[i] - '0');
  }
  return leg <= UINT32_MAX ? static_cast<uint32_t>(leg) : 0;
}

std::string MessageKey(const gp::Message& message) {
  const gp::Descriptor* d = message.GetDescriptor();
  const gp::Reflection* r = message.GetReflection();
  if (const auto* f = d->FindFieldByName("leg_id");
      f != nullptr && !f->is_repeated() && f->cpp_type() == gp::FieldDescriptor::CPPTYPE_UINT32)
    return LegStreamKey(r->GetUInt32(message, f));
  if (const auto* f = d->FindFieldByName("node_name");
      f != nullptr && !f->is_repeated() && f->cpp_type() == gp::FieldDescriptor::CPPTYPE_STRING)
    return "node " + r->GetString(message, f);
  return "";
}

std::size_t TickLossTracker::StreamIndex(const std::string& key) {
  const auto [it, inserted] = index_.try_emplace(key, streams_.size());
  if (inserted) streams_.emplace_back();
  return it->second;
}

void TickLossTracker::AddAt(std::size_t stream_index, uint64_t tick) {
  Stream& s = streams_[stream_index];
  if (s.count == 0) {
    s.first = s.last = s.max_tick = tick;
  } else if (tick > s.max_tick) {
    const uint64_t delta = tick - s.max_tick;
    if (delta <= kSmallDeltas) {
      ++s.small_deltas[delta];
    } else {
      ++s.large_deltas[delta];
    }
    if (delta > 1) {
      if (s.jumps.size() < kMaxKept) s.jumps.emplace_back(s.max_tick, tick);
      else s.overflow = true;
    }
    s.max_tick = tick;
  } else {
    ++s.not_increasing;  // duplicate or late sample: not a loss, but reported
    if (s.late.size() < kMaxKept) s.late.push_back(tick);
    else s.overflow = true;
  }
  s.first = std::min(s.first, tick);
  s.last = s.max_tick;
  ++s.count;
}

// The holes a stream's forward jumps left, less the ticks that arrived later (reordered):
// each jump of n steps leaves n - 1 expected ticks (from + k step); a late sample on one of
// them fills it. What stays unfilled is missing, each run of unfilled ticks one gap, and the
// largest gap is the longest such run in ticks (plus one step, like a plain jump).
void TickLossTracker::CountHoles(const Stream& s, StreamLoss& l) {
  std::vector<uint64_t> late = s.late;
  std::sort(late.begin(), late.end());
  late.erase(std::unique(late.begin(), late.end()), late.end());
  const uint64_t step = l.step_ticks;
  uint64_t largest = 0;
  for (uint64_t d = 1; d <= std::min<uint64_t>(step, kSmallDeltas); ++d)
    if (s.small_deltas[d] > 0) largest = std::max(largest, d);
  for (const auto& [from, to] : s.jumps) {
    const uint64_t delta = to - from;
    if (delta <= step) continue;
    // Round to the nearest whole number of steps: a late sample shifts one difference.
    const uint64_t steps = (delta + step / 2) / step;
    if (steps <= 1) {
      largest = std::max(largest, delta);
      continue;
    }
    // Positions 1 .. steps-1 of this hole that a late sample filled, ascending.
    uint64_t filled = 0, runs = 0, previous = 0, longest_run = 0;
    for (auto it = std::upper_bound(late.begin(), late.end(), from); it != late.end() && *it < to; ++it) {
      if ((*it - from) % step != 0) continue;
      const uint64_t position = (*it - from) / step;
      if (position == 0 || position >= steps) continue;
      if (position > previous + 1) {
        ++runs;
        longest_run = std::max(longest_run, position - previous - 1);
      }
      previous = position;
      ++filled;
    }
    if (steps - 1 > previous) {
      ++runs;
      longest_run = std::max(longest_run, steps - 1 - previous);
    }
    l.filled_late += filled;
    l.missing += steps - 1 - filled;
    l.gaps += runs;
    largest = std::max(largest, runs > 0 ? (longest_run + 1) * step : step);
  }
  l.max_gap_ticks = std::max<uint64_t>(largest, step);
}

std::vector<StreamLoss> TickLossTracker::Results() const {
  std::vector<StreamLoss> out;
  for (const auto& [key, index] : index_) {
    const Stream& s = streams_[index];
    StreamLoss l;
    l.key = key;
    l.count = s.count;
    l.first_tick = s.first;
    l.last_tick = s.last;
    l.not_increasing = s.not_increasing;
    std::vector<std::pair<uint64_t, uint64_t>> histogram;  // (delta, count), delta ascending
    for (uint64_t d = 1; d <= kSmallDeltas; ++d) {
      if (s.small_deltas[d] > 0) histogram.emplace_back(d, s.small_deltas[d]);
    }
    histogram.insert(histogram.end(), s.large_deltas.begin(), s.large_deltas.end());
    uint64_t best = 0;
    for (const auto& [delta, n] : histogram) {
      if (n > best) {
        best = n;
        l.step_ticks = delta;
      }
      l.max_gap_ticks = std::max(l.max_gap_ticks, delta);
    }
    if (l.step_ticks == 0) l.step_ticks = 1;
    if (s.overflow) {
      for (const auto& [delta, n] : histogram) {
        if (delta > l.step_ticks) {
          // Round to the nearest whole number of steps: a late sample shifts one difference.
          const uint64_t steps = (delta + l.step_ticks / 2) / l.step_ticks;
          if (steps > 1) {
            l.missing += (steps - 1) * n;
            l.gaps += n;
          }
        }
      }
    } else {
      CountHoles(s, l);
    }
    l.expected = (l.last_tick - l.first_tick) / l.step_ticks + 1;
    out.push_back(l);
  }
  return out;
}

std::map<std::string, std::vector<uint64_t>> TickLossTracker::MissingTicks() const {
  std::map<std::string, std::vector<uint64_t>> out;
  const std::vector<StreamLoss> results = Results();
  for (const StreamLoss& l : results) {
    const Stream& s = streams_[index_.at(l.key)];
    std::vector<uint64_t>& ticks = out[l.key];
    if (s.overflow) continue;
    std::vector<uint64_t> late = s.late;
    std::sort(late.begin(), late.end());
    const uint64_t step = l.step_ticks;
    for (const auto& [from, to] : s.jumps) {
      const uint64_t delta = to - from;
      if (delta <= step) continue;
      const uint64_t steps = (delta + step / 2) / step;  // as CountHoles
      for (uint64_t k = 1; k < steps; ++k) {
        const uint64_t tick = from + k * step;
        if (!std::binary_search(late.begin(), late.end(), tick)) ticks.push_back(tick);
      }
    }
  }
  return out;
}

std::string ProducerOf(const std::string& topic, const std::string& key) {
  if (topic == "hexa_LegSensors" || topic == "hexa_GroundTruth" || topic == "hexa_ImuSample" ||
      topic == "hexa_TrackerPose")
    return "plant";
  if (topic == "hexa_LegSetpoint" || topic == "hexa_PoseReport") return "supervisor";
  if (topic == "hexa_ValveCommand") return key.empty() ? "legs" : key;
  return topic;
}

void LossEventCounter::AddTopic(const std::string& topic,
                                const std::map<std::string, std::vector<uint64_t>>& missing) {
  for (const auto& [key, ticks] : missing) {
    auto& all = ticks_[ProducerOf(topic, key)];
    all.insert(all.end(), ticks.begin(), ticks.end());
  }
}

LossEvents LossEventCounter::Finish() const {
  LossEvents e;
  for (auto [producer, ticks] : ticks_) {
    e.samples[producer] = ticks.size();
    std::sort(ticks.begin(), ticks.end());
    e.events[producer] = static_cast<uint64_t>(std::unique(ticks.begin(), ticks.end()) - ticks.begin());
    e.total_samples += e.samples[producer];
    e.total_events += e.events[producer];
  }
  return e;
}

}  // namespace hexa::recorder
