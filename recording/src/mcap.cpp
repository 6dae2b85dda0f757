// MCAP writer (and the CRC and record names the reader shares), implemented from the
// specification (mcap.dev/spec): little-endian integers, strings and byte arrays prefixed by a
// uint32 length, maps and arrays prefixed by their uint32 byte length, every record = opcode
// (1 byte) + uint64 content length + content. The reader is mcap_reader.cpp.
#include "hexa/recording/mcap.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <sstream>
#include <thread>

#include "compression.hpp"

namespace hexa::recorder {
namespace {

// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), the one the MCAP spec names.
// Slicing-by-8 tables: the writer checksums every byte twice (chunk CRC + data-section CRC).
struct CrcTables {
  std::array<std::array<uint32_t, 256>, 8> t{};
  constexpr CrcTables() {
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
      t[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i)
      for (int s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
  }
};
constexpr CrcTables kCrc{};

// --- little-endian encoding ---------------------------------------------------------------
void PutU8(std::string& s, uint8_t v) { s.push_back(static_cast<char>(v)); }
void PutU16(std::string& s, uint16_t v) { s.append(reinterpret_cast<const char*>(&v), 2); }
void PutU32(std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }
void PutU64(std::string& s, uint64_t v) { s.append(reinterpret_cast<const char*>(&v), 8); }
void PutStr(std::string& s, std::string_view v) {
  PutU32(s, static_cast<uint32_t>(v.size()));
  s.append(v);
}
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP is little-endian; so is this host");

}  // namespace

uint32_t Crc32(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  while (size >= 8) {
    uint32_t lo, hi;
    std::memcpy(&lo, p, 4);
    std::memcpy(&hi, p + 4, 4);
    lo ^= crc;
    crc = kCrc.t[7][lo & 0xFF] ^ kCrc.t[6][(lo >> 8) & 0xFF] ^ kCrc.t[5][(lo >> 16) & 0xFF] ^
          kCrc.t[4][lo >> 24] ^ kCrc.t[3][hi & 0xFF] ^ kCrc.t[2][(hi >> 8) & 0xFF] ^
          kCrc.t[1][(hi >> 16) & 0xFF] ^ kCrc.t[0][hi >> 24];
    p += 8;
    size -= 8;
  }
  while (size--) crc = kCrc.t[0][(crc ^ *p++) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

const char* McapOpcodeName(uint8_t opcode) {
  switch (opcode) {
    case 0x01: return "Header";
    case 0x02: return "Footer";
    case 0x03: return "Schema";
    case 0x04: return "Channel";
    case 0x05: return "Message";
    case 0x06: return "Chunk";
    case 0x07: return "MessageIndex";
    case 0x08: return "ChunkIndex";
    case 0x09: return "Attachment";
    case 0x0A: return "AttachmentIndex";
    case 0x0B: return "Statistics";
    case 0x0C: return "Metadata";
    case 0x0D: return "MetadataIndex";
    case 0x0E: return "SummaryOffset";
    case 0x0F: return "DataEnd";
    default: return "unknown";
  }
}

// ===================================== writer =============================================

const char* McapCompressionName(McapCompression c) {
  return c == McapCompression::kZstd ? "zstd" : "";
}

McapCompression ParseMcapCompression(const std::string& text) {
  if (text == "none") return McapCompression::kNone;
  if (text == "zstd") return McapCompression::kZstd;
  throw std::invalid_argument("compression must be none or zstd, got '" + text + "'");
}

void McapWriterConfig::Validate() const {
  if (compression == McapCompression::kZstd && (zstd_level < 1 || zstd_level > 19))
    throw std::invalid_argument("McapWriterConfig.zstd_level = " + std::to_string(zstd_level) +
                                " outside [1, 19]");
  if (chunk_max_bytes < 64 || chunk_max_bytes > (1ull << 32))
    throw std::invalid_argument("McapWriterConfig.chunk_max_bytes = " +
                                std::to_string(chunk_max_bytes) + " outside [64, 2^32]");
  if (chunk_max_messages == 0)
    throw std::invalid_argument("McapWriterConfig.chunk_max_messages must be > 0");
  if (chunk_max_span_ns == 0)
    throw std::invalid_argument("McapWriterConfig.chunk_max_span_ns must be > 0");
}

// Schema and Channel record bodies: written once into the data section when added and again
// into the summary section by Close().
std::string SchemaBody(const McapSchema& s) {
  std::string body;
  PutU16(body, s.id);
  PutStr(body, s.name);
  PutStr(body, s.encoding);
  PutStr(body, s.data);
  return body;
}

std::string ChannelBody(const McapChannel& ch) {
  std::string body, map;
  PutU16(body, ch.id);
  PutU16(body, ch.schema_id);
  PutStr(body, ch.topic);
  PutStr(body, ch.message_encoding);
  for (const auto& [k, v] : ch.metadata) {
    PutStr(map, k);
    PutStr(map, v);
  }
  PutStr(body, map);
  return body;
}

// fdatasync() of one file descriptor on its own thread: Request() returns at once; requests
// made while a sync runs are coalesced into one more sync (which covers everything written
// before it started). Finish() waits for the last requested sync and stops the thread.
class BackgroundSync {
 public:
  explicit BackgroundSync(int fd) : fd_(fd), thread_([this] { Run(); }) {}
  ~BackgroundSync() { Finish(); }
  void Request() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pending_ = true;
    }
    cv_.notify_one();
  }
  // Waits until every requested sync is done, stops the thread. Returns the errno of the
  // first failed fdatasync, 0 if none failed.
  int Finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_one();
    if (thread_.joinable()) thread_.join();
    return error_;
  }
  int error() {
    std::lock_guard<std::mutex> lock(mutex_);
    return error_;
  }

 private:
  void Run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return pending_ || stop_; });
      if (pending_) {
        pending_ = false;
        lock.unlock();
        const int rc = ::fdatasync(fd_);
        const int err = rc == 0 ? 0 : errno;
        lock.lock();
        if (err != 0 && error_ == 0) error_ = err;
        continue;  // a request made meanwhile is served before stopping
      }
      if (stop_) return;
    }
  }
  const int fd_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool pending_ = false;
  bool stop_ = false;
  int error_ = 0;
  std::thread thread_;  // last: starts after the members it uses
};

McapWriter::McapWriter(McapWriterConfig config) : config_(std::move(config)) {
  config_.Validate();
  if (config_.compression == McapCompression::kZstd) zstd_ = std::make_unique<ZstdCodec>();
}

McapWriter::~McapWriter() {
  if (file_ != nullptr) {
    try {
      Close();
    } catch (...) {
      // Destructors must not throw; Close() explicitly to observe errors.
    }
  }
}

void McapWriter::WriteBytes(const void* data, size_t size) {
  if (std::fwrite(data, 1, size, file_) != size)
    throw McapError("write to '" + path_ + "' failed: " + std::strerror(errno));
  if (in_data_section_ && config_.compute_data_crc) data_crc_ = Crc32(data, size, data_crc_);
  offset_ += size;
  stats_.bytes += size;
}

void McapWriter::WriteRecord(McapOpcode op, const std::string& body) {
  char head[9];
  head[0] = static_cast<char>(op);
  const uint64_t len = body.size();
  std::memcpy(head + 1, &len, 8);
  WriteBytes(head, 9);
  WriteBytes(body.data(), body.size());
}

void McapWriter::Open(const std::string& path) {
  if (file_ != nullptr) throw McapError("McapWriter::Open: '" + path_ + "' is still open");
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr)
    throw McapError("cannot create '" + path + "': " + std::strerror(errno));
  path_ = path;
  std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
  if (config_.sync == McapSyncMode::kFdatasync)
    syncer_ = std::make_unique<BackgroundSync>(fileno(file_));
  offset_ = 0;
  data_crc_ = 0;
  in_data_section_ = true;
  file_messages_ = 0;
  chunk_indexes_.clear();
  std::fill(channel_counts_.begin(), channel_counts_.end(), 0);
  WriteBytes(kMcapMagic, sizeof kMcapMagic);
  std::string body;
  PutStr(body, config_.profile);
  PutStr(body, config_.library);
  WriteRecord(McapOpcode::kHeader, body);
}

void McapWriter::Rotate(const std::string& path) {
  if (file_ == nullptr) throw McapError("McapWriter::Rotate: no open file");
  Close();
  Open(path);
  // The same ids as before: the caller's channel ids stay valid, and each file reads alone.
  for (const auto& s : schemas_) WriteRecord(McapOpcode::kSchema, SchemaBody(s));
  for (const auto& ch : channels_) WriteRecord(McapOpcode::kChannel, ChannelBody(ch));
}

uint16_t McapWriter::AddSchema(std::string name, std::string encoding, std::string data) {
  if (file_ == nullptr) throw McapError("McapWriter::AddSchema: no open file");
  if (schemas_.size() >= 65534) throw McapError("too many schemas");
  McapSchema s{static_cast<uint16_t>(schemas_.size() + 1), std::move(name), std::move(encoding),
               std::move(data)};
  WriteRecord(McapOpcode::kSchema, SchemaBody(s));
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

uint16_t McapWriter::AddChannel(uint16_t schema_id, std::string topic,
                                std::string message_encoding,
                                std::map<std::string, std::string> metadata) {
  if (file_ == nullptr) throw McapError("McapWriter::AddChannel: no open file");
  if (schema_id > schemas_.size())
    throw McapError("AddChannel('" + topic + "'): unknown schema id " + std::to_string(schema_id));
  if (channels_.size() >= 65535) throw McapError("too many channels");
  McapChannel ch{static_cast<uint16_t>(channels_.size()), schema_id, std::move(topic),
                 std::move(message_encoding), std::move(metadata)};
  WriteRecord(McapOpcode::kChannel, ChannelBody(ch));
  channels_.push_back(std::move(ch));
  next_sequence_.push_back(0);
  channel_counts_.push_back(0);
  chunk_index_.emplace_back();
  return channels_.back().id;
}

void McapWriter::Write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns,
                       std::string_view data) {
  if (channel_id >= channels_.size())
    throw McapError("McapWriter::Write: unknown channel id " + std::to_string(channel_id));
  WriteWithSequence(channel_id, next_sequence_[channel_id]++, log_time_ns, publish_time_ns, data);
}

void McapWriter::WriteWithSequence(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns,
                                   uint64_t publish_time_ns, std::string_view data) {
  if (file_ == nullptr) throw McapError("McapWriter::Write: no open file");
  if (channel_id >= channels_.size())
    throw McapError("McapWriter::Write: unknown channel id " + std::to_string(channel_id));
  const uint64_t record_offset = chunk_records_.size();
  const uint64_t len = 2 + 4 + 8 + 8 + data.size();
  PutU8(chunk_records_, static_cast<uint8_t>(McapOpcode::kMessage));
  PutU64(chunk_records_, len);
  PutU16(chunk_records_, channel_id);
  PutU32(chunk_records_, sequence);
  PutU64(chunk_records_, log_time_ns);
  PutU64(chunk_records_, publish_time_ns);
  chunk_records_.append(data);
  chunk_index_[channel_id].emplace_back(log_time_ns, record_offset);
  if (chunk_messages_ == 0) {
    chunk_start_ns_ = chunk_end_ns_ = log_time_ns;
  } else {
    chunk_start_ns_ = std::min(chunk_start_ns_, log_time_ns);
    chunk_end_ns_ = std::max(chunk_end_ns_, log_time_ns);
  }
  if (file_messages_ == 0) {
    message_start_ns_ = message_end_ns_ = log_time_ns;
  } else {
    message_start_ns_ = std::min(message_start_ns_, log_time_ns);
    message_end_ns_ = std::max(message_end_ns_, log_time_ns);
  }
  ++chunk_messages_;
  ++stats_.messages;
  ++file_messages_;
  ++channel_counts_[channel_id];
  next_sequence_[channel_id] = sequence + 1;
  if (chunk_records_.size() >= config_.chunk_max_bytes ||
      chunk_messages_ >= config_.chunk_max_messages ||
      chunk_end_ns_ - chunk_start_ns_ >= config_.chunk_max_span_ns) {
    FlushChunk();
  }
}

void McapWriter::FlushIfDue(uint64_t now_log_time_ns) {
  if (chunk_messages_ > 0 && now_log_time_ns >= chunk_start_ns_ &&
      now_log_time_ns - chunk_start_ns_ >= config_.chunk_max_span_ns) {
    FlushChunk();
  }
}

void McapWriter::Sync() {
  if (config_.sync == McapSyncMode::kNone) return;
  if (std::fflush(file_) != 0)
    throw McapError("flush of '" + path_ + "' failed: " + std::strerror(errno));
  if (syncer_ != nullptr) {
    if (const int err = syncer_->error(); err != 0)
      throw McapError("fdatasync of '" + path_ + "' failed: " + std::strerror(err));
    syncer_->Request();
  }
  ++stats_.syncs;
}

void McapWriter::FlushChunk() {
  if (file_ == nullptr) return;
  if (chunk_messages_ == 0) {
    Sync();  // schemas/channels written since the last chunk reach the disk too
    return;
  }
  ChunkIndexEntry idx{};
  idx.start_ns = chunk_start_ns_;
  idx.end_ns = chunk_end_ns_;
  idx.chunk_offset = offset_;
  idx.records_size = chunk_records_.size();
  // The chunk's records as stored: zstd-compressed (one frame) or as they are. The CRC is of
  // the uncompressed records (spec: uncompressed_crc).
  std::string_view stored = chunk_records_;
  if (zstd_ != nullptr) {
    zstd_->Compress(chunk_records_, config_.zstd_level, compressed_);
    stored = compressed_;
  }
  idx.stored_size = stored.size();
  std::string& head = scratch_;
  head.clear();
  PutU64(head, chunk_start_ns_);
  PutU64(head, chunk_end_ns_);
  PutU64(head, chunk_records_.size());  // uncompressed_size
  PutU32(head, Crc32(chunk_records_.data(), chunk_records_.size()));
  PutStr(head, McapCompressionName(config_.compression));
  PutU64(head, stored.size());  // records byte length
  char rec_head[9];
  rec_head[0] = static_cast<char>(McapOpcode::kChunk);
  const uint64_t len = head.size() + stored.size();
  std::memcpy(rec_head + 1, &len, 8);
  WriteBytes(rec_head, 9);
  WriteBytes(head.data(), head.size());
  WriteBytes(stored.data(), stored.size());
  stats_.chunk_records_bytes += chunk_records_.size();
  stats_.chunk_stored_bytes += stored.size();
  idx.chunk_length = offset_ - idx.chunk_offset;

  const uint64_t index_start = offset_;
  for (size_t ch = 0; ch < chunk_index_.size(); ++ch) {
    auto& entries = chunk_index_[ch];
    if (entries.empty()) continue;
    // Readers expect index entries in log-time order; arrival order may differ slightly.
    std::stable_sort(entries.begin(), entries.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::string body;
    body.reserve(6 + entries.size() * 16);
    PutU16(body, static_cast<uint16_t>(ch));
    PutU32(body, static_cast<uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      PutU64(body, t);
      PutU64(body, off);
    }
    idx.index_offsets.emplace_back(static_cast<uint16_t>(ch), offset_);
    WriteRecord(McapOpcode::kMessageIndex, body);
    entries.clear();
  }
  idx.index_length = offset_ - index_start;
  chunk_indexes_.push_back(std::move(idx));
  chunk_records_.clear();
  chunk_messages_ = 0;
  ++stats_.chunks;
  Sync();
}

void McapWriter::Close() {
  if (file_ == nullptr) return;
  FlushChunk();
  // DataEnd carries the CRC of everything before it (0 = not computed).
  std::string body;
  PutU32(body, config_.compute_data_crc ? data_crc_ : 0);
  WriteRecord(McapOpcode::kDataEnd, body);
  in_data_section_ = false;

  const uint64_t summary_start = offset_;
  uint32_t summary_crc = 0;
  auto summary_record = [&](McapOpcode op, const std::string& b) {
    char head[9];
    head[0] = static_cast<char>(op);
    const uint64_t len = b.size();
    std::memcpy(head + 1, &len, 8);
    summary_crc = Crc32(head, 9, summary_crc);
    summary_crc = Crc32(b.data(), b.size(), summary_crc);
    WriteRecord(op, b);
  };
  struct Group { McapOpcode op; uint64_t start, length; };
  std::vector<Group> groups;
  auto group = [&](McapOpcode op, const std::function<void()>& emit) {
    const uint64_t start = offset_;
    emit();
    if (offset_ > start) groups.push_back({op, start, offset_ - start});
  };
  group(McapOpcode::kSchema, [&] {
    for (const auto& s : schemas_) summary_record(McapOpcode::kSchema, SchemaBody(s));
  });
  group(McapOpcode::kChannel, [&] {
    for (const auto& ch : channels_) summary_record(McapOpcode::kChannel, ChannelBody(ch));
  });
  group(McapOpcode::kStatistics, [&] {
    std::string b, map;
    PutU64(b, file_messages_);
    PutU16(b, static_cast<uint16_t>(schemas_.size()));
    PutU32(b, static_cast<uint32_t>(channels_.size()));
    PutU32(b, 0);  // attachments
    PutU32(b, 0);  // metadata
    PutU32(b, static_cast<uint32_t>(chunk_indexes_.size()));
    PutU64(b, file_messages_ ? message_start_ns_ : 0);
    PutU64(b, file_messages_ ? message_end_ns_ : 0);
    for (size_t ch = 0; ch < channel_counts_.size(); ++ch) {
      PutU16(map, static_cast<uint16_t>(ch));
      PutU64(map, channel_counts_[ch]);
    }
    PutStr(b, map);
    summary_record(McapOpcode::kStatistics, b);
  });
  group(McapOpcode::kChunkIndex, [&] {
    for (const auto& ci : chunk_indexes_) {
      std::string b, map;
      PutU64(b, ci.start_ns);
      PutU64(b, ci.end_ns);
      PutU64(b, ci.chunk_offset);
      PutU64(b, ci.chunk_length);
      for (const auto& [ch, off] : ci.index_offsets) {
        PutU16(map, ch);
        PutU64(map, off);
      }
      PutStr(b, map);
      PutU64(b, ci.index_length);
      PutStr(b, McapCompressionName(config_.compression));
      PutU64(b, ci.stored_size);   // compressed_size (= uncompressed_size when not compressed)
      PutU64(b, ci.records_size);  // uncompressed_size
      summary_record(McapOpcode::kChunkIndex, b);
    }
  });
  const uint64_t summary_offset_start = offset_;
  for (const auto& g : groups) {
    std::string b;
    PutU8(b, static_cast<uint8_t>(g.op));
    PutU64(b, g.start);
    PutU64(b, g.length);
    summary_record(McapOpcode::kSummaryOffset, b);
  }
  // Footer: the summary CRC covers the summary sections plus the footer up to and including
  // summary_offset_start.
  std::string footer;
  PutU8(footer, static_cast<uint8_t>(McapOpcode::kFooter));
  PutU64(footer, 20);
  PutU64(footer, summary_start);
  PutU64(footer, summary_offset_start);
  summary_crc = Crc32(footer.data(), footer.size(), summary_crc);
  PutU32(footer, summary_crc);
  WriteBytes(footer.data(), footer.size());
  WriteBytes(kMcapMagic, sizeof kMcapMagic);

  const bool flushed = std::fflush(file_) == 0;
  int err = flushed ? 0 : errno;
  if (syncer_ != nullptr) {
    const int background = syncer_->Finish();
    syncer_.reset();
    if (err == 0) err = background;
    if (err == 0 && ::fdatasync(fileno(file_)) != 0) err = errno;
  }
  if (std::fclose(file_) != 0 && err == 0) err = errno;
  file_ = nullptr;
  if (err != 0) throw McapError("closing '" + path_ + "' failed: " + std::strerror(err));
}

}  // namespace hexa::recorder
