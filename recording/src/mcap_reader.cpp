// MCAP reader (mcap.dev/spec): checks and delivers a file record by record, strict or
// tolerant of damage (McapScanOptions). The writer is mcap.cpp.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <vector>

#include "compression.hpp"
#include "hexa/recording/mcap.hpp"

namespace hexa::recorder {
namespace {

std::string Hex(uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%llx", static_cast<unsigned long long>(v));
  return buf;
}

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

// One scan of an open file: the data section record by record, then the summary, the footer
// and the closing magic, each checked against what the data section held.
class McapScanner {
 public:
  McapScanner(McapReader& reader, const McapVisitor& visitor, const McapScanOptions& options)
      : reader_(reader), visitor_(visitor), options_(options), where_("'" + reader.path_ + "'") {
    result_.file_size = reader.file_size_;
  }

  McapScanResult Run() {
    if (!ScanDataSection()) return result_;
    try {
      ScanSummary();
      result_.complete = true;
    } catch (const McapError& e) {
      Defect(e.what());
    }
    return result_;
  }

 private:
  // A defect: strict mode throws, tolerant mode records it and the scan stops or skips.
  void Defect(const std::string& what) {
    if (!options_.tolerant) throw McapError(where_ + ": " + what);
    result_.problems.push_back(what);
  }

  void DeliverSchema(McapSchema s) {
    if (visitor_.on_schema) visitor_.on_schema(s);
    reader_.schemas_[s.id] = std::move(s);
  }

  void DeliverChannel(McapChannel ch, const std::string& what) {
    if (ch.schema_id != 0 && reader_.schemas_.count(ch.schema_id) == 0)
      throw McapError(what + ": channel " + std::to_string(ch.id) + " '" + ch.topic +
                      "' refers to schema id " + std::to_string(ch.schema_id) +
                      " which no Schema record defines (unknown schema)");
    if (visitor_.on_channel) visitor_.on_channel(ch);
    reader_.channels_[ch.id] = std::move(ch);
  }

  McapMessageView ParseMessage(std::string_view rec, const std::string& what) const {
    Cursor c(rec, what);
    McapMessageView m;
    m.channel_id = c.U16("channel_id");
    m.sequence = c.U32("sequence");
    m.log_time_ns = c.U64("log_time");
    m.publish_time_ns = c.U64("publish_time");
    m.data = c.Rest();
    if (reader_.channels_.count(m.channel_id) == 0)
      throw McapError(what + ": message refers to channel id " + std::to_string(m.channel_id) +
                      " which no Channel record defined before it");
    return m;
  }

  void DeliverMessage(std::string_view rec, const std::string& what) {
    const McapMessageView m = ParseMessage(rec, what);
    if (visitor_.on_message) visitor_.on_message(m);
    ++channel_counts_[m.channel_id];
    ++result_.messages;
  }

  // ---- data section ----------------------------------------------------------------------

  // Reads the opcode and length of the record at pos_; false (after a defect) when the data
  // section ends there.
  bool ReadDataHead(unsigned char (&head)[9], uint8_t& op, uint64_t& len) {
    const uint64_t file_size = reader_.file_size_;
    if (file_size - pos_ < 9) {
      Defect("file ends at offset " + std::to_string(file_size) +
             " inside the data section (no DataEnd record, no summary, no footer): the file is "
             "truncated, e.g. the recorder was killed; `hexa_recorder recover` rewrites it");
      return false;
    }
    reader_.ReadAt(pos_, head, 9);
    op = head[0];
    std::memcpy(&len, head + 1, 8);
    if (len > file_size - pos_ - 9) {
      Defect("record at offset " + std::to_string(pos_) + " (opcode " + Hex(op) + " " +
             McapOpcodeName(op) + ") claims " + std::to_string(len) + " bytes but only " +
             std::to_string(file_size - pos_ - 9) +
             " remain in the file: length runs past end of file (truncated or corrupt; "
             "`hexa_recorder recover` keeps the intact chunks)");
      return false;
    }
    if (!seen_header_ && op != static_cast<uint8_t>(McapOpcode::kHeader)) {
      Defect("first record at offset 8 is opcode " + Hex(op) + " (" + McapOpcodeName(op) +
             "), expected a Header record");
      return false;
    }
    return true;
  }

  // true when the data section ended with a DataEnd record (the summary follows).
  bool ScanDataSection() {
    while (true) {
      const uint64_t rec_start = pos_;
      unsigned char head[9];
      uint8_t op = 0;
      uint64_t len = 0;
      if (!ReadDataHead(head, op, len)) return false;
      body_.resize(len);
      reader_.ReadAt(pos_ + 9, body_.data(), len);
      const std::string what = "record at offset " + std::to_string(rec_start) + " (" +
                               McapOpcodeName(op) + ")";
      pos_ += 9 + len;
      if (op == static_cast<uint8_t>(McapOpcode::kDataEnd)) {
        Cursor c(body_, what);
        const uint32_t stored = c.U32("data_section_crc");
        if (options_.verify_crcs && stored != 0 && stored != data_crc_)
          Defect("data section CRC mismatch: DataEnd says " + Hex(stored) + ", computed " +
                 Hex(data_crc_));
        result_.valid_data_end = pos_;
        return true;
      }
      data_crc_ = Crc32(head, 9, data_crc_);
      data_crc_ = Crc32(body_.data(), body_.size(), data_crc_);
      try {
        DataRecord(op, what, rec_start);
      } catch (const McapError& e) {
        if (!options_.tolerant) throw McapError(where_ + ": " + e.what());
        if (op == static_cast<uint8_t>(McapOpcode::kChunk)) {
          ++result_.bad_chunks;
          result_.problems.push_back(std::string("skipped: ") + e.what());
          result_.valid_data_end = pos_;
          continue;
        }
        result_.problems.push_back(std::string("stopped: ") + e.what());
        return false;
      }
      result_.valid_data_end = pos_;
      if (options_.progress) options_.progress(pos_, reader_.file_size_);
    }
  }

  void DataRecord(uint8_t op, const std::string& what, uint64_t rec_start) {
    switch (static_cast<McapOpcode>(op)) {
      case McapOpcode::kHeader: {
        if (seen_header_) throw McapError(what + ": second Header record");
        Cursor c(body_, what);
        c.Str("profile");
        c.Str("library");
        seen_header_ = true;
        break;
      }
      case McapOpcode::kSchema: DeliverSchema(ParseSchema(body_, what)); break;
      case McapOpcode::kChannel: DeliverChannel(ParseChannel(body_, what), what); break;
      case McapOpcode::kMessage: DeliverMessage(body_, what); break;
      case McapOpcode::kChunk: ReadChunk(what, rec_start); break;
      case McapOpcode::kFooter:
        throw McapError(what + ": Footer before any DataEnd record");
      default:
        break;  // MessageIndex, Attachment, Metadata, private and unknown opcodes: skipped
    }
  }

  void ReadChunk(const std::string& what, uint64_t rec_start) {
    Cursor c(body_, what);
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
      if (reader_.zstd_ == nullptr) reader_.zstd_ = std::make_unique<ZstdCodec>();
      reader_.zstd_->Decompress(records, uncompressed_size, reader_.chunk_buffer_, what);
      records = reader_.chunk_buffer_;
    } else if (!compression.empty()) {
      throw McapError(what + ": compression '" + compression +
                      "' is not supported by this reader (chunks must be uncompressed "
                      "or zstd)");
    }
    if (uncompressed_size != records.size())
      throw McapError(what + ": uncompressed_size " + std::to_string(uncompressed_size) +
                      " != records length " + std::to_string(records.size()));
    if (options_.verify_crcs && crc != 0) {
      const uint32_t got = Crc32(records.data(), records.size());
      if (got != crc)
        throw McapError(what + ": chunk CRC mismatch (stored " + Hex(crc) +
                        ", computed " + Hex(got) + "): the chunk is corrupt");
    }
    DeliverChunkRecords(records, what);
    chunk_offsets_.push_back(rec_start);
    ++result_.chunks;
    ++result_.chunk_compression[compression.empty() ? "none" : compression];
    result_.chunk_records_bytes += records.size();
    result_.chunk_stored_bytes += stored_size;
  }

  // Validates every inner record before delivering any message of the chunk, so that a
  // corrupt chunk is skipped whole in tolerant mode.
  void DeliverChunkRecords(std::string_view records, const std::string& what) {
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
        DeliverSchema(ParseSchema(in.body, iwhat));
      } else if (in.op == static_cast<uint8_t>(McapOpcode::kChannel)) {
        DeliverChannel(ParseChannel(in.body, iwhat), iwhat);
      } else if (in.op == static_cast<uint8_t>(McapOpcode::kMessage)) {
        ParseMessage(in.body, iwhat);  // validation pass only
      } else if (in.op < 0x80) {
        throw McapError(iwhat + ": record type not allowed inside a chunk");
      }
    }
    for (const auto& in : inner) {
      if (in.op == static_cast<uint8_t>(McapOpcode::kMessage)) DeliverMessage(in.body, what);
    }
  }

  // ---- summary, summary offsets, footer ------------------------------------------------

  // Throws McapError on any defect; the caller records it.
  void ScanSummary() {
    const uint64_t summary_first = pos_;
    uint32_t summary_crc = 0;
    const uint64_t file_size = reader_.file_size_;
    while (true) {
      const uint64_t rec_start = pos_;
      if (file_size - pos_ < 9)
        throw McapError("file ends at offset " + std::to_string(file_size) +
                        " after the data section without a Footer record (truncated summary)");
      unsigned char head[9];
      reader_.ReadAt(pos_, head, 9);
      const uint8_t op = head[0];
      uint64_t len;
      std::memcpy(&len, head + 1, 8);
      if (len > file_size - pos_ - 9)
        throw McapError("summary record at offset " + std::to_string(rec_start) + " (" +
                        McapOpcodeName(op) + ") claims " + std::to_string(len) +
                        " bytes past end of file (truncated or corrupt)");
      body_.resize(len);
      reader_.ReadAt(pos_ + 9, body_.data(), len);
      pos_ += 9 + len;
      const std::string what = "summary record at offset " + std::to_string(rec_start) + " (" +
                               McapOpcodeName(op) + ")";
      if (op == static_cast<uint8_t>(McapOpcode::kFooter)) {
        ReadFooter(head, what, summary_first, rec_start, summary_crc);
        break;
      }
      summary_crc = Crc32(head, 9, summary_crc);
      summary_crc = Crc32(body_.data(), body_.size(), summary_crc);
      SummaryRecord(op, what);
    }
    CheckClosingMagic();
    CheckSummaryMatchesData();
  }

  void ReadFooter(const unsigned char (&head)[9], const std::string& what, uint64_t summary_first,
                  uint64_t footer_start, uint32_t summary_crc) {
    Cursor c(body_, what);
    const uint64_t summary_start = c.U64("summary_start");
    const uint64_t summary_offset_start = c.U64("summary_offset_start");
    summary_crc = Crc32(head, 9, summary_crc);
    summary_crc = Crc32(body_.data(), 16, summary_crc);
    const uint32_t stored = c.U32("summary_crc");
    if (summary_start != 0 && summary_start != summary_first)
      throw McapError("Footer says the summary starts at " + std::to_string(summary_start) +
                      " but it starts at " + std::to_string(summary_first));
    if (summary_offset_start > footer_start)
      throw McapError("Footer's summary_offset_start " +
                      std::to_string(summary_offset_start) + " lies past the footer");
    if (options_.verify_crcs && stored != 0 && summary_start != 0 && stored != summary_crc)
      throw McapError("summary CRC mismatch: Footer says " + Hex(stored) + ", computed " +
                      Hex(summary_crc));
    result_.has_summary = summary_start != 0;
  }

  void SummaryRecord(uint8_t op, const std::string& what) {
    Cursor c(body_, what);
    if (op == static_cast<uint8_t>(McapOpcode::kStatistics)) {
      McapStatistics& s = result_.summary_statistics;
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
      have_stats_ = true;
    } else if (op == static_cast<uint8_t>(McapOpcode::kChunkIndex)) {
      c.U64("message_start_time");
      c.U64("message_end_time");
      indexed_chunks_.push_back(c.U64("chunk_start_offset"));
    } else if (op == static_cast<uint8_t>(McapOpcode::kChannel)) {
      McapChannel ch = ParseChannel(body_, what);
      if (reader_.channels_.count(ch.id) == 0) DeliverChannel(std::move(ch), what);
    } else if (op == static_cast<uint8_t>(McapOpcode::kSchema)) {
      McapSchema s = ParseSchema(body_, what);
      if (reader_.schemas_.count(s.id) == 0) DeliverSchema(std::move(s));
    } else if (op == static_cast<uint8_t>(McapOpcode::kHeader) ||
               op == static_cast<uint8_t>(McapOpcode::kMessage) ||
               op == static_cast<uint8_t>(McapOpcode::kChunk) ||
               op == static_cast<uint8_t>(McapOpcode::kDataEnd)) {
      throw McapError(what + ": record type not allowed in the summary section");
    }
  }

  // Closing magic, then nothing.
  void CheckClosingMagic() {
    const uint64_t file_size = reader_.file_size_;
    if (file_size - pos_ < 8)
      throw McapError("file ends " + std::to_string(file_size - pos_) +
                      " bytes after the Footer: closing magic missing (truncated)");
    unsigned char magic[8];
    reader_.ReadAt(pos_, magic, 8);
    if (std::memcmp(magic, kMcapMagic, 8) != 0)
      throw McapError("no closing MCAP magic after the Footer at offset " + std::to_string(pos_));
    pos_ += 8;
    if (pos_ != file_size)
      throw McapError(std::to_string(file_size - pos_) +
                      " bytes of trailing data after the closing magic at offset " +
                      std::to_string(pos_) + " (garbage appended to the file?)");
  }

  // The summary must agree with the data section it describes.
  void CheckSummaryMatchesData() const {
    if (have_stats_) {
      const McapStatistics& s = result_.summary_statistics;
      if (s.message_count != result_.messages)
        throw McapError("summary Statistics count " + std::to_string(s.message_count) +
                        " messages but the data section holds " +
                        std::to_string(result_.messages));
      for (const auto& [ch, n] : s.channel_message_counts) {
        const uint64_t got = channel_counts_.count(ch) ? channel_counts_.at(ch) : 0;
        if (got != n)
          throw McapError("summary Statistics count " + std::to_string(n) +
                          " messages on channel " + std::to_string(ch) + " but the data has " +
                          std::to_string(got));
      }
    }
    if (!indexed_chunks_.empty() && indexed_chunks_ != chunk_offsets_)
      throw McapError("summary ChunkIndex offsets do not match the chunks in the data section");
  }

  McapReader& reader_;
  const McapVisitor& visitor_;
  const McapScanOptions& options_;
  const std::string where_;
  McapScanResult result_;
  uint64_t pos_ = 8;
  uint32_t data_crc_ = Crc32(kMcapMagic, 8);
  std::string body_;
  bool seen_header_ = false;
  std::map<uint16_t, uint64_t> channel_counts_;
  std::vector<uint64_t> chunk_offsets_;   // of the chunks in the data section
  std::vector<uint64_t> indexed_chunks_;  // the summary's ChunkIndex offsets
  bool have_stats_ = false;
};

McapScanResult McapReader::Scan(const McapVisitor& visitor, const McapScanOptions& options) {
  if (fd_ < 0) throw McapError("McapReader::Scan: no open file");
  schemas_.clear();
  channels_.clear();
  return McapScanner(*this, visitor, options).Run();
}

}  // namespace hexa::recorder
