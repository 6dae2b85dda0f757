// MCAP writer and reader, implemented from the specification (mcap.dev/spec): little-endian
// integers, strings and byte arrays prefixed by a uint32 length, maps and arrays prefixed by
// their uint32 byte length, every record = opcode (1 byte) + uint64 content length + content.
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

std::string Hex(uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%llx", static_cast<unsigned long long>(v));
  return buf;
}

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

// Bounds-checked decoder over one record's content. Every read checks the remaining size and
// throws McapError naming the record and the field.
class Cursor {
 public:
  Cursor(std::string_view data, std::string what) : d_(data), what_(std::move(what)) {}
  uint8_t U8(const char* f) { return Fixed<uint8_t>(f); }
  uint16_t U16(const char* f) { return Fixed<uint16_t>(f); }
  uint32_t U32(const char* f) { return Fixed<uint32_t>(f); }
  uint64_t U64(const char* f) { return Fixed<uint64_t>(f); }
  std::string_view Bytes(size_t n, const char* f) {
    if (n > d_.size() - pos_) Fail(f, n);
    std::string_view v = d_.substr(pos_, n);
    pos_ += n;
    return v;
  }
  std::string Str(const char* f) { return std::string(Bytes(U32(f), f)); }
  std::string_view Rest() { return Bytes(d_.size() - pos_, "rest"); }
  size_t remaining() const { return d_.size() - pos_; }
  size_t pos() const { return pos_; }

 private:
  template <typename T>
  T Fixed(const char* f) {
    if (sizeof(T) > d_.size() - pos_) Fail(f, sizeof(T));
    T v;
    std::memcpy(&v, d_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  [[noreturn]] void Fail(const char* field, size_t need) {
    throw McapError(what_ + ": field '" + field + "' needs " + std::to_string(need) +
                    " bytes but only " + std::to_string(d_.size() - pos_) + " remain");
  }
  std::string_view d_;
  size_t pos_ = 0;
  std::string what_;
};

McapSchema ParseSchema(std::string_view body, const std::string& what) {
  Cursor c(body, what);
  McapSchema s;
  s.id = c.U16("id");
  s.name = c.Str("name");
  s.encoding = c.Str("encoding");
  s.data = std::string(c.Bytes(c.U32("data length"), "data"));
  if (s.id == 0) throw McapError(what + ": schema id 0 is reserved");
  return s;
}

McapChannel ParseChannel(std::string_view body, const std::string& what) {
  Cursor c(body, what);
  McapChannel ch;
  ch.id = c.U16("id");
  ch.schema_id = c.U16("schema_id");
  ch.topic = c.Str("topic");
  ch.message_encoding = c.Str("message_encoding");
  Cursor m(c.Bytes(c.U32("metadata length"), "metadata"), what + " metadata");
  while (m.remaining() > 0) {
    std::string k = m.Str("key");
    ch.metadata[k] = m.Str("value");
  }
  return ch;
}

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

// ===================================== reader =============================================

McapReader::McapReader() = default;

McapReader::~McapReader() {
  if (fd_ >= 0) ::close(fd_);
}

void McapReader::ReadAt(uint64_t offset, void* out, size_t size) {
  auto* p = static_cast<char*>(out);
  while (size > 0) {
    const ssize_t n = ::pread(fd_, p, size, static_cast<off_t>(offset));
    if (n < 0) {
      if (errno == EINTR) continue;
      throw McapError("'" + path_ + "': read at offset " + std::to_string(offset) +
                      " failed: " + std::strerror(errno));
    }
    if (n == 0)
      throw McapError("'" + path_ + "': unexpected end of file at offset " +
                      std::to_string(offset));
    p += n;
    size -= static_cast<size_t>(n);
    offset += static_cast<uint64_t>(n);
  }
}

void McapReader::Open(const std::string& path) {
  path_ = path;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw McapError("cannot open '" + path + "': " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode))
    throw McapError("'" + path + "' is not a regular file");
  file_size_ = static_cast<uint64_t>(st.st_size);
  if (file_size_ == 0) throw McapError("'" + path + "' is empty (0 bytes): not an MCAP file");
  unsigned char magic[8] = {};
  const size_t n = static_cast<size_t>(std::min<uint64_t>(8, file_size_));
  ReadAt(0, magic, n);
  std::ostringstream seen;
  for (size_t i = 0; i < n; ++i) {
    char b[4];
    std::snprintf(b, sizeof b, "%02x ", magic[i]);
    seen << b;
  }
  if (n >= 5 && std::memcmp(magic, kMcapMagic, 5) == 0 && (n < 6 || magic[5] != '0'))
    throw McapError("'" + path + "': unsupported MCAP major version byte " +
                    (n >= 6 ? Hex(magic[5]) : std::string("(missing)")) +
                    " (this reader handles version '0')");
  if (n < 8 || std::memcmp(magic, kMcapMagic, 8) != 0)
    throw McapError("'" + path + "' is not an MCAP file: it starts with bytes " + seen.str() +
                    "(expected 89 4d 43 41 50 30 0d 0a)");
}

McapScanResult McapReader::Scan(const McapVisitor& visitor, const McapScanOptions& options) {
  if (fd_ < 0) throw McapError("McapReader::Scan: no open file");
  schemas_.clear();
  channels_.clear();
  McapScanResult result;
  result.file_size = file_size_;
  const std::string where = "'" + path_ + "'";
  // A defect: strict mode throws, tolerant mode records it and the scan stops or skips.
  auto defect = [&](const std::string& what) {
    if (!options.tolerant) throw McapError(where + ": " + what);
    result.problems.push_back(what);
  };

  uint64_t pos = 8;
  uint32_t data_crc = Crc32(kMcapMagic, 8);
  std::string body;
  std::map<uint16_t, uint64_t> channel_counts;
  std::vector<uint64_t> chunk_offsets;
  uint64_t min_log = 0, max_log = 0;
  bool seen_header = false;

  auto deliver_schema = [&](McapSchema s) {
    if (visitor.on_schema) visitor.on_schema(s);
    schemas_[s.id] = std::move(s);
  };
  auto deliver_channel = [&](McapChannel ch, const std::string& what) {
    if (ch.schema_id != 0 && schemas_.count(ch.schema_id) == 0)
      throw McapError(what + ": channel " + std::to_string(ch.id) + " '" + ch.topic +
                      "' refers to schema id " + std::to_string(ch.schema_id) +
                      " which no Schema record defines (unknown schema)");
    if (visitor.on_channel) visitor.on_channel(ch);
    channels_[ch.id] = std::move(ch);
  };
  auto deliver_message = [&](std::string_view rec, const std::string& what) {
    Cursor c(rec, what);
    McapMessageView m;
    m.channel_id = c.U16("channel_id");
    m.sequence = c.U32("sequence");
    m.log_time_ns = c.U64("log_time");
    m.publish_time_ns = c.U64("publish_time");
    m.data = c.Rest();
    if (channels_.count(m.channel_id) == 0)
      throw McapError(what + ": message refers to channel id " + std::to_string(m.channel_id) +
                      " which no Channel record defined before it");
    return m;
  };

  // ---- data section ----------------------------------------------------------------------
  bool data_end_seen = false;
  while (true) {
    const uint64_t rec_start = pos;
    if (file_size_ - pos < 9) {
      defect("file ends at offset " + std::to_string(file_size_) +
             " inside the data section (no DataEnd record, no summary, no footer): the file is "
             "truncated, e.g. the recorder was killed; `hexa_recorder recover` rewrites it");
      break;
    }
    unsigned char head[9];
    ReadAt(pos, head, 9);
    const uint8_t op = head[0];
    uint64_t len;
    std::memcpy(&len, head + 1, 8);
    if (len > file_size_ - pos - 9) {
      defect("record at offset " + std::to_string(rec_start) + " (opcode " + Hex(op) + " " +
             McapOpcodeName(op) + ") claims " + std::to_string(len) + " bytes but only " +
             std::to_string(file_size_ - pos - 9) +
             " remain in the file: length runs past end of file (truncated or corrupt; "
             "`hexa_recorder recover` keeps the intact chunks)");
      break;
    }
    if (!seen_header && op != static_cast<uint8_t>(McapOpcode::kHeader)) {
      defect("first record at offset 8 is opcode " + Hex(op) + " (" + McapOpcodeName(op) +
             "), expected a Header record");
      break;
    }
    body.resize(len);
    ReadAt(pos + 9, body.data(), len);
    const std::string what = "record at offset " + std::to_string(rec_start) + " (" +
                             McapOpcodeName(op) + ")";
    pos += 9 + len;
    if (op == static_cast<uint8_t>(McapOpcode::kDataEnd)) {
      Cursor c(body, what);
      const uint32_t stored = c.U32("data_section_crc");
      if (options.verify_crcs && stored != 0 && stored != data_crc)
        defect("data section CRC mismatch: DataEnd says " + Hex(stored) + ", computed " +
               Hex(data_crc));
      data_end_seen = true;
      result.valid_data_end = pos;
      break;
    }
    data_crc = Crc32(head, 9, data_crc);
    data_crc = Crc32(body.data(), body.size(), data_crc);
    try {
      switch (static_cast<McapOpcode>(op)) {
        case McapOpcode::kHeader: {
          if (seen_header) throw McapError(what + ": second Header record");
          Cursor c(body, what);
          c.Str("profile");
          c.Str("library");
          seen_header = true;
          break;
        }
        case McapOpcode::kSchema: deliver_schema(ParseSchema(body, what)); break;
        case McapOpcode::kChannel: deliver_channel(ParseChannel(body, what), what); break;
        case McapOpcode::kMessage: {
          const McapMessageView m = deliver_message(body, what);
          if (visitor.on_message) visitor.on_message(m);
          ++channel_counts[m.channel_id];
          if (result.messages == 0) min_log = max_log = m.log_time_ns;
          min_log = std::min(min_log, m.log_time_ns);
          max_log = std::max(max_log, m.log_time_ns);
          ++result.messages;
          break;
        }
        case McapOpcode::kChunk: {
          Cursor c(body, what);
          c.U64("message_start_time");
          c.U64("message_end_time");
          const uint64_t uncompressed_size = c.U64("uncompressed_size");
          const uint32_t crc = c.U32("uncompressed_crc");
          const std::string compression = c.Str("compression");
          const uint64_t records_len = c.U64("records length");
          if (records_len != c.remaining())
            throw McapError(what + ": records length " + std::to_string(records_len) +
                            " does not match the " + std::to_string(c.remaining()) +
                            " bytes left in the record");
          std::string_view records = c.Rest();
          const uint64_t stored_size = records.size();
          if (compression == "zstd") {
            if (zstd_ == nullptr) zstd_ = std::make_unique<ZstdCodec>();
            zstd_->Decompress(records, uncompressed_size, chunk_buffer_, what);
            records = chunk_buffer_;
          } else if (!compression.empty()) {
            throw McapError(what + ": compression '" + compression +
                            "' is not supported by this reader (chunks must be uncompressed "
                            "or zstd)");
          }
          if (uncompressed_size != records.size())
            throw McapError(what + ": uncompressed_size " + std::to_string(uncompressed_size) +
                            " != records length " + std::to_string(records.size()));
          if (options.verify_crcs && crc != 0) {
            const uint32_t got = Crc32(records.data(), records.size());
            if (got != crc)
              throw McapError(what + ": chunk CRC mismatch (stored " + Hex(crc) +
                              ", computed " + Hex(got) + "): the chunk is corrupt");
          }
          // Validate every inner record before delivering any message of the chunk, so that
          // a corrupt chunk is skipped whole in tolerant mode.
          struct Inner { uint8_t op; std::string_view body; uint64_t off; };
          std::vector<Inner> inner;
          Cursor r(records, what + " records");
          while (r.remaining() > 0) {
            const uint64_t off = r.pos();
            const uint8_t iop = r.U8("inner opcode");
            const uint64_t ilen = r.U64("inner length");
            if (ilen > r.remaining())
              throw McapError(what + ": inner record at chunk offset " + std::to_string(off) +
                              " claims " + std::to_string(ilen) + " bytes past the chunk end");
            inner.push_back({iop, r.Bytes(ilen, "inner body"), off});
          }
          for (const auto& in : inner) {
            const std::string iwhat = what + " inner " + McapOpcodeName(in.op) +
                                      " at chunk offset " + std::to_string(in.off);
            if (in.op == static_cast<uint8_t>(McapOpcode::kSchema)) {
              deliver_schema(ParseSchema(in.body, iwhat));
            } else if (in.op == static_cast<uint8_t>(McapOpcode::kChannel)) {
              deliver_channel(ParseChannel(in.body, iwhat), iwhat);
            } else if (in.op == static_cast<uint8_t>(McapOpcode::kMessage)) {
              deliver_message(in.body, iwhat);  // validation pass only
            } else if (in.op < 0x80) {
              throw McapError(iwhat + ": record type not allowed inside a chunk");
            }
          }
          for (const auto& in : inner) {
            if (in.op != static_cast<uint8_t>(McapOpcode::kMessage)) continue;
            const McapMessageView m = deliver_message(in.body, what);
            if (visitor.on_message) visitor.on_message(m);
            ++channel_counts[m.channel_id];
            if (result.messages == 0) min_log = max_log = m.log_time_ns;
            min_log = std::min(min_log, m.log_time_ns);
            max_log = std::max(max_log, m.log_time_ns);
            ++result.messages;
          }
          chunk_offsets.push_back(rec_start);
          ++result.chunks;
          ++result.chunk_compression[compression.empty() ? "none" : compression];
          result.chunk_records_bytes += records.size();
          result.chunk_stored_bytes += stored_size;
          break;
        }
        case McapOpcode::kFooter:
          throw McapError(what + ": Footer before any DataEnd record");
        default:
          break;  // MessageIndex, Attachment, Metadata, private and unknown opcodes: skipped
      }
    } catch (const McapError& e) {
      if (!options.tolerant) throw McapError(where + ": " + e.what());
      if (op == static_cast<uint8_t>(McapOpcode::kChunk)) {
        ++result.bad_chunks;
        result.problems.push_back(std::string("skipped: ") + e.what());
        result.valid_data_end = pos;
        continue;
      }
      result.problems.push_back(std::string("stopped: ") + e.what());
      break;
    }
    result.valid_data_end = pos;
    if (options.progress) options.progress(pos, file_size_);
  }
  if (!data_end_seen) return result;

  // ---- summary, summary offsets, footer ------------------------------------------------
  try {
    const uint64_t summary_first = pos;
    uint32_t summary_crc = 0;
    std::vector<uint64_t> indexed_chunks;
    bool have_stats = false;
    while (true) {
      const uint64_t rec_start = pos;
      if (file_size_ - pos < 9)
        throw McapError("file ends at offset " + std::to_string(file_size_) +
                        " after the data section without a Footer record (truncated summary)");
      unsigned char head[9];
      ReadAt(pos, head, 9);
      const uint8_t op = head[0];
      uint64_t len;
      std::memcpy(&len, head + 1, 8);
      if (len > file_size_ - pos - 9)
        throw McapError("summary record at offset " + std::to_string(rec_start) + " (" +
                        McapOpcodeName(op) + ") claims " + std::to_string(len) +
                        " bytes past end of file (truncated or corrupt)");
      body.resize(len);
      ReadAt(pos + 9, body.data(), len);
      pos += 9 + len;
      const std::string what = "summary record at offset " + std::to_string(rec_start) + " (" +
                               McapOpcodeName(op) + ")";
      if (op == static_cast<uint8_t>(McapOpcode::kFooter)) {
        Cursor c(body, what);
        const uint64_t summary_start = c.U64("summary_start");
        const uint64_t summary_offset_start = c.U64("summary_offset_start");
        summary_crc = Crc32(head, 9, summary_crc);
        summary_crc = Crc32(body.data(), 16, summary_crc);
        const uint32_t stored = c.U32("summary_crc");
        if (summary_start != 0 && summary_start != summary_first)
          throw McapError("Footer says the summary starts at " + std::to_string(summary_start) +
                          " but it starts at " + std::to_string(summary_first));
        if (summary_offset_start > rec_start)
          throw McapError("Footer's summary_offset_start " +
                          std::to_string(summary_offset_start) + " lies past the footer");
        if (options.verify_crcs && stored != 0 && summary_start != 0 && stored != summary_crc)
          throw McapError("summary CRC mismatch: Footer says " + Hex(stored) + ", computed " +
                          Hex(summary_crc));
        result.has_summary = summary_start != 0;
        break;
      }
      summary_crc = Crc32(head, 9, summary_crc);
      summary_crc = Crc32(body.data(), body.size(), summary_crc);
      Cursor c(body, what);
      if (op == static_cast<uint8_t>(McapOpcode::kStatistics)) {
        McapStatistics& s = result.summary_statistics;
        s.message_count = c.U64("message_count");
        s.schema_count = c.U16("schema_count");
        s.channel_count = c.U32("channel_count");
        c.U32("attachment_count");
        c.U32("metadata_count");
        s.chunk_count = c.U32("chunk_count");
        s.message_start_ns = c.U64("message_start_time");
        s.message_end_ns = c.U64("message_end_time");
        Cursor m(c.Bytes(c.U32("channel_message_counts length"), "map"), what + " map");
        while (m.remaining() > 0) {
          const uint16_t ch = m.U16("channel");
          s.channel_message_counts[ch] = m.U64("count");
        }
        have_stats = true;
      } else if (op == static_cast<uint8_t>(McapOpcode::kChunkIndex)) {
        c.U64("message_start_time");
        c.U64("message_end_time");
        indexed_chunks.push_back(c.U64("chunk_start_offset"));
      } else if (op == static_cast<uint8_t>(McapOpcode::kChannel)) {
        McapChannel ch = ParseChannel(body, what);
        if (channels_.count(ch.id) == 0) deliver_channel(std::move(ch), what);
      } else if (op == static_cast<uint8_t>(McapOpcode::kSchema)) {
        McapSchema s = ParseSchema(body, what);
        if (schemas_.count(s.id) == 0) deliver_schema(std::move(s));
      } else if (op == static_cast<uint8_t>(McapOpcode::kHeader) ||
                 op == static_cast<uint8_t>(McapOpcode::kMessage) ||
                 op == static_cast<uint8_t>(McapOpcode::kChunk) ||
                 op == static_cast<uint8_t>(McapOpcode::kDataEnd)) {
        throw McapError(what + ": record type not allowed in the summary section");
      }
    }
    // Closing magic, then nothing.
    if (file_size_ - pos < 8)
      throw McapError("file ends " + std::to_string(file_size_ - pos) +
                      " bytes after the Footer: closing magic missing (truncated)");
    unsigned char magic[8];
    ReadAt(pos, magic, 8);
    if (std::memcmp(magic, kMcapMagic, 8) != 0)
      throw McapError("no closing MCAP magic after the Footer at offset " + std::to_string(pos));
    pos += 8;
    if (pos != file_size_)
      throw McapError(std::to_string(file_size_ - pos) +
                      " bytes of trailing data after the closing magic at offset " +
                      std::to_string(pos) + " (garbage appended to the file?)");
    // The summary must agree with the data section it describes.
    if (have_stats) {
      const McapStatistics& s = result.summary_statistics;
      if (s.message_count != result.messages)
        throw McapError("summary Statistics count " + std::to_string(s.message_count) +
                        " messages but the data section holds " +
                        std::to_string(result.messages));
      for (const auto& [ch, n] : s.channel_message_counts) {
        const uint64_t got = channel_counts.count(ch) ? channel_counts.at(ch) : 0;
        if (got != n)
          throw McapError("summary Statistics count " + std::to_string(n) +
                          " messages on channel " + std::to_string(ch) + " but the data has " +
                          std::to_string(got));
      }
    }
    if (!indexed_chunks.empty() && indexed_chunks != chunk_offsets)
      throw McapError("summary ChunkIndex offsets do not match the chunks in the data section");
    result.complete = true;
  } catch (const McapError& e) {
    defect(e.what());
  }
  (void)min_log;
  (void)max_log;
  return result;
}

}  // namespace hexa::recorder
