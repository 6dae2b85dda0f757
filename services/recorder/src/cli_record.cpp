// hexa_recorder record: subscribes to every topic of the system (or a subset) and writes each
// sample as protobuf to an MCAP file, with the 3-D scene; per topic the loss seen from tick
// numbers at the end. The DDS side of a topic is topic_recorder.hpp's.
#include <time.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli.hpp"
#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/comm/writer.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/rotation.hpp"
#include "hexa/recording/scene.hpp"
#include "hexa/recording/topic_types.hpp"
#include "hexa/services/runtime.hpp"
#include "hexa/services/scheduling.hpp"
#include "hexa/services/service_manager.hpp"
#include "topic_recorder.hpp"

namespace hexa::recorder::cli {
namespace {

constexpr const char* kRecordHelp =
        "usage: hexa_recorder record --output FILE.mcap [--domain N] [--topics GLOB,..]\n"
        "                            [--exclude GLOB,..] [--duration-s S] [--flush-ms MS]\n"
        "                            [--batch-ms MS] [--sync none|fflush|fdatasync]\n"
        "                            [--dds-config FILE.xml] [--rt-priority N] [--cpus LIST]\n"
        "                            [--compression none|zstd]\n"
        "                            [--periodic-reliability reliable|best-effort]\n"
        "                            [--split-size-mb MB] [--split-duration-s S] [--keep-files N]\n"
        "Subscribes to every topic of the system (reliable, keep-all recorder QoS) or the ones\n"
        "matching --topics, and writes each sample as protobuf to one MCAP channel per topic\n"
        "(log time = when taken from DDS, within --batch-ms of receipt; publish time = the\n"
        "sample's source_time_ns). Chunks are closed\n"
        "and synced every --flush-ms (default 100): a kill -9 loses at most that much.\n"
        "The DDS samples wait in the readers and are taken in batches at most every --batch-ms\n"
        "(default 2; 0 = on every arrival): one wake-up per batch instead of per sample.\n"
        "fdatasync (the default --sync) runs on a background thread.\n"
        "Chunks are zstd-compressed (libzstd, --zstd-level 1..19, default 3) unless\n"
        "--compression none.\n"
        "Stops after --duration-s or on SIGINT/SIGTERM, then prints per topic the samples\n"
        "received and the loss seen from tick numbers, and every writer matched\n"
        "(\"matched writer TOPIC GUID RELIABILITY [strength N]\", the GUID as on the wire).\n"
        "--rt-priority N: SCHED_FIFO at N (1..98) + mlockall, for real-time sessions whose\n"
        "control processes run SCHED_FIFO (a SCHED_OTHER recorder beside them is starved);\n"
        "--cpus LIST pins it (e.g. 0): both before DDS starts, so Cyclone's threads inherit.\n"
        "--periodic-reliability best-effort: the periodic topics (1 kHz and 200 Hz) are read\n"
        "best effort, as the real-time controllers read them and as real-time writers offer\n"
        "them: no control writer repairs what the recorder's link drops (a lossy, slow or\n"
        "cut-off recorder costs the loop nothing); a dropped sample is missing in the recording\n"
        "and counted per topic, and per producer and tick as loss events (one per lost batch).\n"
        "For real-time sessions (hexa_session and hexa_deploy pass it); default reliable\n"
        "(lockstep: the plant waits for the recorder and nothing is lost). A reliable recorder\n"
        "does not match a real-time session's periodic writers (they offer BEST_EFFORT): it\n"
        "says so per topic on stderr (incompatible QoS, policy RELIABILITY) and exits with an\n"
        "error when a periodic topic recorded nothing for that reason.\n"
        "topics: hexa_LegSensors hexa_ValveCommand hexa_ImuSample hexa_LegSetpoint\n"
        "        hexa_PoseReport hexa_GroundTruth hexa_TrackerPose hexa_OperatorCommand\n"
        "        hexa_NodeStatus hexa_FaultEvent\n"
        "--split-size-mb MB / --split-duration-s S: close the file when it reaches MB megabytes\n"
        "(10^6 bytes) or S seconds and go on in a new one; the open file keeps the --output\n"
        "name, the closed parts become NAME-0001.mcap, NAME-0002.mcap, ... (each a complete\n"
        "MCAP file). --keep-files N: keep at most N files in all (the open one included),\n"
        "deleting the oldest parts (default: all).\n"
        "  --no-scene          do not add the 3-D scene\n";

McapSyncMode ParseSync(const std::string& s) {
  if (s == "none") return McapSyncMode::kNone;
  if (s == "fflush") return McapSyncMode::kFflush;
  if (s == "fdatasync") return McapSyncMode::kFdatasync;
  throw UsageError("--sync must be none, fflush or fdatasync, got '" + s + "'");
}

struct RecordOptions {
  std::string out;
  double duration_s = 0.0, flush_ms = 100.0, batch_ms = 2.0;
  TopicFilter filter;
  bool quiet = false;
  long long rt_priority = 0;
  std::vector<int> cpus;
  RotationConfig rotation;
  long long keep_files = 0;
  McapWriterConfig mcap;
  std::string periodic;  // --periodic-reliability
  bool scene = true;
};

RotationConfig ParseRotation(const Args& a) {
  RotationConfig rotation_config;
  const double split_mb = a.GetDouble("split-size-mb", 0.0);
  const double split_s = a.GetDouble("split-duration-s", 0.0);
  const long long keep_files = a.GetInt("keep-files", 0);
  if (!(split_mb >= 0.0 && split_mb <= 1e7)) throw UsageError("--split-size-mb must be in [0, 1e7]");
  if (!(split_s >= 0.0 && split_s <= 1e7)) throw UsageError("--split-duration-s must be in [0, 1e7]");
  if (keep_files < 0 || keep_files > 1000000) throw UsageError("--keep-files must be in [0, 1000000]");
  rotation_config.split_bytes = static_cast<uint64_t>(split_mb * 1e6);
  rotation_config.split_ns = static_cast<uint64_t>(split_s * 1e9);
  rotation_config.keep_files = static_cast<uint32_t>(keep_files);
  if (keep_files > 0 && !rotation_config.enabled())
    throw UsageError("--keep-files needs --split-size-mb or --split-duration-s");
  return rotation_config;
}

RecordOptions ParseRecordOptions(const Args& a) {
  RecordOptions o;
  if (!a.positional.empty()) throw UsageError("unexpected argument '" + a.positional[0] + "'");
  o.out = a.Get("output", a.Get("o", ""));
  if (o.out.empty()) throw UsageError("--output FILE is required");
  o.duration_s = a.GetDouble("duration-s", 0.0);
  if (!(o.duration_s >= 0.0)) throw UsageError("--duration-s must be >= 0");
  o.flush_ms = a.GetDouble("flush-ms", 100.0);
  if (!(o.flush_ms >= 1.0 && o.flush_ms <= 60000.0))
    throw UsageError("--flush-ms must be in [1, 60000]");
  o.batch_ms = a.GetDouble("batch-ms", 2.0);
  if (!(o.batch_ms >= 0.0 && o.batch_ms <= o.flush_ms))
    throw UsageError("--batch-ms must be in [0, --flush-ms]");
  o.filter = TopicFilter{a.GetAll("topics"), a.GetAll("exclude")};
  o.quiet = a.Has("quiet");
  o.rt_priority = a.GetInt("rt-priority", 0);
  if (o.rt_priority < 0 || o.rt_priority > 98) throw UsageError("--rt-priority must be in [0, 98]");
  if (a.Has("cpus") && !sched::ParseCpuList(a.Get("cpus", ""), o.cpus))
    throw UsageError("--cpus '" + a.Get("cpus", "") + "': expected CPU numbers such as 1, 0,1 or 0-1");
  o.rotation = ParseRotation(a);
  o.keep_files = a.GetInt("keep-files", 0);
  o.mcap.chunk_max_span_ns = static_cast<uint64_t>(o.flush_ms * 1e6);
  o.mcap.sync = ParseSync(a.Get("sync", "fdatasync"));
  o.mcap.compression = ParseCompressionOption(a);
  o.mcap.zstd_level = ParseZstdLevelOption(a);
  o.periodic = a.Get("periodic-reliability", "reliable");
  if (o.periodic != "reliable" && o.periodic != "best-effort")
    throw UsageError("--periodic-reliability must be reliable or best-effort, got '" + o.periodic + "'");
  o.scene = !a.Has("no-scene");
  return o;
}

// CPU affinity and SCHED_FIFO before the participant: Cyclone's threads inherit both.
void ApplyScheduling(const RecordOptions& o) {
  std::string sched_message;
  if (!o.cpus.empty()) {
    sched::SetCpuAffinity(o.cpus, sched_message);
    if (!o.quiet) std::fprintf(stderr, "record: %s\n", sched_message.c_str());
  }
  if (o.rt_priority > 0) {
    sched::SetRealtime(static_cast<int>(o.rt_priority), sched_message);
    if (!o.quiet) std::fprintf(stderr, "record: %s\n", sched_message.c_str());
  }
}

// The session key (HEXA_SESSION_KEY, set by hexa_session and the generated units): command
// samples of writers without it are not recorded. Without a key every sample is.
void InstallSessionKeyFromEnvironment() {
  if (const char* key_path = std::getenv(comm::kSessionKeyEnvironment); key_path != nullptr && *key_path) {
    std::string error;
    const auto key = comm::ReadSessionKey(key_path, error);
    if (!key) throw std::runtime_error(error + " (" + comm::kSessionKeyEnvironment + ")");
    comm::InstallSessionKey(*key);
  }
}

using TopicRecorders = std::vector<std::unique_ptr<TopicRecorderBase>>;

TopicRecorders MakeTopicRecorders(const comm::Participant& participant, RecordingWriter& writer,
                                  const RecordOptions& o) {
  comm::QosParams params;
  params.recorder_periodic_best_effort = o.periodic == "best-effort";
  // The writers this recorder matches (their QoS goes into each channel's metadata): the
  // real-time ones with best-effort, else the lockstep ones.
  params.lockstep = !params.recorder_periodic_best_effort;
  TopicRecorders topics;
  ForEachTopicType([&](auto topic_type) {
    using T = typename decltype(topic_type)::Dds;
    using P = typename decltype(topic_type)::Proto;
    if (!o.filter.Matches(std::string(comm::TopicName(comm::TopicTraits<T>::kKind)))) return;
    topics.push_back(std::make_unique<TopicRecorder<T, P>>(participant, writer, params));
  });
  if (topics.empty()) throw UsageError("--topics/--exclude leave no topic to record");
  return topics;
}

// The 3-D scene (docs/foxglove.md): fed with every recorded sample, written when due.
struct SceneRecording {
  std::unique_ptr<SceneBuilder> scene;
  std::unique_ptr<SceneChannels> channels;
};

void AttachScene(const Args& a, RecordingWriter& writer, TopicRecorders& topics, SceneRecording& s) {
  s.scene = std::make_unique<SceneBuilder>(SceneOptionsFromArgs(a));
  s.channels = std::make_unique<SceneChannels>(writer, s.scene->options());
  for (auto& t : topics) {
    t->on_sample = [&s](const google::protobuf::Message& m) {
      if (!s.scene->Add(m)) return;
      const auto now = static_cast<uint64_t>(comm::RealtimeNow_ns());
      s.scene->Build(now);
      s.channels->Write(now, *s.scene);
    };
  }
}

// The record loop: takes samples in batches, flushes (and rotates) the file when due, says
// what does not match and prints progress, until --duration-s or a stop.
class RecordLoop {
 public:
  RecordLoop(const RecordOptions& o, RecordingWriter& writer, TopicRecorders& topics,
             comm::WaitSet& waitset, const comm::ShutdownGuard& shutdown, int64_t start_ns,
             RecordingRotation& rotation)
      : o_(o), writer_(writer), topics_(topics), waitset_(waitset), shutdown_(shutdown),
        rotation_(rotation), start_ns_(start_ns),
        end_ns_(o.duration_s > 0 ? start_ns + static_cast<int64_t>(o.duration_s * 1e9) : INT64_MAX),
        flush_ns_(static_cast<int64_t>(o.flush_ms * 1e6)),
        batch_ns_(static_cast<int64_t>(o.batch_ms * 1e6)),
        next_flush_ns_(start_ns + flush_ns_),
        next_progress_ns_(start_ns + kProgressPeriodNs) {}

  void Run() {
    while (!shutdown_.requested()) {
      node::service_manager::Watchdog();
      const int64_t now = comm::RealtimeNow_ns();
      if (now >= end_ns_) break;
      // Wake on data, on shutdown, or when the open chunk is due to be flushed.
      const int64_t wake = std::min(end_ns_, next_flush_ns_);
      const dds_return_t rc = waitset_.WaitUntil(static_cast<dds_time_t>(wake));
      if (rc < 0) throw std::runtime_error("waitset failed: " + std::string(dds_strretcode(rc)));
      for (dds_attach_t token : waitset_.triggered()) {
        if (token > 0) topics_[static_cast<size_t>(token - 1)]->Drain(writer_);
      }
      const int64_t after = comm::RealtimeNow_ns();
      if (after >= next_flush_ns_) OnFlushDue(after);
      // Let samples accumulate in the readers (keep-all) before the next take: at 1 kHz x 13
      // streams a wake-up per sample costs more CPU than recording the sample.
      const int64_t pause_ns = std::min({batch_ns_, end_ns_ - after, next_flush_ns_ - after});
      if (pause_ns > 0) {
        const timespec pause{static_cast<time_t>(pause_ns / 1'000'000'000),
                             static_cast<long>(pause_ns % 1'000'000'000)};
        nanosleep(&pause, nullptr);  // a signal ends it early; the loop then sees the shutdown
      }
    }
  }

 private:
  // A progress line every second of wall time on stderr (hexa_session shows the newest one).
  static constexpr int64_t kProgressPeriodNs = 1'000'000'000;

  void OnFlushDue(int64_t after) {
    writer_.mcap().FlushIfDue(static_cast<uint64_t>(after));
    next_flush_ns_ = after + flush_ns_;
    if (o_.rotation.enabled() && rotation_.Due(writer_.mcap(), static_cast<uint64_t>(after))) {
      const std::size_t deleted_before = rotation_.deleted().size();
      rotation_.Rotate(writer_.mcap(), static_cast<uint64_t>(after));
      if (!o_.quiet) {
        std::fprintf(stderr, "record: closed %s, recording on in %s\n",
                     rotation_.parts().back().c_str(), o_.out.c_str());
        for (std::size_t k = deleted_before; k < rotation_.deleted().size(); ++k)
          std::fprintf(stderr, "record: deleted %s (--keep-files %lld)\n",
                       rotation_.deleted()[k].c_str(), o_.keep_files);
      }
    }
    for (auto& t : topics_) {
      ReportIncompatibleWriters(*t, o_.periodic);
      NoteMatchedWriters(*t);
    }
    if (!o_.quiet && after >= next_progress_ns_) {
      uint64_t tick = 0, messages = 0;
      for (const auto& t : topics_) {
        tick = std::max(tick, t->last_tick);
        messages += t->received;
      }
      std::fprintf(stderr, "record: progress: %.1f s simulated (tick %" PRIu64 "), %.0f s wall, %" PRIu64
                   " messages\n", static_cast<double>(tick) * kPlantTick_s,
                   tick, static_cast<double>(after - start_ns_) * 1e-9, messages);
      next_progress_ns_ = after + kProgressPeriodNs;
    }
  }

  const RecordOptions& o_;
  RecordingWriter& writer_;
  TopicRecorders& topics_;
  comm::WaitSet& waitset_;
  const comm::ShutdownGuard& shutdown_;
  RecordingRotation& rotation_;
  const int64_t start_ns_, end_ns_, flush_ns_, batch_ns_;
  int64_t next_flush_ns_, next_progress_ns_;
};

// The per-topic table: samples received, loss from tick numbers and DDS's own counters; the
// periodic topics that recorded nothing because no writer matched.
std::vector<std::string> PrintTopicTable(const RecordOptions& o, const TopicRecorders& topics,
                                         LossEventCounter& events) {
  // incompatible: writers refused for their QoS, partition mismatches (by design) left out.
  std::printf("%-22s %10s %10s %8s %12s %12s %12s\n", "topic", "received", "missing", "gaps",
              "dds_lost", "dds_rejected", "incompatible");
  std::vector<std::string> unmatched;  // periodic topics with nothing recorded and a writer refused
  for (const auto& t : topics) {
    ReportIncompatibleWriters(*t, o.periodic);
    uint64_t missing = 0, gaps = 0;
    for (const auto& l : t->loss.Results()) {
      missing += l.missing;
      gaps += l.gaps;
    }
    if (t->periodic) events.AddTopic(t->name, t->loss.MissingTicks());
    const comm::StatusSnapshot st = t->Status();
    std::printf("%-22s %10" PRIu64 " %10s %8s %12u %12u %12u\n", t->name.c_str(), t->received,
                t->periodic ? std::to_string(missing).c_str() : "-",
                t->periodic ? std::to_string(gaps).c_str() : "-", st.sample_lost_total,
                st.sample_rejected_total, st.requested_incompatible_qos_not_partition_total);
    if (t->periodic && t->received == 0 && st.requested_incompatible_qos_not_partition_total > 0)
      unmatched.push_back(t->name);
  }
  return unmatched;
}

int PrintRecordSummary(const RecordOptions& o, RecordingWriter& writer, const TopicRecorders& topics,
                       const RecordingRotation& rotation, int64_t start_ns) {
  const double elapsed_s = static_cast<double>(comm::RealtimeNow_ns() - start_ns) * 1e-9;
  const McapWriterStats& ws = writer.mcap().stats();
  std::printf("recorded %.3f s to %s: %" PRIu64 " messages, %" PRIu64 " chunks, %" PRIu64
              " bytes (chunk records %" PRIu64 " bytes, stored %" PRIu64 ", compression %s)\n",
              elapsed_s, o.out.c_str(), ws.messages, ws.chunks, ws.bytes, ws.chunk_records_bytes,
              ws.chunk_stored_bytes, o.mcap.compression == McapCompression::kZstd ? "zstd" : "none");
  if (o.rotation.enabled())
    std::printf("split into parts: %zu closed part(s) kept beside %s, %zu deleted (--keep-files)\n",
                rotation.parts().size(), o.out.c_str(), rotation.deleted().size());
  LossEventCounter events;
  const std::vector<std::string> unmatched = PrintTopicTable(o, topics, events);
  // One event per producer and tick with a loss: comparable with the datagrams a link
  // dropped (one batch of a producer per tick), where a sample count is not.
  const LossEvents e = events.Finish();
  std::printf("loss events (producer x tick with samples missing, one per lost batch): %" PRIu64
              " for %" PRIu64 " missing samples;",
              e.total_events, e.total_samples);
  for (const auto& [producer, n] : e.events)
    std::printf(" %s %" PRIu64 " (%" PRIu64 " samples)", producer.c_str(), n, e.samples.at(producer));
  std::printf("\n");
  // Command samples of writers not of this session: not recorded (docs/faults.md).
  for (const auto& t : topics)
    if (t->refused > 0)
      std::printf("refused %s: %" PRIu64 " samples from writers not of this session (not recorded)\n",
                  t->name.c_str(), t->refused);
  // The writers each topic matched, by GUID as on the wire: a capture of the datagrams a link
  // dropped names the writer of each DATA submessage (bench/deployment/dropped_datagrams.py).
  for (const auto& t : topics)
    for (const auto& [guid, reliability] : t->matched_writers)
      std::printf("matched writer %s %s %s\n", t->name.c_str(), guid.c_str(), reliability.c_str());
  if (!unmatched.empty()) {
    std::string names;
    for (const auto& n : unmatched) names += " " + n;
    std::fprintf(stderr,
                 "record: error: nothing recorded on%s: their writers did not match this recorder's "
                 "QoS (see the messages above)\n",
                 names.c_str());
    return kExitError;
  }
  return kExitOk;
}

}  // namespace

int RunRecord(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv,
                           {"output", "o", "domain", "topics", "exclude", "duration-s", "flush-ms",
                            "batch-ms", "sync", "dds-config", "rt-priority", "cpus",
                            "compression", "zstd-level", "rig", "profile", "seed", "scene-hz",
                            "periodic-reliability", "split-size-mb", "split-duration-s",
                            "keep-files"},
                           {"quiet", "no-scene"});
  if (a.help) {
    std::fputs(kRecordHelp, stdout);
    std::fputs(kSceneOptionsHelp, stdout);
    return kExitOk;
  }
  const RecordOptions o = ParseRecordOptions(a);
  ApplyScheduling(o);
  std::optional<std::string> dds_config;
  if (a.Has("dds-config")) dds_config = a.Get("dds-config", "");
  comm::EnsureDdsConfig(dds_config);
  InstallSessionKeyFromEnvironment();
  // The service runtime: participant, shutdown guard, and the lifecycle with its NodeStatus.
  node::CommonOptions common;
  common.domain_id = static_cast<int>(ParseDomain(a));
  services::Runtime runtime(common, "recorder", spdlog::default_logger());
  const comm::Participant& participant = runtime.participant();
  RecordingWriter writer(o.mcap);
  writer.Open(o.out);
  TopicRecorders topics = MakeTopicRecorders(participant, writer, o);
  SceneRecording scene;
  if (o.scene) AttachScene(a, writer, topics, scene);
  comm::WaitSet waitset(participant, topics.size() + 1);
  waitset.Attach(runtime.shutdown().guard_condition(), 0);
  for (size_t i = 0; i < topics.size(); ++i)
    waitset.Attach(topics[i]->condition(), static_cast<dds_attach_t>(i + 1));
  writer.mcap().FlushChunk();  // header, schemas and channels reach the disk before any data
  // Announce ourselves: the plant waits for a RUNNING recorder before its first tick when a
  // session asks for one (docs/architecture.md), so nothing is missed at the start. The
  // recorder waits for no one: its readers take whatever comes.
  char detail[64];
  std::snprintf(detail, sizeof detail, "recording %zu topics", topics.size());
  runtime.NoPeersToWaitFor();
  runtime.Running({}, detail, detail);
  if (!o.quiet)
    std::fprintf(stderr, "record: domain %d, %zu topics -> %s (periodic topics %s)\n",
                 static_cast<int>(participant.domain_id()), topics.size(), o.out.c_str(), o.periodic.c_str());

  const int64_t start_ns = comm::RealtimeNow_ns();
  RecordingRotation rotation(o.rotation, o.out, static_cast<uint64_t>(start_ns));
  RecordLoop(o, writer, topics, waitset, runtime.shutdown(), start_ns, rotation).Run();
  for (auto& t : topics) {
    t->Drain(writer);  // what arrived before the stop
    NoteMatchedWriters(*t);
  }
  runtime.Stop({}, detail, "recording closed");
  writer.Close();
  return PrintRecordSummary(o, writer, topics, rotation, start_ns);
}

}  // namespace hexa::recorder::cli
