#include "hexa/recording/recording.hpp"

#include <fnmatch.h>
#include <sys/stat.h>
#include <unistd.h>

#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/descriptor_database.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

#include "hexa/core/param_checks.hpp"
#include "hexa/recording/csv_columns.hpp"
#include "hexa/services/text.hpp"

namespace hexa::recorder {
namespace gp = google::protobuf;

// ================================================================ schemas and writing

std::string FileDescriptorSetFor(const gp::Descriptor& type) {
  gp::FileDescriptorSet set;
  std::set<std::string> seen;
  // Post-order: every dependency precedes the files that import it.
  std::function<void(const gp::FileDescriptor*)> add = [&](const gp::FileDescriptor* f) {
    if (!seen.insert(f->name()).second) return;
    for (int i = 0; i < f->dependency_count(); ++i) add(f->dependency(i));
    f->CopyTo(set.add_file());
  };
  add(type.file());
  return set.SerializeAsString();
}

uint16_t RecordingWriter::AddTopic(const std::string& topic, const gp::Descriptor& type,
                                   std::map<std::string, std::string> metadata) {
  auto it = schema_ids_.find(type.full_name());
  if (it == schema_ids_.end()) {
    const uint16_t id = mcap_.AddSchema(type.full_name(), kProtobufEncoding,
                                        FileDescriptorSetFor(type));
    it = schema_ids_.emplace(type.full_name(), id).first;
  }
  metadata.emplace(kMetaType, type.full_name());
  return mcap_.AddChannel(it->second, topic, kProtobufEncoding, std::move(metadata));
}

void RecordingWriter::Write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns,
                            const gp::Message& message) {
  buffer_.clear();
  if (!message.AppendToString(&buffer_))
    throw McapError("cannot serialize a " + message.GetTypeName() + " message");
  mcap_.Write(channel_id, log_time_ns, publish_time_ns, buffer_);
}

// ================================================================ decoding

namespace {
namespace io = gp::io;

// Copies one message's wire bytes from `in` to `out`, repairing the UTF-8 of every string
// field of `type` and of its nested messages. False on malformed wire data (or groups, which
// proto3 schemas do not have). `changed` is set when a string was rewritten.
bool RewriteStrings(io::CodedInputStream& in, const gp::Descriptor* type, std::string& out,
                    bool& changed, int depth) {
  if (depth > 64) return false;
  io::StringOutputStream sink(&out);
  io::CodedOutputStream os(&sink);
  while (true) {
    const uint32_t tag = in.ReadTag();
    if (tag == 0) return in.ConsumedEntireMessage() || in.BytesUntilLimit() == 0;
    const uint32_t number = tag >> 3;
    const gp::FieldDescriptor* field = type != nullptr ? type->FindFieldByNumber(static_cast<int>(number)) : nullptr;
    switch (tag & 7) {
      case 0: {  // varint
        uint64_t v = 0;
        if (!in.ReadVarint64(&v)) return false;
        os.WriteTag(tag);
        os.WriteVarint64(v);
        break;
      }
      case 1: {  // 64-bit
        uint64_t v = 0;
        if (!in.ReadLittleEndian64(&v)) return false;
        os.WriteTag(tag);
        os.WriteLittleEndian64(v);
        break;
      }
      case 5: {  // 32-bit
        uint32_t v = 0;
        if (!in.ReadLittleEndian32(&v)) return false;
        os.WriteTag(tag);
        os.WriteLittleEndian32(v);
        break;
      }
      case 2: {  // length-delimited
        uint32_t length = 0;
        if (!in.ReadVarint32(&length) || static_cast<int>(length) < 0 ||
            static_cast<int>(length) > in.BytesUntilLimit()) {
          return false;
        }
        std::string bytes;
        if (field != nullptr && field->type() == gp::FieldDescriptor::TYPE_MESSAGE) {
          const io::CodedInputStream::Limit limit = in.PushLimit(static_cast<int>(length));
          bool ok = RewriteStrings(in, field->message_type(), bytes, changed, depth + 1);
          ok = ok && in.BytesUntilLimit() == 0;
          in.PopLimit(limit);
          if (!ok) return false;
        } else {
          if (!in.ReadString(&bytes, static_cast<int>(length))) return false;
          if (field != nullptr && field->type() == gp::FieldDescriptor::TYPE_STRING &&
              !text::IsValidUtf8(bytes)) {
            bytes = text::RepairUtf8(bytes);
            changed = true;
          }
        }
        os.WriteTag(tag);
        os.WriteVarint32(static_cast<uint32_t>(bytes.size()));
        os.WriteString(bytes);
        break;
      }
      default:
        return false;
    }
  }
}

}  // namespace

ParseOutcome ParseRepairingUtf8(std::string_view data, gp::Message& message,
                                std::string* repaired_bytes) {
  if (data.size() > static_cast<size_t>(INT32_MAX)) return ParseOutcome::kFailed;
  if (message.ParseFromArray(data.data(), static_cast<int>(data.size()))) return ParseOutcome::kOk;
  std::string rewritten;
  bool changed = false;
  {
    io::CodedInputStream in(reinterpret_cast<const uint8_t*>(data.data()),
                            static_cast<int>(data.size()));
    if (!RewriteStrings(in, message.GetDescriptor(), rewritten, changed, 0) || !changed) {
      message.Clear();
      return ParseOutcome::kFailed;
    }
  }
  if (!message.ParseFromString(rewritten)) {
    message.Clear();
    return ParseOutcome::kFailed;
  }
  if (repaired_bytes != nullptr) *repaired_bytes = std::move(rewritten);
  return ParseOutcome::kRepaired;
}

namespace {
class CollectErrors : public gp::DescriptorPool::ErrorCollector {
 public:
  void AddError(const std::string& filename, const std::string& element_name,
                const gp::Message*, ErrorLocation, const std::string& message) override {
    if (!text.empty()) text += "; ";
    text += filename + ": " + element_name + ": " + message;
  }
  std::string text;
};

}  // namespace

ProtoDecoder::ProtoDecoder() : factory_(std::make_unique<gp::DynamicMessageFactory>()) {}

ProtoDecoder::~ProtoDecoder() {
  channel_messages_.clear();  // messages before the factory that describes them
  factory_.reset();
  schemas_.clear();
}

namespace {
// Fields of `recorded` (a recording's schema) against the same message type compiled into
// this build, nested message types included: "" when they agree.
void CompareFields(const gp::Descriptor& recorded, const gp::Descriptor& compiled,
                   const std::string& prefix, std::set<std::string>& visited,
                   std::vector<std::string>& only_compiled, std::vector<std::string>& only_recorded,
                   std::vector<std::string>& changed) {
  if (!visited.insert(compiled.full_name()).second) return;
  for (int i = 0; i < compiled.field_count(); ++i) {
    const gp::FieldDescriptor* c = compiled.field(i);
    const gp::FieldDescriptor* r = recorded.FindFieldByNumber(c->number());
    if (r == nullptr) {
      only_compiled.push_back(prefix + c->name());
    } else if (r->name() != c->name() || r->type() != c->type() || r->is_repeated() != c->is_repeated()) {
      changed.push_back(prefix + c->name());
    } else if (c->message_type() != nullptr && r->message_type() != nullptr) {
      CompareFields(*r->message_type(), *c->message_type(), prefix + c->name() + ".", visited,
                    only_compiled, only_recorded, changed);
    }
  }
  for (int i = 0; i < recorded.field_count(); ++i)
    if (compiled.FindFieldByNumber(recorded.field(i)->number()) == nullptr)
      only_recorded.push_back(prefix + recorded.field(i)->name());
}
}  // namespace

std::string SchemaDifference(const gp::Descriptor& recorded) {
  const gp::Descriptor* compiled =
      gp::DescriptorPool::generated_pool()->FindMessageTypeByName(recorded.full_name());
  if (compiled == nullptr) return "";  // a type this build does not know: nothing to compare
  std::set<std::string> visited;
  std::vector<std::string> only_compiled, only_recorded, changed;
  CompareFields(recorded, *compiled, "", visited, only_compiled, only_recorded, changed);
  if (only_compiled.empty() && only_recorded.empty() && changed.empty()) return "";
  auto list = [](const std::vector<std::string>& v) {
    std::string out;
    for (const auto& f : v) out += (out.empty() ? "" : ", ") + f;
    return out;
  };
  std::string out = "schema " + recorded.full_name() +
                    " differs from this build's (recorded by another build):";
  if (!only_compiled.empty()) out += " not in the recording: " + list(only_compiled) + " (read as absent);";
  if (!only_recorded.empty()) out += " unknown to this build: " + list(only_recorded) + " (ignored);";
  if (!changed.empty()) out += " changed name or type: " + list(changed) + ";";
  out.pop_back();
  return out;
}

void ProtoDecoder::AddSchema(const McapSchema& schema) {
  const std::string what = "schema " + std::to_string(schema.id) + " '" + text::Excerpt(schema.name) + "'";
  if (auto it = schemas_.find(schema.id); it != schemas_.end()) {
    const McapSchema& had = it->second.record;
    if (had.name == schema.name && had.encoding == schema.encoding && had.data == schema.data) return;
    // Replacing it would leave the channels decoded with it pointing into a deleted pool.
    throw McapError(what + ": schema id " + std::to_string(schema.id) +
                    " is defined again with different content (MCAP requires repeats to be identical)");
  }
  if (schema.encoding != kProtobufEncoding)
    throw McapError(what + ": unknown schema encoding '" + schema.encoding +
                    "' (this tool decodes only \"protobuf\")");
  gp::FileDescriptorSet set;
  if (!set.ParseFromString(schema.data))
    throw McapError(what + ": schema data is not a serialized FileDescriptorSet");
  auto db = std::make_unique<gp::SimpleDescriptorDatabase>();
  for (const auto& file : set.file()) {
    if (!db->Add(file))
      throw McapError(what + ": FileDescriptorSet holds a conflicting file '" + file.name() + "'");
  }
  SchemaEntry entry;
  auto errors = std::make_unique<CollectErrors>();
  entry.pool = std::make_unique<gp::DescriptorPool>(db.get(), errors.get());
  entry.database = std::move(db);
  const gp::Descriptor* type = entry.pool->FindMessageTypeByName(schema.name);
  if (type == nullptr)
    throw McapError(what + ": unknown schema: no message named '" + text::Excerpt(schema.name) +
                    "' in its FileDescriptorSet" +
                    (errors->text.empty() ? std::string() : " (" + text::Sanitize(errors->text, 1024) + ")"));
  entry.errors = std::move(errors);
  entry.type = type;
  if (std::string difference = SchemaDifference(*type); !difference.empty())
    schema_differences_.push_back(std::move(difference));
  entry.record = schema;
  schemas_[schema.id] = std::move(entry);
}

void ProtoDecoder::AddChannel(const McapChannel& channel) {
  const std::string what = "channel " + std::to_string(channel.id) + " '" + text::Excerpt(channel.topic) + "'";
  if (auto it = channel_records_.find(channel.id); it != channel_records_.end()) {
    const McapChannel& had = it->second;
    if (had.schema_id == channel.schema_id && had.topic == channel.topic &&
        had.message_encoding == channel.message_encoding && had.metadata == channel.metadata)
      return;
    throw McapError(what + ": channel id " + std::to_string(channel.id) +
                    " is defined again with different content (MCAP requires repeats to be identical)");
  }
  if (channel.message_encoding != kProtobufEncoding)
    throw McapError(what + ": unknown message encoding '" + channel.message_encoding +
                    "' (this tool decodes only \"protobuf\")");
  auto it = schemas_.find(channel.schema_id);
  if (it == schemas_.end())
    throw McapError(what + ": unknown schema id " + std::to_string(channel.schema_id));
  channel_messages_[channel.id].reset(factory_->GetPrototype(it->second.type)->New());
  channel_records_[channel.id] = channel;
  if (channel_topics_.size() <= channel.id) channel_topics_.resize(channel.id + 1u);
  channel_topics_[channel.id] = channel.topic;
}

const gp::Message& ProtoDecoder::Decode(const McapMessageView& m) {
  auto it = channel_messages_.find(m.channel_id);
  if (it == channel_messages_.end())
    throw McapError("message on undecodable channel " + std::to_string(m.channel_id));
  gp::Message& msg = *it->second;
  const ParseOutcome outcome = ParseRepairingUtf8(m.data, msg);
  if (outcome == ParseOutcome::kFailed)
    throw McapError("message " + std::to_string(m.sequence) + " on channel '" +
                    text::Excerpt(channel_topics_[m.channel_id]) + "' (log time " +
                    std::to_string(m.log_time_ns) + ") does not parse as " +
                    msg.GetDescriptor()->full_name());
  if (outcome == ParseOutcome::kRepaired) {
    Utf8Repairs& r = repairs_[m.channel_id];
    if (r.messages++ == 0) r.first_sequence = m.sequence;
  }
  return msg;
}

std::vector<std::string> ProtoDecoder::RepairProblems() const {
  std::vector<std::string> out;
  for (const auto& [channel, r] : repairs_) {
    out.push_back("channel '" + text::Excerpt(channel_topics_[channel]) + "': " +
                  std::to_string(r.messages) +
                  " message(s) with invalid UTF-8 in string fields (first: sequence " +
                  std::to_string(r.first_sequence) +
                  "), repaired on read (invalid bytes read as U+FFFD)");
  }
  return out;
}

const gp::Message* ProtoDecoder::Prototype(uint16_t channel_id) const {
  auto it = channel_messages_.find(channel_id);
  return it == channel_messages_.end() ? nullptr : it->second.get();
}

const gp::Descriptor* ProtoDecoder::descriptor(uint16_t channel_id) const {
  auto it = channel_messages_.find(channel_id);
  return it == channel_messages_.end() ? nullptr : it->second->GetDescriptor();
}

McapScanResult ReadRecording(const std::string& path, const DecodedMessageFn& fn,
                             const McapScanOptions& options, RecordingCatalog* catalog) {
  McapReader reader;
  reader.Open(path);
  ProtoDecoder decoder;
  McapVisitor v;
  v.on_schema = [&](const McapSchema& s) { decoder.AddSchema(s); };
  v.on_channel = [&](const McapChannel& c) { decoder.AddChannel(c); };
  v.on_message = [&](const McapMessageView& m) {
    const gp::Message& msg = decoder.Decode(m);
    if (fn) fn(reader.channels().at(m.channel_id), m, msg);
  };
  try {
    McapScanResult r = reader.Scan(v, options);
    for (const auto& [channel, repairs] : decoder.repairs()) r.repaired_messages += repairs.messages;
    for (auto& p : decoder.RepairProblems()) r.problems.push_back(std::move(p));
    for (const auto& d : decoder.schema_differences()) r.problems.push_back(d);
    if (catalog != nullptr) {
      catalog->schemas = reader.schemas();
      catalog->channels = reader.channels();
    }
    return r;
  } catch (const McapError& e) {
    const std::string text = e.what();
    if (text.rfind("'" + path + "'", 0) == 0) throw;
    throw McapError("'" + path + "': " + text);
  }
}

// ================================================================ ticks and loss

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

// ================================================================ info

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

// ================================================================ diff

DiffReport DiffValveCommands(const std::string& path_a, const std::string& path_b,
                             double tolerance_v) {
  using Series = std::map<uint32_t, std::vector<std::pair<uint64_t, double>>>;
  auto load = [](const std::string& path) {
    Series s;
    uint64_t n = 0;
    ReadRecording(path, [&](const McapChannel&, const McapMessageView&, const gp::Message& msg) {
      const gp::Descriptor* d = msg.GetDescriptor();
      if (d->full_name() != "hexa.rec.ValveCommand") return;
      const gp::Reflection* r = msg.GetReflection();
      const auto* leg = d->FindFieldByName("leg_id");
      const auto* v = d->FindFieldByName("valve_v");
      const auto tick = MessageTick(msg);
      if (leg == nullptr || v == nullptr || !tick) return;
      s[r->GetUInt32(msg, leg)].emplace_back(*tick, r->GetDouble(msg, v));
      ++n;
    });
    if (n == 0) throw McapError("'" + path + "' holds no hexa.rec.ValveCommand messages");
    for (auto& [leg, v] : s)
      std::stable_sort(v.begin(), v.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
    return s;
  };
  const Series a = load(path_a), b = load(path_b);
  std::set<uint32_t> legs;
  for (const auto& [l, v] : a) legs.insert(l);
  for (const auto& [l, v] : b) legs.insert(l);
  DiffReport report;
  static const std::vector<std::pair<uint64_t, double>> kEmpty;
  for (uint32_t leg : legs) {
    const auto& va = a.count(leg) ? a.at(leg) : kEmpty;
    const auto& vb = b.count(leg) ? b.at(leg) : kEmpty;
    LegDiff d;
    d.leg_id = leg;
    double sum_sq = 0.0;
    size_t i = 0, j = 0;
    auto mark = [&](uint64_t tick) {
      if (!d.differs || tick < d.first_diff_tick) d.first_diff_tick = tick;
      d.differs = true;
    };
    while (i < va.size() || j < vb.size()) {
      // Duplicate ticks within one file: the first sample counts.
      if (i > 0 && i < va.size() && va[i].first == va[i - 1].first) { ++i; continue; }
      if (j > 0 && j < vb.size() && vb[j].first == vb[j - 1].first) { ++j; continue; }
      if (j >= vb.size() || (i < va.size() && va[i].first < vb[j].first)) {
        ++d.only_a;
        mark(va[i].first);
        ++i;
      } else if (i >= va.size() || vb[j].first < va[i].first) {
        ++d.only_b;
        mark(vb[j].first);
        ++j;
      } else {
        const double diff = std::fabs(va[i].second - vb[j].second);
        // NaN in one file and not the other is a difference.
        if (diff > tolerance_v || (std::isnan(va[i].second) != std::isnan(vb[j].second)))
          mark(va[i].first);
        if (std::isfinite(diff)) {
          d.max_abs_diff_v = std::max(d.max_abs_diff_v, diff);
          sum_sq += diff * diff;
        }
        ++d.common_ticks;
        ++i;
        ++j;
      }
    }
    d.rms_diff_v = d.common_ticks ? std::sqrt(sum_sq / static_cast<double>(d.common_ticks)) : 0.0;
    report.identical = report.identical && !d.differs;
    report.legs.push_back(d);
  }
  return report;
}

std::string FormatDiff(const DiffReport& report) {
  std::ostringstream o;
  char line[256];
  std::snprintf(line, sizeof line, "%-4s %12s %8s %8s %14s %14s %18s\n", "leg", "common_ticks",
                "only_a", "only_b", "max_abs_diff_v", "rms_diff_v", "first_diff_tick");
  o << line;
  for (const auto& d : report.legs) {
    std::string first = d.differs ? std::to_string(d.first_diff_tick) : "-";
    std::snprintf(line, sizeof line, "%-4u %12" PRIu64 " %8" PRIu64 " %8" PRIu64 " %14.6g %14.6g %18s\n",
                  d.leg_id, d.common_ticks, d.only_a, d.only_b, d.max_abs_diff_v, d.rms_diff_v,
                  first.c_str());
    o << line;
  }
  o << (report.identical ? "valve command streams are identical\n"
                         : "valve command streams differ\n");
  return o.str();
}

// ================================================================ export

bool TopicFilter::NamesExplicitly(const std::string& topic) const {
  return std::find(include.begin(), include.end(), topic) != include.end();
}

bool TopicFilter::Matches(const std::string& topic) const {
  auto any = [&](const std::vector<std::string>& globs) {
    for (const auto& g : globs)
      if (fnmatch(g.c_str(), topic.c_str(), 0) == 0) return true;
    return false;
  };
  if (!include.empty() && !any(include)) return false;
  return !any(exclude);
}

namespace {
void CsvField(std::string& out, const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) {
    out += s;
    return;
  }
  out += '"';
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

std::string ScalarText(const gp::Message& m, const gp::FieldDescriptor* f, int index) {
  const gp::Reflection* r = m.GetReflection();
  const bool rep = f->is_repeated();
  char buf[64];
  switch (f->cpp_type()) {
    case gp::FieldDescriptor::CPPTYPE_DOUBLE:
      std::snprintf(buf, sizeof buf, "%.17g", rep ? r->GetRepeatedDouble(m, f, index) : r->GetDouble(m, f));
      return buf;
    case gp::FieldDescriptor::CPPTYPE_FLOAT:
      std::snprintf(buf, sizeof buf, "%.9g", rep ? r->GetRepeatedFloat(m, f, index) : r->GetFloat(m, f));
      return buf;
    case gp::FieldDescriptor::CPPTYPE_INT32:
      return std::to_string(rep ? r->GetRepeatedInt32(m, f, index) : r->GetInt32(m, f));
    case gp::FieldDescriptor::CPPTYPE_INT64:
      return std::to_string(rep ? r->GetRepeatedInt64(m, f, index) : r->GetInt64(m, f));
    case gp::FieldDescriptor::CPPTYPE_UINT32:
      return std::to_string(rep ? r->GetRepeatedUInt32(m, f, index) : r->GetUInt32(m, f));
    case gp::FieldDescriptor::CPPTYPE_UINT64:
      return std::to_string(rep ? r->GetRepeatedUInt64(m, f, index) : r->GetUInt64(m, f));
    case gp::FieldDescriptor::CPPTYPE_BOOL:
      return (rep ? r->GetRepeatedBool(m, f, index) : r->GetBool(m, f)) ? "1" : "0";
    case gp::FieldDescriptor::CPPTYPE_ENUM:
      return (rep ? r->GetRepeatedEnum(m, f, index) : r->GetEnum(m, f))->name();
    case gp::FieldDescriptor::CPPTYPE_STRING:
      return rep ? r->GetRepeatedString(m, f, index) : r->GetString(m, f);
    default:
      return "";
  }
}

// Column layout of one channel: fixed by the first message (repeated-field sizes included).
struct Column {
  std::vector<const gp::FieldDescriptor*> path;  // nested singular messages, then the leaf
  int index = -1;                                // element of a repeated leaf
  std::string name;
};

void BuildColumns(const gp::Message& m, std::vector<const gp::FieldDescriptor*> path,
                  const std::string& prefix, std::vector<Column>& out) {
  const gp::Descriptor* d = m.GetDescriptor();
  const gp::Reflection* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* f = d->field(i);
    auto p = path;
    p.push_back(f);
    const std::string name = prefix + f->name();
    if (f->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE) {
      if (!f->is_repeated()) BuildColumns(r->GetMessage(m, f), p, name + ".", out);
      continue;  // repeated messages have no flat CSV form
    }
    if (f->is_repeated()) {
      for (int k = 0; k < r->FieldSize(m, f); ++k)
        out.push_back({p, k, prefix + ElementName(*f, k) + " [" + ColumnUnit(*f, k) + "]"});
    } else {
      out.push_back({p, -1, name + " [" + ColumnUnit(*f, -1) + "]"});
    }
  }
}

struct ExportedFile {
  std::string file, topic, type;
  uint64_t rows;
  std::vector<std::string> columns;
};

// README.txt beside the CSVs: what each file holds and how its header reads.
void WriteExportReadme(const std::string& readme, const std::string& recording,
                       const std::vector<ExportedFile>& files) {
  std::ofstream o(readme);
  if (!o) throw McapError("cannot write '" + readme + "': " + std::strerror(errno));
  o << "CSV export of " << recording << " (hexa_recorder export; docs/recorder.md, \"Export\").\n\n"
    << "One file per topic, one row per recorded message. Every header cell is \"name [unit]\":\n"
    << "SI units (m, rad, s, ns, Pa, V, N, kg, Hz and their products), [1] for a dimensionless\n"
    << "number (counts, ids, tick numbers of 1 ms, flags 0/1, quaternion components, scale\n"
    << "factors), [-] for text (strings, enum names). Nested fields read a.b; repeated fields\n"
    << "name the component they hold (desired_pose.x, orientation_wxyz.w, leg_length_m.leg3)\n"
    << "or their index (name[i]). log_time_ns: when the recorder received the message;\n"
    << "publish_time_ns: the writer's source time (both CLOCK_REALTIME); header.tick and\n"
    << "header.sim_time_s: the simulated time the sample belongs to. The Foxglove 3-D scene\n"
    << "(hexa_Scene, hexa_FrameTransforms) has no flat form and is exported only when --topics\n"
    << "names it.\n\n";
  for (const auto& f : files) {
    o << f.file << ": topic " << f.topic << ", message " << f.type << ", " << f.rows << " rows\n";
    const std::string what = MessageDescription(f.type);
    if (!what.empty()) o << "  " << what << "\n";
    o << "  columns: log_time_ns [ns], publish_time_ns [ns], sequence [1]";
    for (const auto& c : f.columns) o << ", " << c;
    o << "\n\n";
  }
  if (!o) throw McapError("writing '" + readme + "' failed");
}

std::string ColumnValue(const gp::Message& root, const Column& c) {
  const gp::Message* m = &root;
  for (size_t i = 0; i + 1 < c.path.size(); ++i) m = &m->GetReflection()->GetMessage(*m, c.path[i]);
  const gp::FieldDescriptor* leaf = c.path.back();
  if (c.index >= 0 && c.index >= m->GetReflection()->FieldSize(*m, leaf)) return "";
  return ScalarText(*m, leaf, c.index);
}
}  // namespace

ExportResult ExportCsv(const std::string& path, const std::string& out_dir,
                       const TopicFilter& filter) {
  struct stat st {};
  if (::stat(out_dir.c_str(), &st) != 0 && ::mkdir(out_dir.c_str(), 0755) != 0)
    throw McapError("cannot create output directory '" + out_dir + "': " + std::strerror(errno));
  struct Sink {
    std::ofstream file;
    std::string path;       // final name
    std::string temp_path;  // written here, renamed to `path` once the whole export succeeded
    std::vector<Column> columns;
    uint64_t rows = 0;
    std::string type, topic;
  };
  std::map<uint16_t, Sink> sinks;
  // All or nothing: CSVs are written under temporary names and renamed only after the whole
  // recording was read and every file closed without error; on any error the temporary files
  // are removed, so an export that fails leaves no partial CSV behind (and no older CSV of the
  // same name is touched).
  struct RemoveTemps {
    std::map<uint16_t, Sink>& sinks;
    bool armed = true;
    ~RemoveTemps() {
      if (!armed) return;
      for (auto& [id, s] : sinks) {
        s.file.close();
        std::remove(s.temp_path.c_str());
      }
    }
  } guard{sinks};
  std::string row;
  const McapScanResult scan = ReadRecording(path, [&](const McapChannel& ch, const McapMessageView& m, const gp::Message& msg) {
    if (!filter.Matches(ch.topic)) return;
    // The 3-D scene is a drawing (repeated messages, no flat form): exported only by name.
    if (msg.GetDescriptor()->file()->package() == "foxglove" && !filter.NamesExplicitly(ch.topic))
      return;
    auto it = sinks.find(ch.id);
    if (it == sinks.end()) {
      std::string name = ch.topic;
      std::replace_if(name.begin(), name.end(), [](char c) { return !std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-'; }, '_');
      name.erase(0, name.find_first_not_of('_'));
      if (name.size() > 100) name.resize(100);  // a file name, not the whole topic string
      Sink s;
      s.path = out_dir + "/" + (name.empty() ? "channel" + std::to_string(ch.id) : name) + ".csv";
      s.temp_path = s.path + ".partial." + std::to_string(::getpid());
      it = sinks.emplace(ch.id, std::move(s)).first;
      Sink& n = it->second;
      n.file.open(n.temp_path, std::ios::out | std::ios::trunc);
      if (!n.file) throw McapError("cannot write '" + n.temp_path + "': " + std::strerror(errno));
      BuildColumns(msg, {}, "", n.columns);
      n.file << "log_time_ns [ns],publish_time_ns [ns],sequence [1]";
      n.type = msg.GetDescriptor()->full_name();
      n.topic = ch.topic;
      for (const auto& c : n.columns) n.file << ',' << c.name;
      n.file << '\n';
    }
    Sink& s = it->second;
    row = std::to_string(m.log_time_ns) + ',' + std::to_string(m.publish_time_ns) + ',' +
          std::to_string(m.sequence);
    for (const auto& c : s.columns) {
      row += ',';
      CsvField(row, ColumnValue(msg, c));
    }
    row += '\n';
    s.file << row;
    if (!s.file) throw McapError("writing '" + s.temp_path + "' failed: " + std::strerror(errno));
    ++s.rows;
  });
  ExportResult result;
  for (auto& [id, s] : sinks) {
    s.file.close();
    if (!s.file) throw McapError("writing '" + s.temp_path + "' failed");
  }
  for (auto& [id, s] : sinks) {
    if (std::rename(s.temp_path.c_str(), s.path.c_str()) != 0)
      throw McapError("cannot rename '" + s.temp_path + "' to '" + s.path + "': " + std::strerror(errno));
    result.files.emplace_back(s.path, s.rows);
  }
  guard.armed = false;
  result.warnings = scan.problems;
  std::vector<ExportedFile> described;
  for (const auto& [id, s] : sinks) {
    ExportedFile e{s.path.substr(out_dir.size() + 1), s.topic, s.type, s.rows, {}};
    for (const auto& c : s.columns) e.columns.push_back(c.name);
    described.push_back(std::move(e));
  }
  WriteExportReadme(out_dir + "/README.txt", path, described);
  return result;
}

// ================================================================ recover

RecoverResult Recover(const std::string& in_path, const std::string& out_path,
                      const McapWriterConfig& config) {
  McapReader reader;
  reader.Open(in_path);
  McapWriterConfig out_config = config;
  out_config.sync = McapSyncMode::kNone;  // one sync at Close() is enough for a rewrite
  McapWriter writer(out_config);
  writer.Open(out_path);
  RecoverResult result;
  std::map<uint16_t, uint16_t> schema_map, channel_map;
  // Every message is also decoded with its channel's schema (protobuf channels): a file whose
  // structure is intact is not "complete" when messages in it cannot be read. Strings that are
  // not valid UTF-8 are repaired in the output (ParseRepairingUtf8); messages that do not parse
  // even then are copied unchanged and counted.
  ProtoDecoder decoder;
  std::set<uint16_t> decodable_schemas, decodable_channels;
  std::map<uint16_t, std::unique_ptr<gp::Message>> messages;
  std::map<uint16_t, std::string> topics;
  std::string repaired;
  McapVisitor v;
  v.on_schema = [&](const McapSchema& s) {
    if (!schema_map.count(s.id)) schema_map[s.id] = writer.AddSchema(s.name, s.encoding, s.data);
    try {
      decoder.AddSchema(s);
      decodable_schemas.insert(s.id);
    } catch (const McapError& e) {
      result.problems.push_back(std::string("messages of schema ") + std::to_string(s.id) +
                                " are copied without decoding: " + e.what());
    }
  };
  v.on_channel = [&](const McapChannel& c) {
    if (channel_map.count(c.id)) return;
    const uint16_t schema = c.schema_id == 0 ? 0 : schema_map.at(c.schema_id);
    channel_map[c.id] = writer.AddChannel(schema, c.topic, c.message_encoding, c.metadata);
    topics[c.id] = c.topic;
    if (decodable_schemas.count(c.schema_id) && c.message_encoding == kProtobufEncoding) {
      decoder.AddChannel(c);
      decodable_channels.insert(c.id);
    }
  };
  std::map<uint16_t, uint64_t> undecodable;
  v.on_message = [&](const McapMessageView& m) {
    std::string_view data = m.data;
    if (decodable_channels.count(m.channel_id)) {
      auto& msg = messages[m.channel_id];
      if (!msg) msg.reset(decoder.Prototype(m.channel_id)->New());
      const ParseOutcome outcome = ParseRepairingUtf8(m.data, *msg, &repaired);
      if (outcome == ParseOutcome::kRepaired) {
        data = repaired;
        ++result.repaired_messages;
      } else if (outcome == ParseOutcome::kFailed) {
        ++undecodable[m.channel_id];
        ++result.undecodable_messages;
      }
    }
    writer.WriteWithSequence(channel_map.at(m.channel_id), m.sequence, m.log_time_ns,
                             m.publish_time_ns, data);
  };
  McapScanOptions options;
  options.tolerant = true;
  McapScanResult r;
  try {
    r = reader.Scan(v, options);
    writer.Close();
  } catch (...) {
    // A write error (a full disk): no partial output that could pass for a recovered file.
    std::remove(out_path.c_str());
    throw;
  }
  result.input_complete = r.complete;
  result.messages = r.messages;
  result.chunks_read = r.chunks;
  result.bad_chunks = r.bad_chunks;
  for (const auto& p : r.problems) result.problems.push_back(p);
  result.bytes_dropped = r.complete ? 0 : r.file_size - r.valid_data_end;
  result.input_readable = r.complete && result.repaired_messages == 0 && result.undecodable_messages == 0;
  if (result.repaired_messages > 0)
    result.problems.push_back(std::to_string(result.repaired_messages) +
                              " message(s) with invalid UTF-8 in string fields: repaired in the "
                              "output (invalid bytes written as U+FFFD)");
  for (const auto& [channel, n] : undecodable)
    result.problems.push_back("channel '" + text::Excerpt(topics[channel]) + "': " +
                              std::to_string(n) +
                              " message(s) do not parse as their schema: copied unchanged");
  return result;
}

}  // namespace hexa::recorder
