// File layer of the recorder: MCAP writer -> reader with every record field and every
// recording type, chunking, crash safety (kill -9 of a writing child process) and recovery.
// What is read back from recordings (info, report, diff, export, loss): test_recording_analysis.cpp.
#include <gtest/gtest.h>

#include "recorder_scratch.hpp"
#include <google/protobuf/util/message_differencer.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/services/json.hpp"
#include "recording.pb.h"
#include "synth.hpp"

namespace hexa::recorder {
namespace {
namespace fs = std::filesystem;
namespace gp = google::protobuf;

TEST(Crc32, MatchesTheStandardCheckValue) {
  // CRC-32/ISO-HDLC check value of "123456789".
  EXPECT_EQ(Crc32("123456789", 9), 0xCBF43926u);
  // Incremental over pieces equals one pass.
  const std::string s = "The quick brown fox jumps over the lazy dog, twice over.";
  EXPECT_EQ(Crc32(s.data() + 10, s.size() - 10, Crc32(s.data(), 10)), Crc32(s.data(), s.size()));
}

TEST(McapFile, RawRoundTripKeepsEveryRecordField) {
  const fs::path dir = TempDir();
  const std::string path = dir / "raw.mcap";
  McapWriterConfig cfg;
  cfg.chunk_max_messages = 7;
  cfg.sync = McapSyncMode::kFflush;
  McapWriter w(cfg);
  w.Open(path);
  const uint16_t s1 = w.AddSchema("pkg.A", "protobuf", std::string("\x01\x00\x02", 3));
  const uint16_t c1 = w.AddChannel(s1, "/a", "protobuf", {{"k", "v"}, {"qos.depth", "3"}});
  const uint16_t c2 = w.AddChannel(s1, "/b", "protobuf", {});
  std::mt19937_64 rng(42);
  struct Sent { uint16_t ch; uint64_t log, pub; std::string data; };
  std::vector<Sent> sent;
  for (int i = 0; i < 50; ++i) {
    Sent s{static_cast<uint16_t>(i % 3 == 0 ? c2 : c1), 1000 + 10ull * i, rng(),
           std::string(static_cast<size_t>(rng() % 40), static_cast<char>('a' + i % 26))};
    w.Write(s.ch, s.log, s.pub, s.data);
    sent.push_back(s);
  }
  w.Close();
  EXPECT_EQ(w.stats().chunks, 8u);  // 50 messages, 7 per chunk

  McapReader r;
  r.Open(path);
  std::vector<McapMessageView> got;
  std::vector<std::string> payloads;
  McapVisitor v;
  v.on_message = [&](const McapMessageView& m) {
    got.push_back(m);
    payloads.emplace_back(m.data);
  };
  const McapScanResult res = r.Scan(v);
  ASSERT_TRUE(res.complete);
  ASSERT_TRUE(res.has_summary);
  EXPECT_EQ(res.chunks, 8u);
  ASSERT_EQ(got.size(), sent.size());
  uint32_t seq_a = 0, seq_b = 0;
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].channel_id, sent[i].ch);
    EXPECT_EQ(got[i].log_time_ns, sent[i].log);
    EXPECT_EQ(got[i].publish_time_ns, sent[i].pub);
    EXPECT_EQ(payloads[i], sent[i].data);
    EXPECT_EQ(got[i].sequence, sent[i].ch == c1 ? seq_a++ : seq_b++);
  }
  ASSERT_EQ(r.schemas().size(), 1u);
  EXPECT_EQ(r.schemas().at(s1).name, "pkg.A");
  EXPECT_EQ(r.schemas().at(s1).data, std::string("\x01\x00\x02", 3));
  ASSERT_EQ(r.channels().size(), 2u);
  EXPECT_EQ(r.channels().at(c1).topic, "/a");
  EXPECT_EQ(r.channels().at(c1).metadata.at("qos.depth"), "3");
  const McapStatistics& st = res.summary_statistics;
  EXPECT_EQ(st.message_count, 50u);
  EXPECT_EQ(st.chunk_count, 8u);
  EXPECT_EQ(st.channel_count, 2u);
  EXPECT_EQ(st.message_start_ns, 1000u);
  EXPECT_EQ(st.message_end_ns, 1490u);
  EXPECT_EQ(st.channel_message_counts.at(c2), 17u);
  EXPECT_EQ(st.channel_message_counts.at(c1), 33u);
}

TEST(McapFile, ChunksCloseWhenTheirLogTimeSpanIsReached) {
  const fs::path dir = TempDir();
  McapWriterConfig cfg;
  cfg.chunk_max_span_ns = 100'000'000;  // 100 ms
  cfg.sync = McapSyncMode::kNone;
  McapWriter w(cfg);
  w.Open(dir / "span.mcap");
  const uint16_t ch = w.AddChannel(0, "/x", "raw", {});
  for (uint64_t t = 0; t < 1'000'000'000; t += 1'000'000) w.Write(ch, t, t, "x");  // 1 kHz, 1 s
  // A chunk closes on the message that is 100 ms younger than its first: 101 messages per
  // chunk, 9 chunks closed, messages 909..999 ms still open.
  EXPECT_EQ(w.stats().chunks, 9u);
  w.FlushIfDue(909'000'000 + 100'000'000 - 1);
  EXPECT_EQ(w.stats().chunks, 9u);  // oldest open message not yet 100 ms old
  w.FlushIfDue(909'000'000 + 100'000'000);
  EXPECT_EQ(w.stats().chunks, 10u);
  w.Close();
}

// Sets every field of a message to a non-default value that differs from field to field.
void FillEveryField(gp::Message& m, int& counter) {
  const gp::Descriptor* d = m.GetDescriptor();
  const gp::Reflection* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* f = d->field(i);
    const int n = f->is_repeated() ? 3 : 1;
    for (int k = 0; k < n; ++k) {
      ++counter;
      switch (f->cpp_type()) {
        case gp::FieldDescriptor::CPPTYPE_MESSAGE:
          FillEveryField(f->is_repeated() ? *r->AddMessage(&m, f) : *r->MutableMessage(&m, f),
                         counter);
          break;
        case gp::FieldDescriptor::CPPTYPE_DOUBLE:
          f->is_repeated() ? r->AddDouble(&m, f, counter * 1.25) : r->SetDouble(&m, f, counter * 1.25);
          break;
        case gp::FieldDescriptor::CPPTYPE_UINT64:
          f->is_repeated() ? r->AddUInt64(&m, f, counter + (1ull << 40))
                           : r->SetUInt64(&m, f, counter + (1ull << 40));
          break;
        case gp::FieldDescriptor::CPPTYPE_INT64:
          r->SetInt64(&m, f, -static_cast<int64_t>(counter) * 1'000'000'007);
          break;
        case gp::FieldDescriptor::CPPTYPE_UINT32: r->SetUInt32(&m, f, counter % 250 + 1); break;
        case gp::FieldDescriptor::CPPTYPE_INT32:
          f->is_repeated() ? r->AddInt32(&m, f, -(counter % 100) - 1)
                           : r->SetInt32(&m, f, -(counter % 100) - 1);
          break;
        case gp::FieldDescriptor::CPPTYPE_BOOL: r->SetBool(&m, f, true); break;
        case gp::FieldDescriptor::CPPTYPE_ENUM:
          r->SetEnum(&m, f, f->enum_type()->value(f->enum_type()->value_count() - 1));
          break;
        case gp::FieldDescriptor::CPPTYPE_STRING:
          r->SetString(&m, f, "s," + std::to_string(counter) + "\"q\"");
          break;
        default: FAIL() << "unhandled field type in " << f->full_name();
      }
    }
  }
}

TEST(McapFile, EveryRecordingTypeRoundTripsWithEveryField) {
  const fs::path dir = TempDir();
  const std::string path = dir / "types.mcap";
  std::vector<std::unique_ptr<gp::Message>> sent;
  const gp::FileDescriptor* file = rec::LegSensors::descriptor()->file();
  {
    RecordingWriter w;
    w.Open(path);
    int counter = 0;
    for (int i = 0; i < file->message_type_count(); ++i) {
      const gp::Descriptor* d = file->message_type(i);
      const gp::Message* proto = gp::MessageFactory::generated_factory()->GetPrototype(d);
      std::unique_ptr<gp::Message> m(proto->New());
      FillEveryField(*m, counter);
      const uint16_t ch = w.AddTopic("t_" + d->name(), *d, {});
      w.Write(ch, 10 + i, 5 + i, *m);
      sent.push_back(std::move(m));
    }
    w.Close();
  }
  ASSERT_EQ(sent.size(), 11u);  // SampleHeader + the ten published types
  size_t i = 0;
  const McapScanResult r = ReadRecording(
      path, [&](const McapChannel& ch, const McapMessageView& view, const gp::Message& decoded) {
        ASSERT_LT(i, sent.size());
        // Decoded with the schema embedded in the file (a DynamicMessage), then compared with
        // what was sent through the compiled type.
        EXPECT_EQ(decoded.GetDescriptor()->full_name(), sent[i]->GetDescriptor()->full_name());
        EXPECT_NE(decoded.GetDescriptor(), sent[i]->GetDescriptor());
        std::unique_ptr<gp::Message> back(sent[i]->New());
        ASSERT_TRUE(back->ParseFromString(decoded.SerializeAsString()));
        EXPECT_TRUE(gp::util::MessageDifferencer::Equals(*back, *sent[i]))
            << ch.topic << "\n" << back->DebugString() << "\nvs\n" << sent[i]->DebugString();
        EXPECT_EQ(view.log_time_ns, 10 + i);
        EXPECT_EQ(view.publish_time_ns, 5 + i);
        ++i;
      });
  EXPECT_TRUE(r.complete);
  EXPECT_EQ(i, sent.size());
}

// kill -9 of a writing process: the file has no summary and no footer, yet every chunk flushed
// before the kill is readable, and recover makes a complete file of it.
TEST(CrashSafety, FileIsReadableUpToTheLastFlushAfterKill9AndRecoverCompletesIt) {
  const fs::path dir = TempDir();
  const std::string path = dir / "crash.mcap";
  constexpr uint64_t kPerChunk = 50;
  int pipe_fd[2];
  ASSERT_EQ(::pipe(pipe_fd), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(pipe_fd[0]);
    McapWriterConfig cfg;
    cfg.chunk_max_messages = kPerChunk;
    cfg.sync = McapSyncMode::kFflush;
    RecordingWriter w(cfg);
    w.Open(path);
    const uint16_t ch = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(),
                                   {{kMetaPeriodS, "0.001"}});
    rec::LegSensors s;
    uint64_t last_chunks = 0;
    for (uint64_t tick = 1;; ++tick) {  // runs until killed
      s.set_leg_id(1);
      test::FillHeader(s.mutable_header(), tick);
      s.set_length_m(0.5);
      w.Write(ch, tick * 1'000'000, tick * 1'000'000, s);
      if (w.mcap().stats().chunks != last_chunks) {
        last_chunks = w.mcap().stats().chunks;
        const uint64_t flushed = tick;  // every message so far is in a flushed chunk
        if (::write(pipe_fd[1], &flushed, sizeof flushed) != sizeof flushed) _exit(3);
      }
      if (tick % kPerChunk == 0) ::usleep(200);
    }
  }
  ::close(pipe_fd[1]);
  uint64_t flushed = 0;
  while (flushed < 40 * kPerChunk) {
    ASSERT_EQ(::read(pipe_fd[0], &flushed, sizeof flushed), static_cast<ssize_t>(sizeof flushed));
  }
  ASSERT_EQ(::kill(child, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  ::close(pipe_fd[0]);

  // Strict reading refuses the file and says why.
  try {
    Inspect(path);
    ADD_FAILURE() << "a file without footer must not read as complete";
  } catch (const McapError& e) {
    EXPECT_NE(std::string(e.what()).find("recover"), std::string::npos) << e.what();
  }
  // Tolerant reading gets every flushed message, in order, and only whole chunks.
  McapScanOptions tolerant;
  tolerant.tolerant = true;
  uint64_t n = 0;
  const McapScanResult r = ReadRecording(
      path,
      [&](const McapChannel&, const McapMessageView& m, const gp::Message& msg) {
        EXPECT_EQ(m.sequence, n);
        EXPECT_EQ(MessageTick(msg).value_or(0), n + 1);
        ++n;
      },
      tolerant);
  EXPECT_FALSE(r.complete);
  EXPECT_GE(n, flushed);
  EXPECT_EQ(n % kPerChunk, 0u);
  EXPECT_EQ(n, r.messages);

  const RecoverResult rec = Recover(path, dir / "fixed.mcap");
  EXPECT_FALSE(rec.input_complete);
  EXPECT_EQ(rec.messages, n);
  const RecordingInfo info = Inspect(dir / "fixed.mcap");  // strict: must be complete now
  EXPECT_TRUE(info.complete);
  EXPECT_EQ(info.messages, n);
  ASSERT_EQ(info.channels.size(), 1u);
  EXPECT_EQ(info.channels[0].missing, 0u);
  EXPECT_EQ(info.channels[0].streams[0].last_tick, n);
}

}  // namespace
}  // namespace hexa::recorder
