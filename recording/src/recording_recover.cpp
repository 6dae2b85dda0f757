// hexa_recorder recover: the intact chunks of a damaged or truncated recording rewritten as a
// complete MCAP file.

#include "hexa/recording/recording.hpp"

#include <algorithm>
#include <cstdio>
#include <set>

#include "hexa/services/text.hpp"

namespace hexa::recorder {
namespace gp = google::protobuf;

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
