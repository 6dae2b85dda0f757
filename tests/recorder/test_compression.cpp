// zstd chunk compression of the MCAP layer (docs/measurements/recorder.md, "Compression"): round trip in both
// modes, and what the reader says about damaged compressed chunks.
#include <gtest/gtest.h>

#include "scratch_dir.hpp"
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "synth.hpp"

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;

// Removed when the test passes, kept when it fails (scratch_dir.hpp).
fs::path TempDir() {
  return hexa::testing::ScratchDir(
      std::string("hexa_zstd_test_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
}
std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
void Spit(const fs::path& p, const std::string& b) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(b.data(), static_cast<std::streamsize>(b.size()));
}

struct Sent {
  uint16_t channel;
  uint64_t log_ns;
  std::string data;
};

// Writes 3000 messages (compressible: repeated text with a counter) in one of the two modes.
std::vector<Sent> WriteFile(const std::string& path, McapCompression c) {
  McapWriterConfig cfg;
  cfg.compression = c;
  cfg.sync = McapSyncMode::kNone;
  cfg.chunk_max_bytes = 32 * 1024;
  McapWriter w(cfg);
  w.Open(path);
  const uint16_t s = w.AddSchema("pkg.A", "protobuf", "schema");
  const uint16_t a = w.AddChannel(s, "/a", "protobuf", {});
  const uint16_t b = w.AddChannel(s, "/b", "protobuf", {});
  std::mt19937_64 rng(7);
  std::vector<Sent> sent;
  for (int i = 0; i < 3000; ++i) {
    Sent m{static_cast<uint16_t>(i % 4 == 0 ? b : a), 1000 + 1000ull * i,
           "leg " + std::to_string(i % 6) + " length " + std::to_string(rng() % 1000) +
               std::string(static_cast<size_t>(rng() % 50), 'x')};
    w.Write(m.channel, m.log_ns, m.log_ns, m.data);
    sent.push_back(m);
  }
  w.Close();
  return sent;
}

McapScanResult ReadAll(const std::string& path, std::vector<Sent>& got, bool tolerant = false) {
  McapReader r;
  r.Open(path);
  McapVisitor v;
  v.on_message = [&](const McapMessageView& m) {
    got.push_back({m.channel_id, m.log_time_ns, std::string(m.data)});
  };
  McapScanOptions o;
  o.tolerant = tolerant;
  return r.Scan(v, o);
}

// Offset of the first Chunk record and of its fields.
struct ChunkAt {
  uint64_t record = 0, uncompressed_size = 0, crc = 0, compression = 0, records = 0;
  uint64_t records_len = 0;
};
ChunkAt FirstChunk(const std::string& bytes) {
  uint64_t pos = 8;
  while (pos + 9 <= bytes.size()) {
    uint64_t len;
    std::memcpy(&len, bytes.data() + pos + 1, 8);
    if (bytes[pos] == 0x06) {
      ChunkAt c;
      c.record = pos;
      c.uncompressed_size = pos + 9 + 16;
      c.crc = c.uncompressed_size + 8;
      c.compression = c.crc + 4;  // uint32 length + text
      uint32_t n;
      std::memcpy(&n, bytes.data() + c.compression, 4);
      const uint64_t records_len_at = c.compression + 4 + n;
      std::memcpy(&c.records_len, bytes.data() + records_len_at, 8);
      c.records = records_len_at + 8;
      return c;
    }
    pos += 9 + len;
  }
  ADD_FAILURE() << "no chunk";
  return {};
}

TEST(McapCompression, RoundTripInBothModesKeepsEveryMessage) {
  const fs::path dir = TempDir();
  for (McapCompression c : {McapCompression::kNone, McapCompression::kZstd}) {
    const std::string path = dir / (std::string("f_") + (c == McapCompression::kZstd ? "zstd" : "none"));
    const std::vector<Sent> sent = WriteFile(path, c);
    std::vector<Sent> got;
    const McapScanResult r = ReadAll(path, got);
    EXPECT_TRUE(r.complete);
    ASSERT_EQ(got.size(), sent.size());
    for (size_t i = 0; i < sent.size(); ++i) {
      EXPECT_EQ(got[i].channel, sent[i].channel);
      EXPECT_EQ(got[i].log_ns, sent[i].log_ns);
      ASSERT_EQ(got[i].data, sent[i].data) << i;
    }
    const std::string kind = c == McapCompression::kZstd ? "zstd" : "none";
    ASSERT_EQ(r.chunk_compression.size(), 1u);
    EXPECT_EQ(r.chunk_compression.begin()->first, kind);
    EXPECT_EQ(r.chunk_compression.begin()->second, r.chunks);
    EXPECT_GT(r.chunks, 3u);
    if (c == McapCompression::kZstd) {
      EXPECT_LT(r.chunk_stored_bytes * 3, r.chunk_records_bytes)
          << "text this repetitive compresses more than 3x";
    } else {
      EXPECT_EQ(r.chunk_stored_bytes, r.chunk_records_bytes);
    }
  }
}

TEST(McapCompression, DamagedChunkIsReportedAndSkippedWhenTolerant) {
  const fs::path dir = TempDir();
  const std::vector<Sent> sent = WriteFile(dir / "good.mcap", McapCompression::kZstd);
  const std::string good = Slurp(dir / "good.mcap");
  const ChunkAt c = FirstChunk(good);
  ASSERT_EQ(good.substr(c.compression + 4, 4), "zstd");
  std::string bad = good;
  for (uint64_t k = 0; k < 16; ++k) bad[c.records + c.records_len / 2 + k] ^= 0x5A;
  Spit(dir / "bad.mcap", bad);
  std::vector<Sent> got;
  try {
    ReadAll(dir / "bad.mcap", got);
    FAIL() << "a damaged zstd chunk was accepted";
  } catch (const McapError& e) {
    const std::string what = e.what();
    // Either zstd sees the damage, or it decodes garbage that the CRC of the uncompressed
    // records catches.
    EXPECT_TRUE(what.find("zstd") != std::string::npos ||
                what.find("CRC mismatch") != std::string::npos) << what;
    EXPECT_NE(what.find("offset " + std::to_string(c.record)), std::string::npos) << what;
  }
  got.clear();
  const McapScanResult r = ReadAll(dir / "bad.mcap", got, /*tolerant=*/true);
  EXPECT_EQ(r.bad_chunks, 1u);
  EXPECT_GT(got.size(), 0u);
  EXPECT_LT(got.size(), sent.size());
}

TEST(McapCompression, SizeFieldsAndUnknownCompressionAreRefused) {
  const fs::path dir = TempDir();
  WriteFile(dir / "good.mcap", McapCompression::kZstd);
  const std::string good = Slurp(dir / "good.mcap");
  const ChunkAt c = FirstChunk(good);
  auto expect_error = [&](const std::string& bytes, const std::string& part) {
    Spit(dir / "bad.mcap", bytes);
    std::vector<Sent> got;
    try {
      ReadAll(dir / "bad.mcap", got);
      ADD_FAILURE() << "accepted; expected '" << part << "'";
    } catch (const McapError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  std::string b = good;
  uint64_t size;
  std::memcpy(&size, b.data() + c.uncompressed_size, 8);
  const uint64_t wrong = size + 1;
  std::memcpy(b.data() + c.uncompressed_size, &wrong, 8);
  expect_error(b, "zstd frame holds " + std::to_string(size) + " bytes but the chunk's "
                  "uncompressed_size says " + std::to_string(wrong));
  b = good;
  const uint64_t huge = 1ull << 40;
  std::memcpy(b.data() + c.uncompressed_size, &huge, 8);
  expect_error(b, "exceeds the");
  b = good;
  b.replace(c.compression + 4, 4, "lz4!");
  expect_error(b, "compression 'lz4!' is not supported by this reader");
  b = good;
  b[c.crc] ^= 0x01;  // CRC of the uncompressed records
  expect_error(b, "chunk CRC mismatch");
}

TEST(McapCompression, RecoverRewritesATruncatedCompressedFile) {
  const fs::path dir = TempDir();
  const std::vector<Sent> sent = WriteFile(dir / "good.mcap", McapCompression::kZstd);
  const std::string good = Slurp(dir / "good.mcap");
  Spit(dir / "cut.mcap", good.substr(0, good.size() / 2));
  std::vector<Sent> tolerant;
  ReadAll(dir / "cut.mcap", tolerant, true);
  for (McapCompression out : {McapCompression::kNone, McapCompression::kZstd}) {
    McapWriterConfig cfg;
    cfg.compression = out;
    const fs::path fixed = dir / (out == McapCompression::kZstd ? "fixed_zstd.mcap" : "fixed_none.mcap");
    const RecoverResult rr = Recover(dir / "cut.mcap", fixed, cfg);
    EXPECT_FALSE(rr.input_complete);
    std::vector<Sent> got;
    const McapScanResult r = ReadAll(fixed, got);
    EXPECT_TRUE(r.complete);
    ASSERT_EQ(got.size(), tolerant.size());
    ASSERT_GT(got.size(), 0u);
    for (size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i].data, sent[i].data);
    EXPECT_EQ(r.chunk_compression.count(out == McapCompression::kZstd ? "zstd" : "none"), 1u);
  }
}

TEST(McapCompression, ConfigIsValidated) {
  McapWriterConfig cfg;
  cfg.zstd_level = 0;
  EXPECT_THROW(cfg.Validate(), std::invalid_argument);
  cfg.zstd_level = 20;
  EXPECT_THROW(cfg.Validate(), std::invalid_argument);
  cfg.compression = McapCompression::kNone;
  EXPECT_NO_THROW(cfg.Validate());
  EXPECT_EQ(ParseMcapCompression("zstd"), McapCompression::kZstd);
  EXPECT_EQ(ParseMcapCompression("none"), McapCompression::kNone);
  EXPECT_THROW(ParseMcapCompression("lz4"), std::invalid_argument);
  EXPECT_EQ(McapWriterConfig{}.compression, McapCompression::kZstd) << "on by default";
}

}  // namespace
}  // namespace hexa::recorder
