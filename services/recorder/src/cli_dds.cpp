// DDS subcommands of hexa_recorder: record and play, through the comm layer (RAII participant,
// topics, readers, writers, named QoS profiles, shutdown guard). Conversion DDS <-> protobuf
// is convert.cpp's; this file only moves samples.
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "cli.hpp"
#include "hexa/comm/comm.hpp"
#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/reader.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/comm/writer.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/recording/rotation.hpp"
#include "hexa/recording/scene.hpp"
#include "hexa/services/scheduling.hpp"
#include "hexa/services/service_manager.hpp"

namespace hexa::recorder::cli {
namespace {

template <typename T, typename P>
struct Pair {
  using Dds = T;
  using Proto = P;
};

// Every published wire type with its recording message.
template <typename F>
void ForEachTopicType(F&& f) {
  f(Pair<hexa_msg_LegSensors, rec::LegSensors>{});
  f(Pair<hexa_msg_ValveCommand, rec::ValveCommand>{});
  f(Pair<hexa_msg_ImuSample, rec::ImuSample>{});
  f(Pair<hexa_msg_LegSetpoint, rec::LegSetpoint>{});
  f(Pair<hexa_msg_PoseReport, rec::PoseReport>{});
  f(Pair<hexa_msg_GroundTruth, rec::GroundTruth>{});
  f(Pair<hexa_msg_TrackerPose, rec::TrackerPose>{});
  f(Pair<hexa_msg_OperatorCommand, rec::OperatorCommand>{});
  f(Pair<hexa_msg_NodeStatus, rec::NodeStatus>{});
  f(Pair<hexa_msg_FaultEvent, rec::FaultEvent>{});
}

template <typename T>
int64_t SourceTime_ns(const T& s) {
  if constexpr (requires { s.header.source_time_ns; }) {
    return s.header.source_time_ns;
  } else {
    return s.source_time_ns;
  }
}

std::string DurationText(dds_duration_t d) {
  return d >= DDS_INFINITY ? "infinite" : std::to_string(d);
}

// The QoS a profile gives, as channel metadata ("qos.writer.reliability" = "reliable", ...).
void DescribeQos(const dds_qos_t* q, const std::string& prefix,
                 std::map<std::string, std::string>& out) {
  dds_reliability_kind_t rel;
  dds_duration_t blocking;
  if (dds_qget_reliability(q, &rel, &blocking))
    out[prefix + "reliability"] = rel == DDS_RELIABILITY_RELIABLE ? "reliable" : "best_effort";
  dds_history_kind_t hist;
  int32_t depth;
  if (dds_qget_history(q, &hist, &depth))
    out[prefix + "history"] =
        hist == DDS_HISTORY_KEEP_ALL ? "keep_all" : "keep_last " + std::to_string(depth);
  dds_durability_kind_t dur;
  if (dds_qget_durability(q, &dur))
    out[prefix + "durability"] = dur == DDS_DURABILITY_TRANSIENT_LOCAL ? "transient_local"
                                 : dur == DDS_DURABILITY_VOLATILE      ? "volatile"
                                                                       : "other";
  dds_duration_t deadline;
  if (dds_qget_deadline(q, &deadline)) out[prefix + "deadline_ns"] = DurationText(deadline);
  dds_liveliness_kind_t live;
  dds_duration_t lease;
  if (dds_qget_liveliness(q, &live, &lease))
    out[prefix + "liveliness"] =
        std::string(live == DDS_LIVELINESS_AUTOMATIC ? "automatic" : "manual_by_topic") +
        " lease_ns " + DurationText(lease);
  dds_ownership_kind_t own;
  if (dds_qget_ownership(q, &own))
    out[prefix + "ownership"] = own == DDS_OWNERSHIP_EXCLUSIVE ? "exclusive" : "shared";
}

// ------------------------------------------------------------------------------- record

struct TopicRecorderBase {
  virtual ~TopicRecorderBase() = default;
  virtual dds_entity_t condition() const = 0;
  virtual void Drain(RecordingWriter& w) = 0;
  virtual comm::StatusSnapshot Status() const = 0;
  // The reader, for its matched writers (NoteMatchedWriters).
  virtual dds_entity_t reader() const = 0;
  std::string name;
  uint16_t channel = 0;
  bool periodic = false;
  uint64_t received = 0;
  uint64_t refused = 0;  // command samples not authenticated with the session key
  uint64_t last_tick = 0;  // newest header.tick received (progress lines)
  TickLossTracker loss;
  // Writers this topic's reader could not match (incompatible QoS), as last reported.
  uint32_t incompatible_reported = 0;
  // Every writer this topic's reader has matched so far: GUID (32 hex digits, as on the
  // wire: GUID prefix then entity id) -> "reliable" / "best-effort" and, under exclusive
  // ownership, " strength N". Printed at the stop, so that the datagrams a link
  // dropped can be attributed to topics (bench/deployment/dropped_datagrams.py).
  std::map<std::string, std::string> matched_writers;
  // Called with each recorded message (play --answers-out watches the answers through it).
  std::function<void(const google::protobuf::Message&)> on_sample;
};

template <typename T, typename P>
class TopicRecorder final : public TopicRecorderBase {
 public:
  static constexpr std::size_t kCapacity = 256;
  // The leg controllers write ValveCommand in their leg's partition (docs/security.md, DDS
  // Security): the recorder subscribes to every leg partition and the default one.
  static std::vector<std::string> Partitions() {
    if constexpr (comm::TopicTraits<T>::kKind != comm::TopicKind::kValveCommand) return {};
    return comm::EveryLegPartitionAndDefault();
  }
  TopicRecorder(const comm::Participant& p, RecordingWriter& w, const comm::QosParams& params)
      : topic_(p),
        reader_(p, topic_, comm::EndpointRole::kRecorderReader, params, kCapacity, Partitions()) {
    const comm::TopicKind kind = comm::TopicTraits<T>::kKind;
    name = std::string(comm::TopicName(kind));
    const std::optional<double> period = comm::NominalPeriod_s(kind);
    periodic = period.has_value();
    std::map<std::string, std::string> meta;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", period.value_or(0.0));
    meta[kMetaPeriodS] = buf;
    meta["dds.topic"] = name;
    meta["dds.type"] = comm::TopicTraits<T>::Descriptor()->m_typename;
    DescribeQos(comm::MakeQos(kind, comm::EndpointRole::kWriter, params).get(), "qos.writer.", meta);
    DescribeQos(comm::MakeQos(kind, comm::EndpointRole::kRecorderReader, params).get(),
                "qos.recorder.", meta);
    channel = w.AddTopic(name, *P::descriptor(), std::move(meta));
  }
  dds_entity_t condition() const override { return reader_.data_condition(); }
  comm::StatusSnapshot Status() const override { return reader_.Snapshot(); }
  dds_entity_t reader() const override { return reader_.get(); }
  void Drain(RecordingWriter& w) override {
    for (;;) {
      const int n = reader_.Take();
      if (n <= 0) return;
      // Log time = when this batch was taken: at most --batch-ms after Cyclone received the
      // sample (Cyclone 0.10's sample info has no reception timestamp).
      const uint64_t log_ns = static_cast<uint64_t>(comm::RealtimeNow_ns());
      for (int i = 0; i < n; ++i) {
        if (!reader_.info(i).valid_data) continue;  // dispose / unregister: no sample
        // A command from a writer not of this session is not part of it (docs/faults.md,
        // "Foreign commands"): the plant and the legs refuse it, the recording leaves it out.
        if constexpr (comm::CommandType<T>) {
          if (!comm::Trusted(reader_.Authenticate(static_cast<std::size_t>(i)))) {
            ++refused;
            continue;
          }
        }
        const T& s = reader_.sample(i);
        ToProto(s, msg_);
        w.Write(channel, log_ns, static_cast<uint64_t>(SourceTime_ns(s)), msg_);
        ++received;
        if (on_sample) on_sample(msg_);
        if constexpr (requires { s.header.tick; }) {  // every periodic topic has a header
          if (periodic) loss.AddAt(StreamOf(s), s.header.tick);
          last_tick = std::max<uint64_t>(last_tick, s.header.tick);
        }
      }
      if (static_cast<std::size_t>(n) < kCapacity) return;
    }
  }

 private:
  // Loss-tracker stream of a sample: keyed by leg for the leg topics, one stream otherwise
  // (the keys MessageKey gives the recorded message, looked up once per key, no reflection).
  std::size_t StreamOf(const T& s) {
    std::size_t slot = kKeylessSlot;
    if constexpr (requires { s.leg_id; }) slot = s.leg_id;
    std::optional<std::size_t>& index = stream_of_key_[slot];
    if (!index) {
      index = loss.StreamIndex(slot == kKeylessSlot
                                   ? std::string()
                                   : LegStreamKey(static_cast<uint32_t>(slot)));
    }
    return *index;
  }

  comm::Topic<T> topic_;
  comm::Reader<T> reader_;
  P msg_;
  static constexpr std::size_t kKeylessSlot = 256;  // leg_id is a uint8_t
  std::array<std::optional<std::size_t>, kKeylessSlot + 1> stream_of_key_{};  // [leg_id]
};

McapSyncMode ParseSync(const std::string& s) {
  if (s == "none") return McapSyncMode::kNone;
  if (s == "fflush") return McapSyncMode::kFflush;
  if (s == "fdatasync") return McapSyncMode::kFdatasync;
  throw UsageError("--sync must be none, fflush or fdatasync, got '" + s + "'");
}

dds_domainid_t ParseDomain(const Args& a) {
  const long long d = a.GetInt("domain", 0);
  if (d < 0 || d > 232) throw UsageError("--domain must be in [0, 232], got " + std::to_string(d));
  return static_cast<dds_domainid_t>(d);
}

}  // namespace

// Adds the writers the topic's reader matches now to t.matched_writers (called every flush;
// a writer that comes and goes between two flushes is missed, none does in a session; at
// most 64 per topic are read, far above a deployment's 9 ValveCommand writers).
static void NoteMatchedWriters(TopicRecorderBase& t) {
  dds_instance_handle_t handles[64];
  const dds_return_t n = dds_get_matched_publications(t.reader(), handles, 64);
  for (dds_return_t i = 0; i < std::min<dds_return_t>(n, 64); ++i) {
    dds_builtintopic_endpoint_t* e = dds_get_matched_publication_data(t.reader(), handles[i]);
    if (e == nullptr) continue;
    char guid[33];
    for (int b = 0; b < 16; ++b) std::snprintf(guid + 2 * b, 3, "%02x", e->key.v[b]);
    dds_reliability_kind_t kind = DDS_RELIABILITY_BEST_EFFORT;
    dds_duration_t blocking = 0;
    if (e->qos != nullptr) dds_qget_reliability(e->qos, &kind, &blocking);
    std::string what = kind == DDS_RELIABILITY_RELIABLE ? "reliable" : "best-effort";
    dds_ownership_kind_t ownership = DDS_OWNERSHIP_SHARED;
    int32_t strength = 0;
    if (e->qos != nullptr && dds_qget_ownership(e->qos, &ownership) &&
        ownership == DDS_OWNERSHIP_EXCLUSIVE && dds_qget_ownership_strength(e->qos, &strength))
      what += " strength " + std::to_string(strength);
    t.matched_writers[guid] = what;
    dds_builtintopic_free_endpoint(e);
  }
}

// Says on stderr, once per new count, that writers of `t`'s topic do not match the recorder
// and why (Cyclone's requested-incompatible-QoS status names the last policy): their
// samples are not recorded. The usual cause: a real-time session's periodic writers offer
// BEST_EFFORT and the recorder was started without --periodic-reliability best-effort.
static void ReportIncompatibleWriters(TopicRecorderBase& t, const std::string& periodic_reliability) {
  // Partition mismatches are by design (the leg partitions' writers; status.hpp) and left out.
  const comm::StatusSnapshot st = t.Status();
  if (st.requested_incompatible_qos_not_partition_total <= t.incompatible_reported) return;
  t.incompatible_reported = st.requested_incompatible_qos_not_partition_total;
  const std::string policy = comm::QosPolicyName(st.requested_incompatible_qos_last_policy);
  std::string hint;
  if (policy == "RELIABILITY" && t.periodic && periodic_reliability == "reliable")
    hint = " A real-time session's periodic writers offer BEST_EFFORT: record it with "
           "--periodic-reliability best-effort.";
  std::fprintf(stderr,
               "record: error: %s: %u writer(s) so far do not match this recorder (incompatible QoS, "
               "last policy %s): their samples are NOT recorded.%s\n",
               t.name.c_str(), st.requested_incompatible_qos_not_partition_total, policy.c_str(), hint.c_str());
}

int RunRecord(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv,
                           {"output", "o", "domain", "topics", "exclude", "duration-s", "flush-ms",
                            "batch-ms", "sync", "dds-config", "rt-priority", "cpus",
                            "compression", "zstd-level", "rig", "profile", "seed", "scene-hz",
                            "periodic-reliability", "split-size-mb", "split-duration-s",
                            "keep-files"},
                           {"quiet", "no-scene"});
  if (a.help) {
    std::fputs(
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
        "  --no-scene          do not add the 3-D scene\n",
        stdout);
    std::fputs(kSceneOptionsHelp, stdout);
    return kExitOk;
  }
  if (!a.positional.empty()) throw UsageError("unexpected argument '" + a.positional[0] + "'");
  const std::string out = a.Get("output", a.Get("o", ""));
  if (out.empty()) throw UsageError("--output FILE is required");
  const double duration_s = a.GetDouble("duration-s", 0.0);
  if (!(duration_s >= 0.0)) throw UsageError("--duration-s must be >= 0");
  const double flush_ms = a.GetDouble("flush-ms", 100.0);
  if (!(flush_ms >= 1.0 && flush_ms <= 60000.0))
    throw UsageError("--flush-ms must be in [1, 60000]");
  const double batch_ms = a.GetDouble("batch-ms", 2.0);
  if (!(batch_ms >= 0.0 && batch_ms <= flush_ms))
    throw UsageError("--batch-ms must be in [0, --flush-ms]");
  const TopicFilter filter{a.GetAll("topics"), a.GetAll("exclude")};
  const bool quiet = a.Has("quiet");
  const long long rt_priority = a.GetInt("rt-priority", 0);
  if (rt_priority < 0 || rt_priority > 98) throw UsageError("--rt-priority must be in [0, 98]");
  std::vector<int> cpus;
  if (a.Has("cpus") && !sched::ParseCpuList(a.Get("cpus", ""), cpus))
    throw UsageError("--cpus '" + a.Get("cpus", "") + "': expected CPU numbers such as 1, 0,1 or 0-1");
  // Before the participant: Cyclone's threads inherit both.
  std::string sched_message;
  if (!cpus.empty()) {
    sched::SetCpuAffinity(cpus, sched_message);
    if (!quiet) std::fprintf(stderr, "record: %s\n", sched_message.c_str());
  }
  if (rt_priority > 0) {
    sched::SetRealtime(static_cast<int>(rt_priority), sched_message);
    if (!quiet) std::fprintf(stderr, "record: %s\n", sched_message.c_str());
  }

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

  McapWriterConfig cfg;
  cfg.chunk_max_span_ns = static_cast<uint64_t>(flush_ms * 1e6);
  cfg.sync = ParseSync(a.Get("sync", "fdatasync"));
  cfg.compression = ParseCompressionOption(a);
  cfg.zstd_level = ParseZstdLevelOption(a);
  std::optional<std::string> dds_config;
  if (a.Has("dds-config")) dds_config = a.Get("dds-config", "");
  comm::EnsureDdsConfig(dds_config);
  // The session key (HEXA_SESSION_KEY, set by hexa_session and the generated units): command
  // samples of writers without it are not recorded. Without a key every sample is.
  if (const char* key_path = std::getenv(comm::kSessionKeyEnvironment); key_path != nullptr && *key_path) {
    std::string error;
    const auto key = comm::ReadSessionKey(key_path, error);
    if (!key) throw std::runtime_error(error + " (" + comm::kSessionKeyEnvironment + ")");
    comm::InstallSessionKey(*key);
  }
  comm::Participant participant(ParseDomain(a));
  comm::ShutdownGuard shutdown(participant);
  RecordingWriter writer(cfg);
  writer.Open(out);
  std::vector<std::unique_ptr<TopicRecorderBase>> topics;
  comm::QosParams params;
  const std::string periodic = a.Get("periodic-reliability", "reliable");
  if (periodic != "reliable" && periodic != "best-effort")
    throw UsageError("--periodic-reliability must be reliable or best-effort, got '" + periodic + "'");
  params.recorder_periodic_best_effort = periodic == "best-effort";
  // The writers this recorder matches (their QoS goes into each channel's metadata): the
  // real-time ones with best-effort, else the lockstep ones.
  params.lockstep = !params.recorder_periodic_best_effort;
  ForEachTopicType([&](auto pair) {
    using T = typename decltype(pair)::Dds;
    using P = typename decltype(pair)::Proto;
    if (!filter.Matches(std::string(comm::TopicName(comm::TopicTraits<T>::kKind)))) return;
    topics.push_back(std::make_unique<TopicRecorder<T, P>>(participant, writer, params));
  });
  if (topics.empty()) throw UsageError("--topics/--exclude leave no topic to record");
  // The 3-D scene (docs/foxglove.md): fed with every recorded sample, written when due.
  std::unique_ptr<SceneBuilder> scene;
  std::unique_ptr<SceneChannels> scene_channels;
  if (!a.Has("no-scene")) {
    scene = std::make_unique<SceneBuilder>(SceneOptionsFromArgs(a));
    scene_channels = std::make_unique<SceneChannels>(writer, scene->options());
    for (auto& t : topics) {
      t->on_sample = [&](const google::protobuf::Message& m) {
        if (!scene->Add(m)) return;
        const auto now = static_cast<uint64_t>(comm::RealtimeNow_ns());
        scene->Build(now);
        scene_channels->Write(now, *scene);
      };
    }
  }
  comm::WaitSet waitset(participant, topics.size() + 1);
  waitset.Attach(shutdown.guard_condition(), 0);
  for (size_t i = 0; i < topics.size(); ++i)
    waitset.Attach(topics[i]->condition(), static_cast<dds_attach_t>(i + 1));
  writer.mcap().FlushChunk();  // header, schemas and channels reach the disk before any data
  // Announce ourselves: the plant waits for a RUNNING recorder before its first tick when a
  // session asks for one (docs/architecture.md), so nothing is missed at the start.
  comm::Topic<hexa_msg_NodeStatus> status_topic(participant);
  comm::Writer<hexa_msg_NodeStatus> status_writer(participant, status_topic);
  hexa_msg_NodeStatus status{};
  std::snprintf(status.node_name, sizeof status.node_name, "recorder");
  std::snprintf(status.detail, sizeof status.detail, "recording %zu topics", topics.size());
  status.state = hexa_msg_NODE_RUNNING;
  status_writer.WriteNow(status);
  node::service_manager::Ready(status.detail);
  if (!quiet)
    std::fprintf(stderr, "record: domain %d, %zu topics -> %s (periodic topics %s)\n",
                 static_cast<int>(participant.domain_id()), topics.size(), out.c_str(), periodic.c_str());

  const int64_t start_ns = comm::RealtimeNow_ns();
  RecordingRotation rotation(rotation_config, out, static_cast<uint64_t>(start_ns));
  const int64_t end_ns =
      duration_s > 0 ? start_ns + static_cast<int64_t>(duration_s * 1e9) : INT64_MAX;
  const int64_t flush_ns = static_cast<int64_t>(flush_ms * 1e6);
  const int64_t batch_ns = static_cast<int64_t>(batch_ms * 1e6);
  int64_t next_flush_ns = start_ns + flush_ns;
  // A progress line every second of wall time on stderr (hexa_session shows the newest one).
  constexpr int64_t kProgressPeriodNs = 1'000'000'000;
  int64_t next_progress_ns = start_ns + kProgressPeriodNs;
  while (!shutdown.requested()) {
    node::service_manager::Watchdog();
    const int64_t now = comm::RealtimeNow_ns();
    if (now >= end_ns) break;
    // Wake on data, on shutdown, or when the open chunk is due to be flushed.
    const int64_t wake = std::min(end_ns, next_flush_ns);
    const dds_return_t rc = waitset.WaitUntil(static_cast<dds_time_t>(wake));
    if (rc < 0) throw std::runtime_error("waitset failed: " + std::string(dds_strretcode(rc)));
    for (dds_attach_t token : waitset.triggered()) {
      if (token > 0) topics[static_cast<size_t>(token - 1)]->Drain(writer);
    }
    const int64_t after = comm::RealtimeNow_ns();
    if (after >= next_flush_ns) {
      writer.mcap().FlushIfDue(static_cast<uint64_t>(after));
      next_flush_ns = after + flush_ns;
      if (rotation_config.enabled() && rotation.Due(writer.mcap(), static_cast<uint64_t>(after))) {
        const std::size_t deleted_before = rotation.deleted().size();
        rotation.Rotate(writer.mcap(), static_cast<uint64_t>(after));
        if (!quiet) {
          std::fprintf(stderr, "record: closed %s, recording on in %s\n",
                       rotation.parts().back().c_str(), out.c_str());
          for (std::size_t k = deleted_before; k < rotation.deleted().size(); ++k)
            std::fprintf(stderr, "record: deleted %s (--keep-files %lld)\n",
                         rotation.deleted()[k].c_str(), keep_files);
        }
      }
      for (auto& t : topics) {
        ReportIncompatibleWriters(*t, periodic);
        NoteMatchedWriters(*t);
      }
      if (!quiet && after >= next_progress_ns) {
        uint64_t tick = 0, messages = 0;
        for (const auto& t : topics) {
          tick = std::max(tick, t->last_tick);
          messages += t->received;
        }
        std::fprintf(stderr, "record: progress: %.1f s simulated (tick %" PRIu64 "), %.0f s wall, %" PRIu64
                     " messages\n", static_cast<double>(tick) * kPlantTick_s,
                     tick, static_cast<double>(after - start_ns) * 1e-9, messages);
        next_progress_ns = after + kProgressPeriodNs;
      }
    }
    // Let samples accumulate in the readers (keep-all) before the next take: at 1 kHz x 13
    // streams a wake-up per sample costs more CPU than recording the sample.
    const int64_t pause_ns = std::min({batch_ns, end_ns - after, next_flush_ns - after});
    if (pause_ns > 0) {
      const timespec pause{static_cast<time_t>(pause_ns / 1'000'000'000),
                           static_cast<long>(pause_ns % 1'000'000'000)};
      nanosleep(&pause, nullptr);  // a signal ends it early; the loop then sees the shutdown
    }
  }
  for (auto& t : topics) {
    t->Drain(writer);  // what arrived before the stop
    NoteMatchedWriters(*t);
  }
  status.state = hexa_msg_NODE_STOPPING;
  status_writer.WriteNow(status);
  node::service_manager::Stopping("recording closed");
  writer.Close();

  const double elapsed_s = static_cast<double>(comm::RealtimeNow_ns() - start_ns) * 1e-9;
  const McapWriterStats& ws = writer.mcap().stats();
  std::printf("recorded %.3f s to %s: %" PRIu64 " messages, %" PRIu64 " chunks, %" PRIu64
              " bytes (chunk records %" PRIu64 " bytes, stored %" PRIu64 ", compression %s)\n",
              elapsed_s, out.c_str(), ws.messages, ws.chunks, ws.bytes, ws.chunk_records_bytes,
              ws.chunk_stored_bytes, cfg.compression == McapCompression::kZstd ? "zstd" : "none");
  if (rotation_config.enabled())
    std::printf("split into parts: %zu closed part(s) kept beside %s, %zu deleted (--keep-files)\n",
                rotation.parts().size(), out.c_str(), rotation.deleted().size());
  // incompatible: writers refused for their QoS, partition mismatches (by design) left out.
  std::printf("%-22s %10s %10s %8s %12s %12s %12s\n", "topic", "received", "missing", "gaps",
              "dds_lost", "dds_rejected", "incompatible");
  LossEventCounter events;
  std::vector<std::string> unmatched;  // periodic topics with nothing recorded and a writer refused
  for (const auto& t : topics) {
    ReportIncompatibleWriters(*t, periodic);
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

// --------------------------------------------------------------------------------- play

namespace {

struct TopicPlayerBase {
  virtual ~TopicPlayerBase() = default;
  // false: the message could not be converted (reported once per channel by the caller).
  virtual bool Publish(std::string_view data) = 0;
  // The decoded message (reused by the next call), nullptr if the bytes do not parse.
  virtual const google::protobuf::Message* Parse(std::string_view data) = 0;
  virtual comm::StatusSnapshot Status() const = 0;
  // Blocks until every matched reliable reader has acknowledged every sample written.
  virtual dds_return_t WaitForAcks(dds_duration_t timeout) = 0;
  std::string topic;
  uint64_t published = 0;
  uint64_t refused = 0;
};

template <typename T, typename P>
class TopicPlayer final : public TopicPlayerBase {
 public:
  // The comm profile's writer QoS; `keep_all` (lockstep replay) replaces the keep-last history
  // by KEEP_ALL so that a reliable reader that falls behind throttles the writer (Cyclone
  // blocks dds_write while too much is unacknowledged) instead of losing samples that the
  // keep-last history would have overwritten.
  TopicPlayer(const comm::Participant& p, const comm::QosParams& params, bool keep_all)
      : topic_(p) {
    const comm::TopicKind kind = comm::TopicTraits<T>::kKind;
    topic = std::string(comm::TopicName(kind));
    const comm::Qos qos = comm::MakeQos(kind, comm::EndpointRole::kWriter, params);
    if (keep_all) {
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    }
    writer_ = comm::OwnedEntity(comm::CheckDds(
        dds_create_writer(p.get(), topic_.get(), qos.get(), nullptr),
        "cannot create writer on " + topic));
    // Leg-keyed topics are also written in each leg's partition, as the plant and the
    // supervisor do (comm::LegRoutedWriter): that is where leg controllers read them.
    if constexpr (comm::LegKeyed<T>) {
      for (int leg = 1; leg <= kRoutedLegs; ++leg) {
        leg_publishers_[leg - 1] = comm::CreatePublisher(p, {comm::LegPartition(leg)});
        leg_writers_[leg - 1] = comm::OwnedEntity(comm::CheckDds(
            dds_create_writer(leg_publishers_[leg - 1].get(), topic_.get(), qos.get(), nullptr),
            "cannot create writer on " + topic + " for leg " + std::to_string(leg)));
      }
    }
  }
  const google::protobuf::Message* Parse(std::string_view data) override {
    return msg_.ParseFromArray(data.data(), static_cast<int>(data.size())) ? &msg_ : nullptr;
  }
  // Matched readers over the writers: a leg controller matches its leg's writer, the
  // recorder and the supervisor the default-partition one.
  comm::StatusSnapshot Status() const override {
    comm::StatusSnapshot s;
    for (dds_entity_t w : Writers()) {
      dds_publication_matched_status_t m{};
      if (dds_get_publication_matched_status(w, &m) == DDS_RETCODE_OK) {
        s.publication_matched_current += m.current_count;
        s.publication_matched_total += m.total_count;
      }
    }
    return s;
  }
  dds_return_t WaitForAcks(dds_duration_t timeout) override {
    dds_return_t rc = DDS_RETCODE_OK;
    for (dds_entity_t w : Writers()) {
      const dds_return_t r = dds_wait_for_acks(w, timeout);
      if (r != DDS_RETCODE_OK) rc = r;
    }
    return rc;
  }
  bool Publish(std::string_view data) override {
    T sample{};
    if (!msg_.ParseFromArray(data.data(), static_cast<int>(data.size())) ||
        !FromProto(msg_, sample)) {
      ++refused;
      return false;
    }
    // The sample keeps its recorded header; DDS gets the replay time as source timestamp.
    // A keep-all writer may time out while a reader catches up: try again (bounded).
    const int64_t now_ns = comm::RealtimeNow_ns();
    Write(writer_.get(), sample, now_ns);
    if constexpr (comm::LegKeyed<T>) {
      if (sample.leg_id >= 1 && sample.leg_id <= kRoutedLegs)
        Write(leg_writers_[sample.leg_id - 1].get(), sample, now_ns);
    }
    ++published;
    return true;
  }

 private:
  static constexpr int kRoutedLegs = 6;
  void Write(dds_entity_t writer, const T& sample, int64_t source_time_ns) {
    dds_return_t rc = DDS_RETCODE_TIMEOUT;
    for (int attempt = 0; attempt < 30 && rc == DDS_RETCODE_TIMEOUT; ++attempt)
      rc = dds_write_ts(writer, &sample, source_time_ns);
    if (rc < 0) throw std::runtime_error("write on " + topic + " failed: " +
                                         std::string(dds_strretcode(rc)));
  }
  std::vector<dds_entity_t> Writers() const {
    std::vector<dds_entity_t> all{writer_.get()};
    for (const auto& w : leg_writers_)
      if (w) all.push_back(w.get());
    return all;
  }
  comm::Topic<T> topic_;
  comm::OwnedEntity writer_;
  std::array<comm::OwnedEntity, kRoutedLegs> leg_publishers_;  // leg-keyed topics only
  std::array<comm::OwnedEntity, kRoutedLegs> leg_writers_;
  P msg_;
};

struct StopPlayback {};

// Lockstep playback (play --lockstep): the recording is published tick by tick, in tick order,
// through keep-all writers (a reliable reader that falls behind throttles the writer, nothing
// is overwritten) and, with --answers-out, the next tick starts only when every leg controller
// whose sensors were published has answered this one with its ValveCommand. That is the plant's lockstep
// protocol (docs/architecture.md), so a controller that keeps only the newest sensor sample
// (keep-last 1) never has a tick overwritten, whatever the machine's load: the replay is
// deterministic, unlike pacing by recorded log times (which carry the recorder's batching).
struct LockstepOptions {
  uint64_t start_log_ns = 0;
  std::string answers_out;           // "" = do not wait for answers
  std::set<uint32_t> answer_legs;    // empty = every leg seen in the sensor stream
  double answer_timeout_s = 10.0;
  double wait_readers_s = 30.0;
  uint64_t reorder_ticks = 10000;    // how far file order may lag tick order
  uint64_t ack_every_ticks = 0;      // 0 = never wait for acknowledgements (keep-all writers
                                     // already guarantee delivery to reliable readers)
  bool progress = true;
};

int RunLockstepPlayback(const std::string& path, const LockstepOptions& o,
                        const RecordingCatalog& catalog,
                        const std::map<uint16_t, TopicPlayerBase*>& players,
                        const std::vector<std::unique_ptr<TopicPlayerBase>>& owned,
                        comm::Participant& participant, comm::ShutdownGuard& shutdown) {
  // Only periodic topics carry the tick that orders the replay.
  std::map<uint16_t, TopicPlayerBase*> ticked;
  TopicPlayerBase* sensors_player = nullptr;
  TopicPlayerBase* setpoint_player = nullptr;
  for (const auto& [id, player] : players) {
    const std::string& topic = catalog.channels.at(id).topic;
    bool periodic = false;
    for (int k = 0; k < comm::kTopicKindCount; ++k) {
      const auto kind = static_cast<comm::TopicKind>(k);
      if (comm::TopicName(kind) == topic) periodic = comm::NominalPeriod_s(kind).has_value();
    }
    if (!periodic) {
      std::fprintf(stderr, "play --lockstep: skipping event topic '%s' (no tick)\n", topic.c_str());
      continue;
    }
    ticked[id] = player;
    if (topic == comm::kLegSensorsTopic) sensors_player = player;
    if (topic == comm::kLegSetpointTopic) setpoint_player = player;
  }
  if (ticked.empty()) throw UsageError("play --lockstep: no periodic topic selected");

  // The legs whose answers are awaited: --answer-legs, else every leg in the sensor stream.
  std::set<uint32_t> legs = o.answer_legs;
  const bool await_answers = !o.answers_out.empty();
  if (await_answers && legs.empty()) {
    if (sensors_player == nullptr)
      throw UsageError("play --answers-out needs hexa_LegSensors among the played topics");
    ReadRecording(path, [&](const McapChannel& ch, const McapMessageView&,
                            const google::protobuf::Message& m) {
      if (ch.topic != comm::kLegSensorsTopic) return;
      if (const uint32_t leg = LegOfKey(MessageKey(m)); leg != 0) legs.insert(leg);
    });
    if (legs.empty()) throw UsageError("play --answers-out: the recording has no leg sensors");
  }

  // Answers: the ValveCommands of the controllers under test, recorded like `record` does.
  // The clock's side of the lockstep protocol (core/lockstep_protocol.hpp) decides when a tick
  // is complete, asks a silent leg again and gives up, exactly as the plant service does.
  std::unique_ptr<RecordingWriter> answers_writer;
  std::unique_ptr<TopicRecorderBase> answers;
  LockstepBarrierParams barrier_params;
  barrier_params.timeout_ns = static_cast<int64_t>(o.answer_timeout_s * 1e9);
  LockstepBarrier barrier(barrier_params);
  uint64_t answers_received = 0;
  std::map<uint32_t, uint64_t> answered;  // leg -> newest tick answered (for the summary)
  comm::WaitSet waitset(participant, 4);
  waitset.Attach(shutdown.guard_condition(), 0);
  if (await_answers) {
    answers_writer = std::make_unique<RecordingWriter>(McapWriterConfig{});
    answers_writer->Open(o.answers_out);
    answers = std::make_unique<TopicRecorder<hexa_msg_ValveCommand, rec::ValveCommand>>(
        participant, *answers_writer, comm::QosParams{});
    answers->on_sample = [&](const google::protobuf::Message& m) {
      ++answers_received;
      const auto tick = MessageTick(m);
      const uint32_t leg = LegOfKey(MessageKey(m));
      if (!tick || leg == 0) return;
      uint64_t& newest = answered[leg];
      newest = std::max(newest, *tick);
      if (leg <= kNumLegs) barrier.Answer(static_cast<int>(leg), *tick);
    };
    answers_writer->mcap().FlushChunk();
    waitset.Attach(answers->condition(), 1);
  }

  // Start when the peers are there: with answers, the controllers of every awaited leg (their
  // ValveCommand writers, sensor and setpoint readers); otherwise one reader per topic.
  {
    const int64_t until = comm::RealtimeNow_ns() + static_cast<int64_t>(o.wait_readers_s * 1e9);
    const uint32_t need = await_answers ? static_cast<uint32_t>(legs.size()) : 1;
    std::string missing;
    for (;;) {
      missing.clear();
      if (await_answers && answers->Status().subscription_matched_current < need)
        missing += " ValveCommand writers " +
                   std::to_string(answers->Status().subscription_matched_current) + "/" +
                   std::to_string(need);
      for (const auto& p : owned) {
        const bool must = !await_answers || p.get() == sensors_player || p.get() == setpoint_player;
        if (must && p->Status().publication_matched_current < need)
          missing += " " + p->topic + " readers " +
                     std::to_string(p->Status().publication_matched_current) + "/" +
                     std::to_string(need);
      }
      if (missing.empty() || shutdown.requested()) break;
      if (comm::RealtimeNow_ns() > until) {
        std::fprintf(stderr, "play --lockstep: peers missing after %.1f s:%s\n", o.wait_readers_s,
                     missing.c_str());
        if (await_answers) throw std::runtime_error("play --lockstep: the controllers under test "
                                                    "did not appear (--wait-readers-s)");
        break;
      }
      waitset.Wait(DDS_MSECS(20));  // match counts change without data: bounded re-check
    }
  }

  struct Pending {
    TopicPlayerBase* player;
    std::string data;
    uint32_t leg;  // LegSensors and LegSetpoint: its leg, else 0
  };
  std::map<uint64_t, std::vector<Pending>> buffer;
  uint64_t next_tick = 0;  // every tick below has been played
  bool started = false;
  uint64_t ticks_played = 0, published = 0, refused = 0, ack_timeouts = 0, resent = 0;
  uint64_t unanswerable = 0;  // leg-ticks not awaited: their setpoint is not in the recording
  int64_t last_progress_ns = 0;
  // The setpoints played so far, per leg (only their ticks matter): the protocol's rule says
  // whether a leg can answer a tick (a recording ends with ticks whose setpoint the finished
  // supervisor never issued; no controller can answer those, so they are not awaited).
  struct PlayedSetpoint {
    uint64_t tick = 0;
  };
  LegArray<SetpointRing<PlayedSetpoint, 2>> played_setpoints{};
  const LockstepSchedule schedule;
  const bool setpoints_played = setpoint_player != nullptr;

  auto drain_answers = [&] {
    if (answers) answers->Drain(*answers_writer);
  };
  auto play_tick = [&](uint64_t tick, std::vector<Pending>& msgs) {
    LegMask awaited = 0;
    for (const Pending& m : msgs) {
      if (!m.player->Publish(m.data)) {
        ++refused;
        continue;
      }
      ++published;
      if (m.leg == 0 || m.leg > kNumLegs) continue;
      if (m.player == setpoint_player) {
        played_setpoints[m.leg - 1].Add(PlayedSetpoint{tick});
      } else if (o.answer_legs.empty() || legs.count(m.leg)) {
        awaited = static_cast<LegMask>(awaited | LegBit(static_cast<int>(m.leg)));
      }
    }
    ++ticks_played;
    if (o.ack_every_ticks > 0 && ticks_played % o.ack_every_ticks == 0) {
      for (const auto& p : owned) {
        if (p->WaitForAcks(DDS_SECS(5)) == DDS_RETCODE_TIMEOUT) ++ack_timeouts;
      }
    }
    if (await_answers) {
      if (setpoints_played) {
        for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
          if ((awaited & LegBit(leg)) &&
              !played_setpoints[leg - 1].CanAnswer(tick, schedule.supervisor_every_ticks)) {
            awaited = static_cast<LegMask>(awaited & ~LegBit(leg));
            ++unanswerable;
          }
        }
      }
      barrier.Begin(tick, awaited, comm::MonotonicNow_ns());
      for (const auto& [leg, newest] : answered)  // answered before this tick was played
        if (newest >= tick && leg <= kNumLegs) barrier.Answer(static_cast<int>(leg), tick);
      for (;;) {
        drain_answers();
        if (barrier.complete()) break;
        if (shutdown.requested()) throw StopPlayback{};
        const int64_t now = comm::MonotonicNow_ns();
        const LockstepBarrier::Action action = barrier.Check(now);
        if (action == LockstepBarrier::Action::kTimeout) {
          std::string late;
          for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
            if (barrier.missing() & LegBit(leg)) late += " " + std::to_string(leg);
          throw std::runtime_error("play --lockstep: tick " + std::to_string(tick) +
                                   " not answered within " + std::to_string(o.answer_timeout_s) +
                                   " s by leg(s)" + late);
        }
        if (action == LockstepBarrier::Action::kReask) {
          // As the plant does: the silent legs' sensor samples once more (a controller answers
          // a repeated tick from its cache).
          for (const Pending& m : msgs) {
            if (m.player == sensors_player && m.leg >= 1 && m.leg <= kNumLegs &&
                (barrier.missing() & LegBit(static_cast<int>(m.leg))) && m.player->Publish(m.data))
              ++resent;
          }
        }
        const int64_t wait_ns = std::max<int64_t>(1'000'000, barrier.next_check_ns() - now);
        waitset.Wait(wait_ns);
      }
    }
    const int64_t now = comm::RealtimeNow_ns();
    if (o.progress && now - last_progress_ns > 250'000'000) {
      last_progress_ns = now;
      std::fprintf(stderr, "\rplay --lockstep: tick %" PRIu64 "  %" PRIu64 " messages  ", tick,
                   published);
    }
  };
  auto flush_below = [&](uint64_t limit) {  // plays every buffered tick < limit
    while (!buffer.empty() && buffer.begin()->first < limit) {
      if (shutdown.requested()) throw StopPlayback{};
      auto node = buffer.extract(buffer.begin());
      play_tick(node.key(), node.mapped());
      next_tick = node.key() + 1;
    }
  };

  bool interrupted = false;
  std::string error;
  try {
    McapReader r;
    r.Open(path);
    McapVisitor v;
    v.on_message = [&](const McapMessageView& m) {
      if (shutdown.requested()) throw StopPlayback{};
      if (m.log_time_ns < o.start_log_ns) return;
      auto it = ticked.find(m.channel_id);
      if (it == ticked.end()) return;
      const google::protobuf::Message* msg = it->second->Parse(m.data);
      const std::optional<uint64_t> tick = msg ? MessageTick(*msg) : std::nullopt;
      if (!tick) {
        ++refused;
        return;
      }
      if (started && *tick < next_tick)
        throw std::runtime_error(
            "play --lockstep: a message of tick " + std::to_string(*tick) + " on '" +
            catalog.channels.at(m.channel_id).topic + "' comes after tick " +
            std::to_string(next_tick - 1) + " was played: raise --reorder-ticks (now " +
            std::to_string(o.reorder_ticks) + ")");
      uint32_t leg = 0;
      if (it->second == sensors_player || it->second == setpoint_player)
        leg = LegOfKey(MessageKey(*msg));
      buffer[*tick].push_back(Pending{it->second, std::string(m.data), leg});
      const uint64_t newest = buffer.rbegin()->first;
      if (newest >= o.reorder_ticks) {
        const uint64_t limit = newest - o.reorder_ticks;
        if (!buffer.empty() && buffer.begin()->first < limit) {
          started = true;
          flush_below(limit);
        }
      }
    };
    r.Scan(v);
    started = true;
    flush_below(UINT64_MAX);
    for (const auto& p : owned) {  // the last samples reach every reliable reader
      if (p->WaitForAcks(DDS_SECS(10)) == DDS_RETCODE_TIMEOUT) ++ack_timeouts;
    }
  } catch (const StopPlayback&) {
    interrupted = true;
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (o.progress) std::fputc('\n', stderr);
  if (answers) {
    drain_answers();
    answers_writer->Close();
  }
  std::printf("played %" PRIu64 " messages in %" PRIu64 " ticks (%" PRIu64
              " refused, %" PRIu64 " acknowledgement timeouts)%s\n",
              published, ticks_played, refused, ack_timeouts, interrupted ? ", interrupted" : "");
  if (answers)
    std::printf("lockstep: %" PRIu64 " sensor samples re-published to silent legs; %" PRIu64
                " leg-ticks not awaited (their setpoint is not in the recording)\n",
                resent, unanswerable);
  if (answers) {
    std::printf("answers: %" PRIu64 " ValveCommands -> %s; newest tick per leg:", answers_received,
                o.answers_out.c_str());
    for (const auto& [leg, tick] : answered) std::printf(" %u:%" PRIu64, leg, tick);
    std::printf("\n");
  }
  if (!error.empty()) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return kExitError;
  }
  return kExitOk;
}

}  // namespace

int RunPlay(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv,
                           {"domain", "rate", "start-s", "topics", "exclude", "dds-config",
                            "deadline-s", "wait-readers-s", "answers-out", "answer-legs",
                            "answer-timeout-s", "reorder-ticks", "ack-every"},
                           {"loop", "no-progress", "lockstep"});
  if (a.help) {
    std::fputs(
        "usage: hexa_recorder play FILE.mcap [--domain N] [--rate X] [--loop] [--start-s S]\n"
        "                          [--topics GLOB,..] [--exclude GLOB,..] [--no-progress]\n"
        "                          [--deadline-s S] [--wait-readers-s S] [--dds-config FILE.xml]\n"
        "Republishes the recording's messages on their DDS topics with the recorded timing\n"
        "(log-time differences divided by --rate, default 1; 0 = as fast as possible),\n"
        "starting --start-s seconds into the recording; --loop repeats until SIGINT/SIGTERM.\n"
        "Only the topics matching --topics (default all) and not --exclude are published, e.g.\n"
        "--topics hexa_LegSensors,hexa_LegSetpoint to feed recorded sensors to a new\n"
        "controller build. --deadline-s sets the writers' offered deadline (as the comm\n"
        "QosParams.deadline_period_s; default the nominal period). --wait-readers-s waits up\n"
        "to S seconds for at least one reader per published topic before starting.\n"
        "A progress line goes to stderr unless --no-progress.\n"
        "\n"
        "Lockstep replay (deterministic, independent of timing and load):\n"
        "  --lockstep            publish the periodic topics tick by tick in tick order with\n"
        "                        keep-all writers: a reliable reader (e.g. record) that falls\n"
        "                        behind slows playback down instead of losing samples. At the\n"
        "                        end, waits until every reader has acknowledged everything.\n"
        "                        --ack-every N also waits for acknowledgements every N ticks.\n"
        "                        --rate and --loop do not apply; --wait-readers-s (default 30)\n"
        "                        waits for a reader on every played topic.\n"
        "  --answers-out F.mcap  also act as the plant: after tick n wait until every leg whose\n"
        "                        LegSensors(n) was played has answered with ValveCommand(n), and\n"
        "                        record those ValveCommands to F.mcap (then `diff` it against\n"
        "                        the original). Waits first for the controllers of every leg.\n"
        "  --answer-legs L,..    legs to wait for (default: every leg in the sensor stream)\n"
        "  --answer-timeout-s S  a tick not answered within S (default 10) is an error (exit 2)\n"
        "  --reorder-ticks N     how far the file order may lag the tick order (default 10000)\n"
        "e.g. play run.mcap --lockstep --topics hexa_LegSensors,hexa_ImuSample,hexa_LegSetpoint\n"
        "       --answers-out new.mcap   (with hexa_leg_ctrl --mode lockstep x6 on the domain)\n",
        stdout);
    return kExitOk;
  }
  if (a.positional.size() != 1) throw UsageError("expected exactly one recording file");
  const std::string path = a.positional[0];
  const double rate = a.GetDouble("rate", 1.0);
  if (!(rate >= 0.0)) throw UsageError("--rate must be >= 0");
  const double start_s = a.GetDouble("start-s", 0.0);
  if (!(start_s >= 0.0)) throw UsageError("--start-s must be >= 0");
  const bool loop = a.Has("loop");
  const bool progress = !a.Has("no-progress");
  const bool lockstep = a.Has("lockstep") || a.Has("answers-out");
  LockstepOptions lo;
  if (lockstep) {
    if (loop) throw UsageError("--loop does not combine with --lockstep");
    if (a.Has("rate")) throw UsageError("--rate does not apply to --lockstep (paced by delivery)");
    lo.answers_out = a.Get("answers-out", "");
    for (const std::string& l : a.GetAll("answer-legs")) {
      const long v = std::strtol(l.c_str(), nullptr, 10);
      if (v < 1 || v > 255) throw UsageError("--answer-legs: '" + l + "' is not a leg id 1..255");
      lo.answer_legs.insert(static_cast<uint32_t>(v));
    }
    lo.answer_timeout_s = a.GetDouble("answer-timeout-s", 10.0);
    if (!(lo.answer_timeout_s > 0)) throw UsageError("--answer-timeout-s must be > 0");
    lo.wait_readers_s = a.GetDouble("wait-readers-s", 30.0);
    const long long reorder = a.GetInt("reorder-ticks", 10000);
    if (reorder < 0) throw UsageError("--reorder-ticks must be >= 0");
    lo.reorder_ticks = static_cast<uint64_t>(reorder);
    const long long ack = a.GetInt("ack-every", 0);
    if (ack < 0) throw UsageError("--ack-every must be >= 0");
    lo.ack_every_ticks = static_cast<uint64_t>(ack);
    lo.progress = progress;
  }
  const TopicFilter filter{a.GetAll("topics"), a.GetAll("exclude")};
  comm::QosParams params;
  // Timed playback writes as a real-time session does (periodic topics best effort: read it
  // with record --periodic-reliability best-effort); --lockstep as a lockstep one (reliable,
  // and keep-all: TopicPlayer).
  params.lockstep = lockstep;
  if (a.Has("deadline-s")) params.deadline_period_s = a.GetDouble("deadline-s", 0.0, /*allow_infinity=*/true);
  params.Validate();

  // First pass: the file is valid, which channels it has, its time span.
  RecordingCatalog catalog;
  uint64_t first_log = UINT64_MAX, last_log = 0;
  {
    McapReader r;
    r.Open(path);
    McapVisitor v;
    v.on_message = [&](const McapMessageView& m) {
      first_log = std::min(first_log, m.log_time_ns);
      last_log = std::max(last_log, m.log_time_ns);
    };
    r.Scan(v);
    catalog.schemas = r.schemas();
    catalog.channels = r.channels();
  }
  if (first_log == UINT64_MAX) throw McapError("'" + path + "' holds no messages");
  const uint64_t start_log = first_log + static_cast<uint64_t>(start_s * 1e9);
  if (start_log > last_log)
    throw UsageError("--start-s " + std::to_string(start_s) + " is past the recording's end (" +
                     std::to_string(static_cast<double>(last_log - first_log) * 1e-9) + " s)");

  std::optional<std::string> dds_config;
  if (a.Has("dds-config")) dds_config = a.Get("dds-config", "");
  comm::EnsureDdsConfig(dds_config);
  comm::Participant participant(ParseDomain(a));
  comm::ShutdownGuard shutdown(participant);
  comm::WaitSet waitset(participant, 2);
  waitset.Attach(shutdown.guard_condition(), 0);

  // One writer per (topic, type) pair that the comm layer knows; other channels are skipped.
  std::map<uint16_t, TopicPlayerBase*> players;
  std::vector<std::unique_ptr<TopicPlayerBase>> owned;
  std::map<std::string, TopicPlayerBase*> by_topic;
  for (const auto& [id, ch] : catalog.channels) {
    if (!filter.Matches(ch.topic)) continue;
    const auto schema = catalog.schemas.find(ch.schema_id);
    const std::string type = schema == catalog.schemas.end() ? "" : schema->second.name;
    bool found = false;
    ForEachTopicType([&](auto pair) {
      using T = typename decltype(pair)::Dds;
      using P = typename decltype(pair)::Proto;
      if (found || ch.topic != comm::TopicName(comm::TopicTraits<T>::kKind)) return;
      found = true;
      if (type != P::descriptor()->full_name()) {
        std::fprintf(stderr, "play: skipping channel '%s': schema '%s', expected '%s'\n",
                     ch.topic.c_str(), type.c_str(), P::descriptor()->full_name().c_str());
        return;
      }
      auto& player = by_topic[ch.topic];
      if (player == nullptr) {
        owned.push_back(std::make_unique<TopicPlayer<T, P>>(participant, params, lockstep));
        player = owned.back().get();
      }
      players[id] = player;
    });
    if (!found)
      std::fprintf(stderr, "play: skipping channel '%s': not a topic of this system\n",
                   ch.topic.c_str());
  }
  if (players.empty()) throw UsageError("no channel of the recording is selected for playback");

  if (lockstep) {
    lo.start_log_ns = start_log;
    return RunLockstepPlayback(path, lo, catalog, players, owned, participant, shutdown);
  }

  if (a.Has("wait-readers-s")) {
    // Give late-joining readers (volatile topics) the chance to match before data flows: up
    // to S seconds until every published topic has at least one reader.
    const double wait_s = a.GetDouble("wait-readers-s", 0.0);
    const int64_t until = comm::RealtimeNow_ns() + static_cast<int64_t>(wait_s * 1e9);
    while (!shutdown.requested() && comm::RealtimeNow_ns() < until) {
      bool all = true;
      for (const auto& p : owned) all = all && p->Status().publication_matched_current >= 1;
      if (all) break;
      waitset.WaitUntil(std::min(static_cast<dds_time_t>(until),
                                 static_cast<dds_time_t>(comm::RealtimeNow_ns() + 20'000'000)));
    }
  }

  uint64_t total_published = 0, total_refused = 0;
  int64_t last_progress_ns = 0;
  uint64_t loops = 0;
  const double span_s = static_cast<double>(last_log - start_log) * 1e-9;
  try {
    do {
      const int64_t wall0 = comm::RealtimeNow_ns();
      McapReader r;
      r.Open(path);
      McapVisitor v;
      v.on_message = [&](const McapMessageView& m) {
        if (shutdown.requested()) throw StopPlayback{};
        if (m.log_time_ns < start_log) return;
        auto it = players.find(m.channel_id);
        if (it == players.end()) return;
        if (rate > 0.0) {
          const int64_t due = wall0 + static_cast<int64_t>(
                                          static_cast<double>(m.log_time_ns - start_log) / rate);
          // Sleeps in the WaitSet so that SIGINT/SIGTERM interrupts at once.
          while (comm::RealtimeNow_ns() < due) {
            waitset.WaitUntil(static_cast<dds_time_t>(due));
            if (shutdown.requested()) throw StopPlayback{};
          }
        }
        if (!it->second->Publish(m.data)) {
          if (it->second->refused == 1)
            std::fprintf(stderr, "\nplay: a message on '%s' does not fit the wire type; skipped\n",
                         catalog.channels.at(m.channel_id).topic.c_str());
          ++total_refused;
          return;
        }
        ++total_published;
        const int64_t now = comm::RealtimeNow_ns();
        if (progress && now - last_progress_ns > 250'000'000) {
          last_progress_ns = now;
          std::fprintf(stderr, "\rplay: %8.3f / %.3f s  %" PRIu64 " messages  loop %" PRIu64 "  ",
                       static_cast<double>(m.log_time_ns - start_log) * 1e-9, span_s,
                       total_published, loops + 1);
        }
      };
      r.Scan(v);
      ++loops;
    } while (loop && !shutdown.requested());
  } catch (const StopPlayback&) {
  }
  if (progress) std::fputc('\n', stderr);
  std::printf("played %" PRIu64 " messages (%" PRIu64 " refused) in %" PRIu64 " pass(es)%s\n",
              total_published, total_refused, loops, shutdown.requested() ? ", interrupted" : "");
  return kExitOk;
}

}  // namespace hexa::recorder::cli
