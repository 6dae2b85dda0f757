// Minimal MCAP (https://mcap.dev/spec, major version 0) writer and reader, written for this
// project from the specification. Only what the recorder needs: Header, Schema, Channel,
// Message, Chunk (uncompressed or zstd, libzstd), MessageIndex, ChunkIndex, Statistics,
// SummaryOffset, DataEnd, Footer. The format layer knows nothing about protobuf or DDS.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace hexa::recorder {

// Every malformed-file or I/O problem is reported with this exception; the message names the
// file offset and what was expected (bad user input -> exception, docs/style.md rule 5).
class McapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class McapOpcode : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05,
  kChunk = 0x06, kMessageIndex = 0x07, kChunkIndex = 0x08, kAttachment = 0x09,
  kAttachmentIndex = 0x0A, kStatistics = 0x0B, kMetadata = 0x0C, kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E, kDataEnd = 0x0F
};
const char* McapOpcodeName(uint8_t opcode);

inline constexpr unsigned char kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

uint32_t Crc32(const void* data, size_t size, uint32_t crc = 0);

struct McapSchema {
  uint16_t id = 0;
  std::string name;
  std::string encoding;
  std::string data;
};

struct McapChannel {
  uint16_t id = 0;
  uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;
  std::map<std::string, std::string> metadata;
};

struct McapMessageView {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time_ns = 0;
  uint64_t publish_time_ns = 0;
  std::string_view data;  // valid only during the callback
};

enum class McapSyncMode { kNone, kFflush, kFdatasync };

// Chunk compression (the spec's per-chunk `compression` string: "" or "zstd"; "lz4" is read
// by neither side here).
enum class McapCompression { kNone, kZstd };
// The chunk's compression string: "" for kNone, "zstd".
const char* McapCompressionName(McapCompression c);
// "none" | "zstd" (the CLI's --compression values); throws std::invalid_argument otherwise.
McapCompression ParseMcapCompression(const std::string& text);

struct McapWriterConfig {
  std::string profile;                       // "" = no well-known profile
  std::string library = "hexa_recorder";
  uint64_t chunk_max_bytes = 1u << 20;       // close a chunk when its records reach this size
  uint64_t chunk_max_messages = 100000;      // ... or hold this many messages
  uint64_t chunk_max_span_ns = 100'000'000;  // ... or span this much log time (crash window)
  // After each chunk is written: kFflush hands the bytes to the kernel (enough to survive a
  // kill -9 of the recorder); kFdatasync does that and then fdatasync()s on a background
  // thread, so that a slow disk never stalls the caller (the recorder's DDS loop). A failed
  // background fdatasync is reported by the next FlushChunk() or Close().
  McapSyncMode sync = McapSyncMode::kFdatasync;
  bool compute_data_crc = true;
  // zstd: a recording shrinks ~5x (docs/measurements/recorder.md, "Compression benchmark").
  McapCompression compression = McapCompression::kZstd;
  int zstd_level = 3;                         // 1..19 (zstd's own scale; 3 is its default)
  void Validate() const;  // throws std::invalid_argument naming the field
};

struct McapWriterStats {
  uint64_t messages = 0;
  uint64_t chunks = 0;
  uint64_t bytes = 0;
  uint64_t syncs = 0;  // flushes to the kernel (each followed by a background fdatasync)
  uint64_t chunk_records_bytes = 0;  // chunk records before compression
  uint64_t chunk_stored_bytes = 0;   // the same as written (compressed or not)
};

class ZstdCodec;  // compression.hpp

class BackgroundSync;  // mcap.cpp

// Writes messages into uncompressed chunks. Schema and Channel records go to the data section
// as soon as they are added, so that a file cut after any flushed chunk is readable (crash
// safety). Not thread-safe.
class McapWriter {
 public:
  explicit McapWriter(McapWriterConfig config = {});
  ~McapWriter();  // Close()s an open file; errors are swallowed (call Close() to see them)
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  void Open(const std::string& path);
  uint16_t AddSchema(std::string name, std::string encoding, std::string data);
  uint16_t AddChannel(uint16_t schema_id, std::string topic, std::string message_encoding,
                      std::map<std::string, std::string> metadata);
  // Sequence numbers count per channel from 0.
  void Write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns,
             std::string_view data);
  void WriteWithSequence(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns,
                         uint64_t publish_time_ns, std::string_view data);
  // Closes the open chunk (if any), writes it and its message indexes, and syncs.
  void FlushChunk();
  // Closes the open chunk if its oldest message was logged chunk_max_span_ns before now.
  void FlushIfDue(uint64_t now_log_time_ns);
  void Close();
  // Closes the open file (complete, with its summary) and continues in a new one at `path`:
  // the schemas and channels are written there again with the same ids, sequence numbers go
  // on. For recordings split by size or time; each file is a complete MCAP file of its own.
  void Rotate(const std::string& path);
  // Bytes written to the open file so far.
  uint64_t file_bytes() const { return offset_; }
  bool is_open() const { return file_ != nullptr; }
  const McapWriterStats& stats() const { return stats_; }
  const std::string& path() const { return path_; }

 private:
  struct ChunkIndexEntry {
    uint64_t start_ns, end_ns, chunk_offset, chunk_length;
    std::vector<std::pair<uint16_t, uint64_t>> index_offsets;
    uint64_t index_length, records_size, stored_size;
  };
  void WriteBytes(const void* data, size_t size);
  void WriteRecord(McapOpcode op, const std::string& body);
  void Sync();

  McapWriterConfig config_;
  std::string path_;
  FILE* file_ = nullptr;
  uint64_t offset_ = 0;
  uint32_t data_crc_ = 0;
  bool in_data_section_ = true;
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::vector<uint32_t> next_sequence_;
  std::vector<uint64_t> channel_counts_;
  // Open chunk.
  std::string chunk_records_;
  uint64_t chunk_messages_ = 0, chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> chunk_index_;  // per channel
  std::vector<ChunkIndexEntry> chunk_indexes_;
  uint64_t message_start_ns_ = 0, message_end_ns_ = 0;
  uint64_t file_messages_ = 0;  // in the open file (stats_.messages: in every file)
  std::string scratch_;
  std::string compressed_;
  std::unique_ptr<ZstdCodec> zstd_;
  McapWriterStats stats_;
  std::unique_ptr<BackgroundSync> syncer_;  // kFdatasync only, while a file is open
};

struct McapStatistics {
  uint64_t message_count = 0;
  uint16_t schema_count = 0;
  uint32_t channel_count = 0;
  uint32_t chunk_count = 0;
  uint64_t message_start_ns = 0;
  uint64_t message_end_ns = 0;
  std::map<uint16_t, uint64_t> channel_message_counts;
};

struct McapScanOptions {
  // false: any defect (truncation, garbage, bad CRC, missing footer) throws McapError.
  // true: read everything up to the first defect, skip chunks with bad CRC, report in result.
  bool tolerant = false;
  bool verify_crcs = true;
  // Called after each record of the data section (a chunk, or a message outside chunks) with
  // the bytes read so far and the file size: progress for a long read.
  std::function<void(uint64_t bytes_read, uint64_t file_size)> progress;
};

struct McapScanResult {
  bool complete = false;          // DataEnd, summary, footer and closing magic all valid
  bool has_summary = false;
  std::vector<std::string> problems;  // tolerant mode: what was skipped or missing
  uint64_t file_size = 0;
  uint64_t valid_data_end = 0;    // offset after the last intact data-section record
  uint64_t messages = 0;
  uint64_t chunks = 0;
  uint64_t bad_chunks = 0;
  std::map<std::string, uint64_t> chunk_compression;  // "none" / "zstd" -> chunks read
  uint64_t chunk_records_bytes = 0;  // records of the chunks read, uncompressed
  uint64_t chunk_stored_bytes = 0;   // the same as stored in the file
  uint64_t repaired_messages = 0;  // set by ReadRecording (recording.hpp): invalid UTF-8 repaired
  McapStatistics summary_statistics;  // valid when has_summary
};

struct McapVisitor {
  std::function<void(const McapSchema&)> on_schema;
  std::function<void(const McapChannel&)> on_channel;
  std::function<void(const McapMessageView&)> on_message;
};

// Linear reader: walks the data section record by record (never trusting a length before
// checking it against the file size), then validates the summary and footer.
class McapScanner;  // one Scan's state (mcap_reader.cpp)

class McapReader {
 public:
  McapReader();
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  // Opens and checks the leading magic; throws McapError (empty file, not MCAP, ...).
  void Open(const std::string& path);
  McapScanResult Scan(const McapVisitor& visitor, const McapScanOptions& options = {});
  const std::map<uint16_t, McapSchema>& schemas() const { return schemas_; }
  const std::map<uint16_t, McapChannel>& channels() const { return channels_; }
  const std::string& path() const { return path_; }

 private:
  friend class McapScanner;
  void ReadAt(uint64_t offset, void* out, size_t size);

  std::string path_;
  int fd_ = -1;
  uint64_t file_size_ = 0;
  std::unique_ptr<ZstdCodec> zstd_;
  std::string chunk_buffer_;  // decompressed records of the chunk being delivered
  std::map<uint16_t, McapSchema> schemas_;
  std::map<uint16_t, McapChannel> channels_;
};

}  // namespace hexa::recorder
