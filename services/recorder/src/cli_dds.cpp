// DDS subcommands of hexa_recorder: record and play, through the comm layer (RAII participant,
// topics, readers, writers, named QoS profiles, shutdown guard). Conversion DDS <-> protobuf
// is convert.cpp's; this file only moves samples.
#include <time.h>
#include <unistd.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

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
#include "hexa/recorder/convert.hpp"
#include "hexa/recorder/recording.hpp"

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
  std::string name;
  uint16_t channel = 0;
  bool periodic = false;
  uint64_t received = 0;
  TickLossTracker loss;
};

template <typename T, typename P>
class TopicRecorder final : public TopicRecorderBase {
 public:
  static constexpr std::size_t kCapacity = 256;
  TopicRecorder(const comm::Participant& p, RecordingWriter& w, const comm::QosParams& params)
      : topic_(p), reader_(p, topic_, comm::EndpointRole::kRecorderReader, params, kCapacity) {
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
  void Drain(RecordingWriter& w) override {
    for (;;) {
      const int n = reader_.Take();
      if (n <= 0) return;
      const uint64_t log_ns = static_cast<uint64_t>(comm::RealtimeNow_ns());
      for (int i = 0; i < n; ++i) {
        if (!reader_.info(i).valid_data) continue;  // dispose / unregister: no sample
        const T& s = reader_.sample(i);
        ToProto(s, msg_);
        w.Write(channel, log_ns, static_cast<uint64_t>(SourceTime_ns(s)), msg_);
        ++received;
        if (periodic) {
          if (auto tick = MessageTick(msg_)) loss.Add(MessageKey(msg_), *tick);
        }
      }
      if (static_cast<std::size_t>(n) < kCapacity) return;
    }
  }

 private:
  comm::Topic<T> topic_;
  comm::Reader<T> reader_;
  P msg_;
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

int RunRecord(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv,
                           {"output", "o", "domain", "topics", "exclude", "duration-s", "flush-ms",
                            "sync", "dds-config"},
                           {"quiet"});
  if (a.help) {
    std::fputs(
        "usage: hexa_recorder record --output FILE.mcap [--domain N] [--topics GLOB,..]\n"
        "                            [--exclude GLOB,..] [--duration-s S] [--flush-ms MS]\n"
        "                            [--sync none|fflush|fdatasync] [--dds-config FILE.xml]\n"
        "Subscribes to every topic of the system (reliable, keep-all recorder QoS) or the ones\n"
        "matching --topics, and writes each sample as protobuf to one MCAP channel per topic\n"
        "(log time = receipt, publish time = the sample's source_time_ns). Chunks are closed\n"
        "and synced every --flush-ms (default 100): a kill -9 loses at most that much.\n"
        "Stops after --duration-s or on SIGINT/SIGTERM, then prints per topic the samples\n"
        "received and the loss seen from tick numbers.\n"
        "topics: hexa_LegSensors hexa_ValveCommand hexa_ImuSample hexa_LegSetpoint\n"
        "        hexa_PoseReport hexa_GroundTruth hexa_OperatorCommand hexa_NodeStatus\n"
        "        hexa_FaultEvent\n",
        stdout);
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
  const TopicFilter filter{a.GetAll("topics"), a.GetAll("exclude")};
  const bool quiet = a.Has("quiet");

  McapWriterConfig cfg;
  cfg.chunk_max_span_ns = static_cast<uint64_t>(flush_ms * 1e6);
  cfg.sync = ParseSync(a.Get("sync", "fdatasync"));
  std::optional<std::string> dds_config;
  if (a.Has("dds-config")) dds_config = a.Get("dds-config", "");
  comm::EnsureDdsConfig(dds_config);
  comm::Participant participant(ParseDomain(a));
  comm::ShutdownGuard shutdown(participant);
  RecordingWriter writer(cfg);
  writer.Open(out);
  std::vector<std::unique_ptr<TopicRecorderBase>> topics;
  const comm::QosParams params;
  ForEachTopicType([&](auto pair) {
    using T = typename decltype(pair)::Dds;
    using P = typename decltype(pair)::Proto;
    if (!filter.Matches(std::string(comm::TopicName(comm::TopicTraits<T>::kKind)))) return;
    topics.push_back(std::make_unique<TopicRecorder<T, P>>(participant, writer, params));
  });
  if (topics.empty()) throw UsageError("--topics/--exclude leave no topic to record");
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
  if (!quiet)
    std::fprintf(stderr, "record: domain %d, %zu topics -> %s\n",
                 static_cast<int>(participant.domain_id()), topics.size(), out.c_str());

  const int64_t start_ns = comm::RealtimeNow_ns();
  const int64_t end_ns =
      duration_s > 0 ? start_ns + static_cast<int64_t>(duration_s * 1e9) : INT64_MAX;
  const int64_t flush_ns = static_cast<int64_t>(flush_ms * 1e6);
  int64_t next_flush_ns = start_ns + flush_ns;
  while (!shutdown.requested()) {
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
    }
  }
  for (auto& t : topics) t->Drain(writer);  // what arrived before the stop
  status.state = hexa_msg_NODE_STOPPING;
  status_writer.WriteNow(status);
  writer.Close();

  const double elapsed_s = static_cast<double>(comm::RealtimeNow_ns() - start_ns) * 1e-9;
  std::printf("recorded %.3f s to %s: %" PRIu64 " messages, %" PRIu64 " chunks, %" PRIu64
              " bytes\n",
              elapsed_s, out.c_str(), writer.mcap().stats().messages,
              writer.mcap().stats().chunks, writer.mcap().stats().bytes);
  std::printf("%-22s %10s %10s %8s %12s %12s\n", "topic", "received", "missing", "gaps",
              "dds_lost", "dds_rejected");
  for (const auto& t : topics) {
    uint64_t missing = 0, gaps = 0;
    for (const auto& l : t->loss.Results()) {
      missing += l.missing;
      gaps += l.gaps;
    }
    const comm::StatusSnapshot st = t->Status();
    std::printf("%-22s %10" PRIu64 " %10s %8s %12u %12u\n", t->name.c_str(), t->received,
                t->periodic ? std::to_string(missing).c_str() : "-",
                t->periodic ? std::to_string(gaps).c_str() : "-", st.sample_lost_total,
                st.sample_rejected_total);
  }
  return kExitOk;
}

// --------------------------------------------------------------------------------- play

namespace {

struct TopicPlayerBase {
  virtual ~TopicPlayerBase() = default;
  // false: the message could not be converted (reported once per channel by the caller).
  virtual bool Publish(std::string_view data) = 0;
  uint64_t published = 0;
  uint64_t refused = 0;
};

template <typename T, typename P>
class TopicPlayer final : public TopicPlayerBase {
 public:
  TopicPlayer(const comm::Participant& p, const comm::QosParams& params)
      : topic_(p), writer_(p, topic_, params) {}
  bool Publish(std::string_view data) override {
    T sample{};
    if (!msg_.ParseFromArray(data.data(), static_cast<int>(data.size())) ||
        !FromProto(msg_, sample)) {
      ++refused;
      return false;
    }
    // The sample keeps its recorded header; DDS gets the replay time as source timestamp.
    const dds_return_t rc = writer_.Write(sample, comm::RealtimeNow_ns());
    if (rc < 0) throw std::runtime_error("write failed: " + std::string(dds_strretcode(rc)));
    ++published;
    return true;
  }

 private:
  comm::Topic<T> topic_;
  comm::Writer<T> writer_;
  P msg_;
};

struct StopPlayback {};

}  // namespace

int RunPlay(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv,
                           {"domain", "rate", "start-s", "topics", "exclude", "dds-config",
                            "deadline-s", "wait-readers-s"},
                           {"loop", "no-progress"});
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
        "A progress line goes to stderr unless --no-progress.\n",
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
  const TopicFilter filter{a.GetAll("topics"), a.GetAll("exclude")};
  comm::QosParams params;
  if (a.Has("deadline-s")) params.deadline_period_s = a.GetDouble("deadline-s", 0.0);
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
        owned.push_back(std::make_unique<TopicPlayer<T, P>>(participant, params));
        player = owned.back().get();
      }
      players[id] = player;
    });
    if (!found)
      std::fprintf(stderr, "play: skipping channel '%s': not a topic of this system\n",
                   ch.topic.c_str());
  }
  if (players.empty()) throw UsageError("no channel of the recording is selected for playback");

  if (a.Has("wait-readers-s")) {
    // Give late-joining readers (volatile topics) the chance to match before data flows.
    const double wait_s = a.GetDouble("wait-readers-s", 0.0);
    const int64_t until = comm::RealtimeNow_ns() + static_cast<int64_t>(wait_s * 1e9);
    waitset.WaitUntil(static_cast<dds_time_t>(until));
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
