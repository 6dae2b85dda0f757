// Protobuf-aware layer over the MCAP format: writing protobuf messages with their
// FileDescriptorSet schemas, decoding any protobuf MCAP file with the schemas it embeds, and
// the file-level tools of `hexa_recorder` (info, diff, export, recover).
#pragma once

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor_database.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hexa/recording/mcap.hpp"

namespace hexa::recorder {

inline constexpr const char* kProtobufEncoding = "protobuf";
// Channel metadata keys written by the recorder (docs/recorder.md lists them all).
inline constexpr const char* kMetaType = "hexa.type";          // "hexa.rec.LegSensors"
inline constexpr const char* kMetaPeriodS = "hexa.period_s";   // "0.001"; "0" for event topics

// Serialized google.protobuf.FileDescriptorSet holding the file that defines `type` and every
// file it depends on, dependencies first (the MCAP "protobuf" schema encoding).
std::string FileDescriptorSetFor(const google::protobuf::Descriptor& type);

class RecordingWriter {
 public:
  explicit RecordingWriter(McapWriterConfig config = {}) : mcap_(std::move(config)) {}
  void Open(const std::string& path) { mcap_.Open(path); }
  // One schema per message type (shared by channels), one channel per call.
  uint16_t AddTopic(const std::string& topic, const google::protobuf::Descriptor& type,
                    std::map<std::string, std::string> metadata);
  void Write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns,
             const google::protobuf::Message& message);
  void Close() { mcap_.Close(); }
  McapWriter& mcap() { return mcap_; }

 private:
  McapWriter mcap_;
  std::map<std::string, uint16_t> schema_ids_;
  std::string buffer_;
};

// Parses protobuf bytes as `message`. Recordings written before the recorder sanitised its
// strings may hold string fields that are not valid UTF-8, which a proto3 parser rejects; such
// a message is repaired on read: the wire bytes are rewritten with every invalid byte of every
// string field (at any nesting depth) replaced by U+FFFD, and parsed again. Returns kRepaired
// then (the caller reports it), kFailed when the bytes do not parse even after the repair.
// `repaired_bytes`, when given, receives the rewritten wire bytes on kRepaired.
enum class ParseOutcome { kOk, kRepaired, kFailed };
ParseOutcome ParseRepairingUtf8(std::string_view data, google::protobuf::Message& message,
                                std::string* repaired_bytes = nullptr);

// Messages repaired on read, per channel (see ParseRepairingUtf8).
struct Utf8Repairs {
  uint64_t messages = 0;
  uint32_t first_sequence = 0;
};

// Decodes messages with the schemas embedded in the file (never the compiled-in types), so any
// protobuf MCAP file can be inspected and files written by older builds still decode.
// "" when the recording's message type `recorded` has the fields (numbers, names, types) of the
// same type compiled into this build, nested types included; else one line naming the fields
// only in this build, only in the recording, and changed. Types this build does not know: "".
std::string SchemaDifference(const google::protobuf::Descriptor& recorded);

class ProtoDecoder {
 public:
  ProtoDecoder();
  ~ProtoDecoder();
  // Throw McapError naming the schema/channel: encoding not "protobuf", FileDescriptorSet that
  // does not parse or build, message name absent from it, channel without a known schema, an
  // id defined again with different content (the MCAP spec requires repeats to be identical;
  // identical repeats are ignored).
  void AddSchema(const McapSchema& schema);
  void AddChannel(const McapChannel& channel);
  // The returned message is reused by the next Decode of the same channel. Throws McapError
  // when the bytes do not parse as the channel's type.
  // Strings that are not valid UTF-8 are repaired (ParseRepairingUtf8) and counted in repairs().
  const google::protobuf::Message& Decode(const McapMessageView& message);
  const google::protobuf::Descriptor* descriptor(uint16_t channel_id) const;
  // The channel's message type (a prototype to New() from); nullptr for an unknown channel.
  const google::protobuf::Message* Prototype(uint16_t channel_id) const;
  const std::map<uint16_t, Utf8Repairs>& repairs() const { return repairs_; }
  // "channel 'T': N message(s) with invalid UTF-8 in string fields (first: sequence S),
  // repaired on read (invalid bytes read as U+FFFD)", one line per channel.
  std::vector<std::string> RepairProblems() const;
  // One line per recorded schema whose fields differ from the same type compiled into this
  // build (SchemaDifference): the recording was made by another build.
  const std::vector<std::string>& schema_differences() const { return schema_differences_; }

 private:
  struct SchemaEntry {
    // Destroyed in reverse order: the pool before the database and the error collector it
    // points to. (DescriptorPool has no virtual destructor: the pieces are owned here, not by
    // a pool subclass - that leaked every schema's database, found by fuzz_mcap_reader.)
    std::unique_ptr<google::protobuf::DescriptorDatabase> database;
    std::unique_ptr<google::protobuf::DescriptorPool::ErrorCollector> errors;
    std::unique_ptr<google::protobuf::DescriptorPool> pool;
    const google::protobuf::Descriptor* type = nullptr;
    McapSchema record;  // to recognise a repeated Schema record (the same id again)
  };
  std::map<uint16_t, SchemaEntry> schemas_;
  std::map<uint16_t, std::unique_ptr<google::protobuf::Message>> channel_messages_;
  std::map<uint16_t, McapChannel> channel_records_;
  std::unique_ptr<google::protobuf::DynamicMessageFactory> factory_;
  std::vector<std::string> channel_topics_;
  std::map<uint16_t, Utf8Repairs> repairs_;
  std::vector<std::string> schema_differences_;
};

using DecodedMessageFn = std::function<void(const McapChannel&, const McapMessageView&,
                                            const google::protobuf::Message&)>;
struct RecordingCatalog {
  std::map<uint16_t, McapSchema> schemas;
  std::map<uint16_t, McapChannel> channels;
};
// Scans the file and calls `fn` for each message, decoded. Strict by default. `catalog`, when
// given, receives every schema and channel found. Messages repaired on read (invalid UTF-8)
// are not an error: each channel with repairs adds a line to the result's `problems` and
// `repaired_messages` counts them.
McapScanResult ReadRecording(const std::string& path, const DecodedMessageFn& fn,
                             const McapScanOptions& options = {},
                             RecordingCatalog* catalog = nullptr);

// Tick of a decoded message (header.tick, else tick, else sequence) and its instance key
// (leg_id, else node_name); nullopt / "" when the type has none.
std::optional<uint64_t> MessageTick(const google::protobuf::Message& message);
std::string MessageKey(const google::protobuf::Message& message);
// The key MessageKey gives a message with leg_id = leg ("leg N").
std::string LegStreamKey(uint32_t leg);
// The leg of such a key; 0 for any other key.
uint32_t LegOfKey(const std::string& key);

// Loss from tick numbers, per instance (topic + key). The expected tick step of a stream is its
// most frequent positive tick difference (1 for 1 kHz topics, 5 for 200 Hz ones); a difference
// of k steps means k - 1 samples missing.
struct StreamLoss {
  std::string key;
  uint64_t count = 0;
  uint64_t first_tick = 0, last_tick = 0;
  uint64_t step_ticks = 0;
  uint64_t expected = 0;       // (last - first) / step + 1
  uint64_t missing = 0;
  uint64_t gaps = 0;           // number of holes
  uint64_t max_gap_ticks = 0;  // largest tick difference seen
  uint64_t not_increasing = 0; // duplicates or reordered samples
  uint64_t filled_late = 0;    // ticks of a hole that arrived later (reordered): not missing
  // Against the other instances of the same topic (same step): ticks this stream starts
  // after the earliest first tick / ends before the latest last tick. Not counted as missing
  // (a leg that joined late or crashed sent nothing), but a recorder that matched a writer
  // late shows here, where the gaps between first and last tick cannot show it.
  uint64_t late_start_ticks = 0;
  uint64_t early_end_ticks = 0;
};

class TickLossTracker {
 public:
  void Add(const std::string& key, uint64_t tick) { AddAt(StreamIndex(key), tick); }
  // Fast path for a caller that sees the same keys over and over (the live recorder): look
  // the key up once, then add by index (no string, no map lookup per message).
  std::size_t StreamIndex(const std::string& key);
  void AddAt(std::size_t stream_index, uint64_t tick);
  std::vector<StreamLoss> Results() const;
  // The ticks each stream misses (the holes Results() counts, less the ones a late sample
  // filled), key -> ticks ascending. A stream past kMaxKept jumps or late samples is left out
  // (its holes are only counted).
  std::map<std::string, std::vector<uint64_t>> MissingTicks() const;

 private:
  struct Stream;
  static void CountHoles(const Stream& s, StreamLoss& l);
  static constexpr uint64_t kSmallDeltas = 16;  // tick differences counted in an array
  // Forward jumps and late samples kept per stream so that a late sample that fills a hole
  // (reordered delivery, e.g. an exclusive-ownership hand-over) is not counted as missing.
  // Past this many of either, the stream's holes are counted as the jumps left them.
  static constexpr std::size_t kMaxKept = 1u << 20;
  struct Stream {
    uint64_t count = 0, first = 0, last = 0, max_tick = 0, not_increasing = 0;
    std::array<uint64_t, kSmallDeltas + 1> small_deltas{};  // [d] = how often d, d <= 16
    std::map<uint64_t, uint64_t> large_deltas;              // d > 16 (gaps)
    std::vector<std::pair<uint64_t, uint64_t>> jumps;       // (from, to) of every delta > 1
    std::vector<uint64_t> late;                             // ticks below the newest seen
    bool overflow = false;                                  // jumps or late past kMaxKept
  };
  std::map<std::string, std::size_t> index_;  // key -> streams_ index (Results in key order)
  std::vector<Stream> streams_;
};

// Loss events: the missing samples of a recording grouped by the process that wrote them and their
// tick. A producer writes the samples of one tick together (the plant its six LegSensors,
// GroundTruth and ImuSample in one write batch, the supervisor its setpoints and pose report, each
// leg controller its ValveCommand), so one datagram lost on the way costs every sample it carried
// and counts as one event here: comparable with the packets a lossy link dropped, where the sample
// count is not (docs/measurements/deployment_recorder_link.md, "The lossy recorder link"). Samples
// of one producer and tick that travelled in two datagrams, both lost, count once.
struct LossEvents {
  std::map<std::string, uint64_t> events;   // producer -> (producer, tick) pairs with a loss
  std::map<std::string, uint64_t> samples;  // producer -> samples missing
  uint64_t total_events = 0, total_samples = 0;
};
// The process that writes `topic` ("hexa_LegSensors", ...) for stream `key` (TickLossTracker
// key: "leg N" or ""): "plant" (LegSensors, GroundTruth, ImuSample, TrackerPose),
// "supervisor" (LegSetpoint, PoseReport), "leg N" (ValveCommand of leg N; primary or standby:
// one owner per tick), else the topic name.
std::string ProducerOf(const std::string& topic, const std::string& key);
// Adds the missing ticks of one topic (TickLossTracker::MissingTicks) to the producers'
// events; call once per topic, then Finish().
class LossEventCounter {
 public:
  void AddTopic(const std::string& topic, const std::map<std::string, std::vector<uint64_t>>& missing);
  LossEvents Finish() const;

 private:
  std::map<std::string, std::vector<uint64_t>> ticks_;  // producer -> missing ticks (with repeats)
};

struct ChannelInfo {
  uint16_t id = 0;
  std::string topic;
  std::string schema_name;
  std::map<std::string, std::string> metadata;
  uint64_t count = 0;
  uint64_t first_log_ns = 0, last_log_ns = 0;
  double rate_hz = 0.0;          // per wall (log-time) second: (count - 1) / (last - first)
  // Per simulated second, from the messages' tick numbers (1 ms): (count - 1) / tick span.
  // 0 when the messages carry no tick or span none. In lockstep the simulated clock runs
  // slower or faster than the wall clock, and only this rate is the topic's own.
  bool has_ticks = false;
  uint64_t first_tick = 0, last_tick = 0;
  double sim_rate_hz = 0.0;
  uint64_t max_log_gap_ns = 0;   // largest log-time gap between consecutive messages
  bool loss_analysed = false;    // periodic topic with ticks
  std::vector<StreamLoss> streams;
  uint64_t missing = 0;          // sum over streams
};

struct RecordingInfo {
  std::string path;
  uint64_t file_size = 0;
  bool complete = false;
  std::vector<std::string> problems;
  uint64_t messages = 0, chunks = 0;
  std::map<std::string, uint64_t> chunk_compression;  // "none" / "zstd" -> chunks
  uint64_t chunk_records_bytes = 0, chunk_stored_bytes = 0;  // before / after compression
  uint64_t start_ns = 0, end_ns = 0;
  std::vector<ChannelInfo> channels;
  LossEvents loss_events;  // over the loss-analysed channels
};

RecordingInfo Inspect(const std::string& path, const McapScanOptions& options = {});
std::string FormatInfo(const RecordingInfo& info);

struct LegDiff {
  uint32_t leg_id = 0;
  uint64_t common_ticks = 0, only_a = 0, only_b = 0;
  double max_abs_diff_v = 0.0, rms_diff_v = 0.0;
  bool differs = false;
  uint64_t first_diff_tick = 0;  // valid when differs
};
struct DiffReport {
  std::vector<LegDiff> legs;
  bool identical = true;  // no tick beyond tolerance, no tick present in only one file
};
// Compares valve_v of the ValveCommand streams (schema hexa.rec.ValveCommand) per leg, matched
// by header.tick. |a - b| > tolerance_v counts as a difference.
DiffReport DiffValveCommands(const std::string& path_a, const std::string& path_b,
                             double tolerance_v);
std::string FormatDiff(const DiffReport& report);

// Topic filter: shell globs (fnmatch); an empty include list means every topic.
struct TopicFilter {
  std::vector<std::string> include;
  std::vector<std::string> exclude;
  bool Matches(const std::string& topic) const;
  bool NamesExplicitly(const std::string& topic) const;  // an include entry equal to it
};

struct ExportResult {
  std::vector<std::pair<std::string, uint64_t>> files;  // path, rows
  std::vector<std::string> warnings;                    // repaired on read (invalid UTF-8)
};
// One CSV per topic: log_time_ns, publish_time_ns, sequence, then every field flattened
// (nested as a.b, repeated by component or name[i]), each header cell "name [unit]"
// (csv_columns.hpp), and README.txt saying what each file holds. The Foxglove scene channels
// only when `include` names them. All or nothing: on an error (unreadable recording,
// write failure) no CSV is left behind; files appear under their names only on success.
ExportResult ExportCsv(const std::string& path, const std::string& out_dir,
                       const TopicFilter& filter);

struct RecoverResult {
  bool input_complete = false;   // structure: data end, summary and footer valid
  bool input_readable = false;   // complete and every message decodes as its schema unchanged
  uint64_t repaired_messages = 0;     // invalid UTF-8 in string fields, repaired in the output
  uint64_t undecodable_messages = 0;  // do not parse as their schema even after the repair
  uint64_t messages = 0;
  uint64_t chunks_read = 0;
  uint64_t bad_chunks = 0;
  uint64_t bytes_dropped = 0;    // after the last intact record
  std::vector<std::string> problems;
};
// Reads what is intact (tolerant scan) and rewrites it as a complete MCAP file with summary.
RecoverResult Recover(const std::string& in_path, const std::string& out_path,
                      const McapWriterConfig& config = {});

}  // namespace hexa::recorder
