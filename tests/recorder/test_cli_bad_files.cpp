// hexa_recorder on damaged input: every bad file, derived here from a good recording, gives a
// clear message on stderr and exit status 2, never a crash. Also the CLI on good files.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "synth.hpp"

#ifndef HEXA_RECORDER_BIN
#error "HEXA_RECORDER_BIN must name the hexa_recorder executable"
#endif

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;

struct CliResult {
  bool exited = false;  // false: killed by a signal (a crash)
  int code = -1;
  std::string out, err;
};

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
void Spit(const fs::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hexa_rec_cli_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    good_ = dir_ / "good.mcap";
    McapWriterConfig cfg;
    cfg.chunk_max_bytes = 64 * 1024;
    // The damage below is done to the uncompressed layout (bytes of chunk records); damaged
    // zstd chunks are tested in test_mcap_file.cpp (McapCompression.*).
    cfg.compression = McapCompression::kNone;
    test::WriteSynthRecording(good_.string(), cfg);
    bytes_ = Slurp(good_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `prefix`: shell text before the command (environment, ulimit).
  CliResult Run(const std::string& args, const std::string& prefix = "") {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string cmd = prefix + "'" + HEXA_RECORDER_BIN + "' " + args + " >'" +
                            out.string() + "' 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    CliResult r;
    r.exited = WIFEXITED(status);
    r.code = r.exited ? WEXITSTATUS(status) : -1;
    r.out = Slurp(out);
    r.err = Slurp(err);
    return r;
  }
  // Offset of the first record with `opcode` in the data section (walks record lengths).
  uint64_t FirstRecord(uint8_t opcode) const {
    uint64_t pos = 8;
    while (pos + 9 <= bytes_.size()) {
      uint64_t len;
      std::memcpy(&len, bytes_.data() + pos + 1, 8);
      if (static_cast<uint8_t>(bytes_[pos]) == opcode) return pos;
      pos += 9 + len;
    }
    ADD_FAILURE() << "no record with opcode " << int(opcode);
    return 0;
  }
  // Offset of the last record with `opcode` in the data section.
  uint64_t LastRecord(uint8_t opcode) const {
    uint64_t pos = 8, last = 0;
    while (pos + 9 <= bytes_.size()) {
      uint64_t len;
      std::memcpy(&len, bytes_.data() + pos + 1, 8);
      if (static_cast<uint8_t>(bytes_[pos]) == opcode) last = pos;
      if (static_cast<uint8_t>(bytes_[pos]) == 0x0F) break;  // DataEnd
      pos += 9 + len;
    }
    EXPECT_NE(last, 0u) << "no record with opcode " << int(opcode);
    return last;
  }
  // The bad file must fail `info` with exit 2 and a message naming the problem.
  void ExpectRejected(const std::string& name, const std::string& bytes,
                      const std::string& message_part) {
    const fs::path p = dir_ / name;
    Spit(p, bytes);
    const CliResult r = Run("info '" + p.string() + "'");
    EXPECT_TRUE(r.exited) << name << ": crashed";
    EXPECT_EQ(r.code, 2) << name << "\nstdout: " << r.out << "\nstderr: " << r.err;
    EXPECT_NE(r.err.find(message_part), std::string::npos)
        << name << ": stderr lacks '" << message_part << "':\n" << r.err;
    EXPECT_NE(r.err.find(p.string()), std::string::npos) << name << ": message names no file";
    // The other readers fail the same way, without crashing.
    for (const std::string& cmd : {"export '" + p.string() + "' --out-dir '" + (dir_ / "csv").string() + "'",
                                  "diff '" + p.string() + "' '" + good_.string() + "'"}) {
      const CliResult o = Run(cmd);
      EXPECT_TRUE(o.exited) << cmd;
      EXPECT_EQ(o.code, 2) << cmd << "\n" << o.err;
    }
  }

  fs::path dir_, good_;
  std::string bytes_;
};

TEST_F(CliTest, GoodFileInfoExportDiffSucceed) {
  const CliResult info = Run("info '" + good_.string() + "'");
  ASSERT_EQ(info.code, 0) << info.err;
  EXPECT_NE(info.out.find("messages:  14616 in"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("5 missing in 1 gaps"), std::string::npos) << info.out;
  const CliResult exp = Run("export '" + good_.string() + "' --out-dir '" + (dir_ / "csv").string() +
                            "' --topics hexa_ValveCommand");
  ASSERT_EQ(exp.code, 0) << exp.err;
  EXPECT_NE(exp.out.find("hexa_ValveCommand.csv: 5999 rows"), std::string::npos) << exp.out;
  EXPECT_EQ(Run("diff '" + good_.string() + "' '" + good_.string() + "'").code, 0);
  const fs::path other = dir_ / "other.mcap";
  test::WriteSynthRecording(other.string(), {}, 0.5, 1, 10);
  const CliResult diff = Run("diff '" + good_.string() + "' '" + other.string() + "'");
  EXPECT_EQ(diff.code, 1) << diff.err;
  EXPECT_NE(diff.out.find("differ"), std::string::npos);
  for (const char* cmd : {"info", "play", "record", "diff", "export", "recover"}) {
    const CliResult h = Run(std::string(cmd) + " --help");
    EXPECT_EQ(h.code, 0) << cmd;
    EXPECT_NE(h.out.find("usage: hexa_recorder"), std::string::npos) << cmd;
  }
  const CliResult bad_opt = Run("info --frobnicate '" + good_.string() + "'");
  EXPECT_EQ(bad_opt.code, 2);
  EXPECT_NE(bad_opt.err.find("unknown option '--frobnicate'"), std::string::npos) << bad_opt.err;
  // Record options are checked before any DDS entity exists.
  const CliResult bad_batch = Run("record --output '" + (dir_ / "x.mcap").string() +
                                  "' --flush-ms 100 --batch-ms 500");
  EXPECT_EQ(bad_batch.code, 2);
  EXPECT_NE(bad_batch.err.find("--batch-ms must be in [0, --flush-ms]"), std::string::npos)
      << bad_batch.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.mcap"));
}

TEST_F(CliTest, EmptyFile) { ExpectRejected("empty.mcap", "", "is empty"); }

TEST_F(CliTest, NotAnMcapFile) {
  ExpectRejected("zip.mcap", std::string("PK\x03\x04", 4) + std::string(200, 'z'),
                 "is not an MCAP file: it starts with bytes 50 4b 03 04");
}

TEST_F(CliTest, WrongMagicVersion) {
  std::string b = bytes_;
  b[5] = '1';
  ExpectRejected("version1.mcap", b, "unsupported MCAP major version byte 0x31");
}

TEST_F(CliTest, TruncatedFile) {
  ExpectRejected("truncated.mcap", bytes_.substr(0, bytes_.size() / 2),
                 "length runs past end of file");
}

TEST_F(CliTest, OnlyTheMagic) {
  ExpectRejected("magic_only.mcap", bytes_.substr(0, 8), "inside the data section");
}

TEST_F(CliTest, GarbageAppended) {
  ExpectRejected("garbage.mcap", bytes_ + "some garbage\n",
                 "13 bytes of trailing data after the closing magic");
}

TEST_F(CliTest, BadChunkCrc) {
  std::string b = bytes_;
  const uint64_t chunk = FirstRecord(0x06);
  b[chunk + 9 + 100] ^= 0x40;  // inside the chunk's records
  ExpectRejected("bad_crc.mcap", b, "chunk CRC mismatch");
}

TEST_F(CliTest, ChunkLengthPastEndOfFile) {
  std::string b = bytes_;
  const uint64_t chunk = FirstRecord(0x06);
  const uint64_t huge = 1ull << 40;
  std::memcpy(b.data() + chunk + 1, &huge, 8);
  ExpectRejected("chunk_len.mcap", b, "claims 1099511627776 bytes");
}

TEST_F(CliTest, BadSummaryCrc) {
  std::string b = bytes_;
  // The Footer's summary_start points at the first summary record; corrupt a byte past its
  // record header (a schema name character, so the record still parses).
  uint64_t summary_start;
  std::memcpy(&summary_start, b.data() + b.size() - 8 - 20, 8);
  b[summary_start + 9 + 2 + 4] ^= 0x01;
  ExpectRejected("bad_summary_crc.mcap", b, "summary CRC mismatch");
}

TEST_F(CliTest, UnknownSchemaName) {
  const fs::path p = dir_ / "unknown_schema.mcap";
  {
    McapWriter w;
    w.Open(p.string());
    const uint16_t s = w.AddSchema("hexa.rec.NoSuchMessage", "protobuf",
                                   FileDescriptorSetFor(*rec::LegSensors::descriptor()));
    const uint16_t c = w.AddChannel(s, "hexa_Mystery", "protobuf", {});
    w.Write(c, 1, 1, "");
    w.Close();
  }
  ExpectRejected("unknown_schema.mcap", Slurp(p), "unknown schema: no message named 'hexa.rec.NoSuchMessage'");
}

TEST_F(CliTest, UnknownSchemaEncoding) {
  const fs::path p = dir_ / "ros.mcap";
  {
    McapWriter w;
    w.Open(p.string());
    const uint16_t s = w.AddSchema("std_msgs/String", "ros2msg", "string data");
    const uint16_t c = w.AddChannel(s, "/chatter", "cdr", {});
    w.Write(c, 1, 1, "abc");
    w.Close();
  }
  ExpectRejected("ros.mcap", Slurp(p), "unknown schema encoding 'ros2msg'");
}

TEST_F(CliTest, MissingFileAndDirectory) {
  const CliResult missing = Run("info '" + (dir_ / "nope.mcap").string() + "'");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("No such file or directory"), std::string::npos) << missing.err;
  const CliResult directory = Run("info '" + dir_.string() + "'");
  EXPECT_EQ(directory.code, 2);
  EXPECT_NE(directory.err.find("is not a regular file"), std::string::npos) << directory.err;
}

TEST_F(CliTest, RecoverRepairsATruncatedFileAndInfoThenAgreesWithTheIntactPart) {
  const fs::path cut = dir_ / "cut.mcap", fixed = dir_ / "fixed.mcap";
  Spit(cut, bytes_.substr(0, bytes_.size() * 2 / 3));
  const CliResult tolerant = Run("info --tolerant '" + cut.string() + "'");
  EXPECT_EQ(tolerant.code, 0) << tolerant.err;
  EXPECT_NE(tolerant.out.find("INCOMPLETE"), std::string::npos);
  const CliResult rec = Run("recover '" + cut.string() + "' --output '" + fixed.string() + "'");
  ASSERT_EQ(rec.code, 0) << rec.err;
  EXPECT_NE(rec.out.find("input was incomplete"), std::string::npos) << rec.out;
  const RecordingInfo info = Inspect(fixed.string());
  EXPECT_TRUE(info.complete);
  McapScanOptions t;
  t.tolerant = true;
  EXPECT_EQ(info.messages, Inspect(cut.string(), t).messages);
  EXPECT_GT(info.messages, 14616u / 2);
  // Recovering a file with a corrupt chunk skips that chunk and keeps the rest.
  std::string b = bytes_;
  b[FirstRecord(0x06) + 9 + 100] ^= 0x40;
  Spit(cut, b);
  const CliResult rec2 = Run("recover '" + cut.string() + "' --output '" + fixed.string() + "'");
  ASSERT_EQ(rec2.code, 0) << rec2.err;
  EXPECT_NE(rec2.out.find("1 corrupt chunks skipped"), std::string::npos) << rec2.out;
  EXPECT_TRUE(Inspect(fixed.string()).complete);
}

// A recording whose FaultEvent.detail strings are not UTF-8 (written by recorders before the
// sanitiser: a CSV of random bytes must not make the session's recording unreadable): info,
// export and report read it, repair the strings (U+FFFD) and say so; recover does not call it
// complete, repairs it, and its output then reads without any repair.
TEST_F(CliTest, InvalidUtf8StringsAreRepairedOnReadAndReported) {
  const fs::path bad = dir_ / "bad_utf8.mcap", fixed = dir_ / "fixed.mcap";
  test::WriteSynthRecording(bad.string(), {}, 0.0, 0, 0, true);
  const CliResult info = Run("info '" + bad.string() + "'");
  ASSERT_EQ(info.code, 0) << info.err;
  EXPECT_NE(info.out.find("channel 'hexa_FaultEvent': 2 message(s) with invalid UTF-8"),
            std::string::npos) << info.out;
  EXPECT_NE(info.out.find("messages:  14616 in"), std::string::npos) << info.out;

  const fs::path csv = dir_ / "csv";
  const CliResult exp = Run("export '" + bad.string() + "' --out-dir '" + csv.string() + "'");
  ASSERT_EQ(exp.code, 0) << exp.err;
  EXPECT_NE(exp.err.find("warning: channel 'hexa_FaultEvent'"), std::string::npos) << exp.err;
  const std::string faults = Slurp(csv / "hexa_FaultEvent.csv");
  EXPECT_NE(faults.find("bad header \"\"\xEF\xBF\xBD"), std::string::npos) << faults;

  const fs::path out = dir_ / "report";
  const CliResult rep = Run("report '" + bad.string() + "' --out '" + out.string() + "' --no-plots");
  ASSERT_EQ(rep.code, 0) << rep.err;
  EXPECT_NE(Slurp(out / "report.md").find("recording warning: channel 'hexa_FaultEvent'"),
            std::string::npos);

  const CliResult rec = Run("recover '" + bad.string() + "' --output '" + fixed.string() + "'");
  ASSERT_EQ(rec.code, 0) << rec.err;
  EXPECT_NE(rec.out.find("complete in structure but not readable as it was"), std::string::npos)
      << rec.out;
  EXPECT_NE(rec.out.find("2 messages repaired"), std::string::npos) << rec.out;
  const RecordingInfo after = Inspect(fixed.string());
  EXPECT_TRUE(after.complete);
  EXPECT_TRUE(after.problems.empty()) << after.problems.front();
  EXPECT_EQ(after.messages, 14616u);
  // A good file is readable as it is.
  const CliResult again = Run("recover '" + good_.string() + "' --output '" + fixed.string() + "'");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("input was complete;"), std::string::npos) << again.out;
}

// recover exits 2, with a message and without an output file, when nothing was recovered.
TEST_F(CliTest, RecoverOfNothingFails) {
  const fs::path cut = dir_ / "header_only.mcap", fixed = dir_ / "fixed.mcap";
  Spit(cut, bytes_.substr(0, FirstRecord(0x06)));  // header, schemas, channels: no chunk
  const CliResult rec = Run("recover '" + cut.string() + "' --output '" + fixed.string() + "'");
  EXPECT_EQ(rec.code, 2) << rec.out << rec.err;
  EXPECT_NE(rec.err.find("nothing recovered"), std::string::npos) << rec.err;
  EXPECT_FALSE(fs::exists(fixed));
}

// export is all or nothing: a recording that turns out corrupt near its end leaves no CSV.
TEST_F(CliTest, ExportLeavesNoPartialCsvOnError) {
  std::string b = bytes_;
  b[LastRecord(0x06) + 9 + 100] ^= 0x40;  // CRC error in the last chunk
  const fs::path p = dir_ / "late_corruption.mcap", csv = dir_ / "csv";
  Spit(p, b);
  const CliResult exp = Run("export '" + p.string() + "' --out-dir '" + csv.string() + "'");
  EXPECT_EQ(exp.code, 2) << exp.out;
  EXPECT_NE(exp.err.find("CRC"), std::string::npos) << exp.err;
  ASSERT_TRUE(fs::exists(csv));
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(csv)) left.push_back(e.path().filename().string());
  EXPECT_TRUE(left.empty()) << left.size() << " file(s) left, e.g. " << left.front();
}

// The plots run on the system's Python whatever comes first on PATH: a virtual environment's
// python3 without matplotlib first on PATH made Python started as "python3" take that
// environment's prefix (it finds its prefix from argv[0] on PATH) and the plots failed.
TEST_F(CliTest, ReportPlotsWithTheSystemPythonWhateverIsFirstOnPath) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "matplotlib is not installed for /usr/bin/python3";
  const fs::path venv = dir_ / "venv";
  fs::create_directories(venv / "bin");
  fs::create_symlink("/usr/bin/python3", venv / "bin" / "python3");
  Spit(venv / "pyvenv.cfg", "home = /nonexistent\ninclude-system-site-packages = false\n");
  const fs::path out = dir_ / "report";
  const CliResult rep = Run("report '" + good_.string() + "' --out '" + out.string() + "'",
                            "PATH='" + (venv / "bin").string() + "':\"$PATH\" ");
  EXPECT_EQ(rep.code, 0) << rep.err;
  int plots = 0;
  for (const auto& e : fs::directory_iterator(out)) plots += e.path().extension() == ".png";
  EXPECT_GT(plots, 0) << rep.err;
  const CliResult relative = Run("report '" + good_.string() + "' --out '" + out.string() +
                                 "' --python python3");
  EXPECT_EQ(relative.code, 2) << relative.err;
  EXPECT_NE(relative.err.find("--python wants an absolute path"), std::string::npos) << relative.err;
}

// A full disk while recovering (here a file-size limit: writes fail with EFBIG, as they fail
// with ENOSPC on a full disk): the error names the file and the cause, and no partial or
// empty output is left that could pass for a recovered recording.
TEST_F(CliTest, RecoverOnAFullDiskSaysWhyAndLeavesNoOutput) {
  const fs::path damaged = dir_ / "damaged.mcap", fixed = dir_ / "fixed.mcap";
  Spit(damaged, bytes_.substr(0, bytes_.size() - 200));  // no footer: as after a kill -9
  // 64 blocks of 512 bytes (sh's ulimit -f unit): far less than the recovered file.
  const CliResult rec = Run("recover '" + damaged.string() + "' --output '" + fixed.string() + "'",
                            "trap '' XFSZ; ulimit -f 64; ");
  EXPECT_TRUE(rec.exited);
  EXPECT_NE(rec.code, 0) << rec.out;
  EXPECT_NE(rec.err.find(fixed.string()), std::string::npos) << "stderr: '" << rec.err << "'";
  EXPECT_NE(rec.err.find("File too large"), std::string::npos) << "stderr: '" << rec.err << "'";
  EXPECT_FALSE(fs::exists(fixed)) << fs::file_size(fixed) << " bytes left";
}

}  // namespace
}  // namespace hexa::recorder
