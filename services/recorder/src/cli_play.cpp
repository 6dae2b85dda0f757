// hexa_recorder play: republishes a recording on its DDS topics, timed by its log times or
// (--lockstep, play_lockstep.cpp) tick by tick.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <map>
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
#include "hexa/recording/recording.hpp"
#include "hexa/recording/topic_types.hpp"
#include "play_lockstep.hpp"
#include "topic_player.hpp"
#include "topic_recorder.hpp"

namespace hexa::recorder::cli {
namespace {

constexpr const char* kPlayHelp =
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
        "       --answers-out new.mcap   (with hexa_leg_ctrl --mode lockstep x6 on the domain)\n";

LockstepOptions ParseLockstepOptions(const Args& a) {
  LockstepOptions lo;
  if (a.Has("loop")) throw UsageError("--loop does not combine with --lockstep");
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
  lo.progress = !a.Has("no-progress");
  return lo;
}

// First pass: the file is valid, which channels it has, its time span.
struct RecordingSpan {
  RecordingCatalog catalog;
  uint64_t first_log = UINT64_MAX, last_log = 0;
};

RecordingSpan ScanSpan(const std::string& path) {
  RecordingSpan s;
  McapReader r;
  r.Open(path);
  McapVisitor v;
  v.on_message = [&](const McapMessageView& m) {
    s.first_log = std::min(s.first_log, m.log_time_ns);
    s.last_log = std::max(s.last_log, m.log_time_ns);
  };
  r.Scan(v);
  s.catalog.schemas = r.schemas();
  s.catalog.channels = r.channels();
  if (s.first_log == UINT64_MAX) throw McapError("'" + path + "' holds no messages");
  return s;
}

// One writer per (topic, type) pair of the topic-type list; other channels are skipped.
struct Players {
  std::map<uint16_t, TopicPlayerBase*> by_channel;
  std::vector<std::unique_ptr<TopicPlayerBase>> owned;
};

Players MakePlayers(const RecordingCatalog& catalog, const TopicFilter& filter,
                    const comm::Participant& participant, const comm::QosParams& params,
                    bool keep_all) {
  Players out;
  std::map<std::string, TopicPlayerBase*> by_topic;
  for (const auto& [id, ch] : catalog.channels) {
    if (!filter.Matches(ch.topic)) continue;
    const auto schema = catalog.schemas.find(ch.schema_id);
    const std::string type = schema == catalog.schemas.end() ? "" : schema->second.name;
    bool found = false;
    ForEachTopicType([&](auto topic_type) {
      using T = typename decltype(topic_type)::Dds;
      using P = typename decltype(topic_type)::Proto;
      if (found || ch.topic != comm::TopicName(comm::TopicTraits<T>::kKind)) return;
      found = true;
      if (type != P::descriptor()->full_name()) {
        std::fprintf(stderr, "play: skipping channel '%s': schema '%s', expected '%s'\n",
                     ch.topic.c_str(), type.c_str(), P::descriptor()->full_name().c_str());
        return;
      }
      auto& player = by_topic[ch.topic];
      if (player == nullptr) {
        out.owned.push_back(std::make_unique<TopicPlayer<T, P>>(participant, params, keep_all));
        player = out.owned.back().get();
      }
      out.by_channel[id] = player;
    });
    if (!found)
      std::fprintf(stderr, "play: skipping channel '%s': not a topic of this system\n",
                   ch.topic.c_str());
  }
  if (out.by_channel.empty()) throw UsageError("no channel of the recording is selected for playback");
  return out;
}

// Give late-joining readers (volatile topics) the chance to match before data flows: up
// to S seconds until every published topic has at least one reader.
void WaitForReaders(double wait_s, const Players& players, comm::WaitSet& waitset,
                    const comm::ShutdownGuard& shutdown) {
  const int64_t until = comm::RealtimeNow_ns() + static_cast<int64_t>(wait_s * 1e9);
  while (!shutdown.requested() && comm::RealtimeNow_ns() < until) {
    bool all = true;
    for (const auto& p : players.owned) all = all && p->Status().publication_matched_current >= 1;
    if (all) break;
    waitset.WaitUntil(std::min(static_cast<dds_time_t>(until),
                               static_cast<dds_time_t>(comm::RealtimeNow_ns() + 20'000'000)));
  }
}

struct TimedPlayback {
  std::string path;
  uint64_t start_log = 0, last_log = 0;
  double rate = 1.0;
  bool loop = false, progress = true;
};

// Plays the recording with its recorded timing (log-time differences / rate), once or in a loop.
int PlayTimed(const TimedPlayback& o, const RecordingCatalog& catalog, const Players& players,
              comm::WaitSet& waitset, const comm::ShutdownGuard& shutdown) {
  uint64_t total_published = 0, total_refused = 0;
  int64_t last_progress_ns = 0;
  uint64_t loops = 0;
  const double span_s = static_cast<double>(o.last_log - o.start_log) * 1e-9;
  try {
    do {
      const int64_t wall0 = comm::RealtimeNow_ns();
      McapReader r;
      r.Open(o.path);
      McapVisitor v;
      v.on_message = [&](const McapMessageView& m) {
        if (shutdown.requested()) throw StopPlayback{};
        if (m.log_time_ns < o.start_log) return;
        auto it = players.by_channel.find(m.channel_id);
        if (it == players.by_channel.end()) return;
        if (o.rate > 0.0) {
          const int64_t due = wall0 + static_cast<int64_t>(
                                          static_cast<double>(m.log_time_ns - o.start_log) / o.rate);
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
        if (o.progress && now - last_progress_ns > 250'000'000) {
          last_progress_ns = now;
          std::fprintf(stderr, "\rplay: %8.3f / %.3f s  %" PRIu64 " messages  loop %" PRIu64 "  ",
                       static_cast<double>(m.log_time_ns - o.start_log) * 1e-9, span_s,
                       total_published, loops + 1);
        }
      };
      r.Scan(v);
      ++loops;
    } while (o.loop && !shutdown.requested());
  } catch (const StopPlayback&) {
  }
  if (o.progress) std::fputc('\n', stderr);
  std::printf("played %" PRIu64 " messages (%" PRIu64 " refused) in %" PRIu64 " pass(es)%s\n",
              total_published, total_refused, loops, shutdown.requested() ? ", interrupted" : "");
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
    std::fputs(kPlayHelp, stdout);
    return kExitOk;
  }
  if (a.positional.size() != 1) throw UsageError("expected exactly one recording file");
  TimedPlayback timed;
  timed.path = a.positional[0];
  timed.rate = a.GetDouble("rate", 1.0);
  if (!(timed.rate >= 0.0)) throw UsageError("--rate must be >= 0");
  const double start_s = a.GetDouble("start-s", 0.0);
  if (!(start_s >= 0.0)) throw UsageError("--start-s must be >= 0");
  timed.loop = a.Has("loop");
  timed.progress = !a.Has("no-progress");
  const bool lockstep = a.Has("lockstep") || a.Has("answers-out");
  LockstepOptions lo;
  if (lockstep) lo = ParseLockstepOptions(a);
  const TopicFilter filter{a.GetAll("topics"), a.GetAll("exclude")};
  comm::QosParams params;
  // Timed playback writes as a real-time session does (periodic topics best effort: read it
  // with record --periodic-reliability best-effort); --lockstep as a lockstep one (reliable,
  // and keep-all: TopicPlayer).
  params.lockstep = lockstep;
  if (a.Has("deadline-s")) params.deadline_period_s = a.GetDouble("deadline-s", 0.0, /*allow_infinity=*/true);
  params.Validate();

  const RecordingSpan span = ScanSpan(timed.path);
  timed.start_log = span.first_log + static_cast<uint64_t>(start_s * 1e9);
  timed.last_log = span.last_log;
  if (timed.start_log > span.last_log)
    throw UsageError("--start-s " + std::to_string(start_s) + " is past the recording's end (" +
                     std::to_string(static_cast<double>(span.last_log - span.first_log) * 1e-9) + " s)");

  std::optional<std::string> dds_config;
  if (a.Has("dds-config")) dds_config = a.Get("dds-config", "");
  comm::EnsureDdsConfig(dds_config);
  comm::Participant participant(ParseDomain(a));
  comm::ShutdownGuard shutdown(participant);
  comm::WaitSet waitset(participant, 2);
  waitset.Attach(shutdown.guard_condition(), 0);
  const Players players = MakePlayers(span.catalog, filter, participant, params, lockstep);

  if (lockstep) {
    lo.start_log_ns = timed.start_log;
    return RunLockstepPlayback(timed.path, lo, span.catalog, players.by_channel, players.owned,
                               participant, shutdown);
  }
  if (a.Has("wait-readers-s")) WaitForReaders(a.GetDouble("wait-readers-s", 0.0), players, waitset, shutdown);
  return PlayTimed(timed, span.catalog, players, waitset, shutdown);
}

}  // namespace hexa::recorder::cli
