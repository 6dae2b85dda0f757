// Writing a recording (protobuf messages with their FileDescriptorSet schemas) and decoding
// one with the schemas stored in the file.

#include "hexa/recording/recording.hpp"

#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/descriptor_database.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <set>

#include "hexa/services/text.hpp"

namespace hexa::recorder {
namespace gp = google::protobuf;

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

}  // namespace hexa::recorder
