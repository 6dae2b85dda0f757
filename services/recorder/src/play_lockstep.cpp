#include "play_lockstep.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "hexa/comm/time.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/core/lockstep_clock.hpp"
#include "topic_recorder.hpp"

namespace hexa::recorder::cli {
namespace {

class LockstepPlayback {
 public:
  LockstepPlayback(const std::string& path, const LockstepOptions& o,
                   const RecordingCatalog& catalog,
                   const std::map<uint16_t, TopicPlayerBase*>& players,
                   const std::vector<std::unique_ptr<TopicPlayerBase>>& owned,
                   comm::Participant& participant, comm::ShutdownGuard& shutdown)
      : path_(path), o_(o), catalog_(catalog), owned_(owned), participant_(participant),
        shutdown_(shutdown), clock_(ClockParams(o)), waitset_(participant, 4) {
    SelectTickedTopics(players);
    waitset_.Attach(shutdown.guard_condition(), 0);
  }

  int Run() {
    clock_.Run(UINT64_MAX);  // the recording's last tick ends the replay, not the clock
    FindAnswerLegs();
    if (await_answers_) StartAnswers();
    WaitForPeers();
    bool interrupted = false;
    std::string error;
    try {
      ScanAndPlay();
    } catch (const StopPlayback&) {
      interrupted = true;
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (o_.progress) std::fputc('\n', stderr);
    if (answers_) {
      DrainAnswers();
      answers_writer_->Close();
    }
    return PrintSummary(interrupted, error);
  }

 private:
  struct Pending {
    TopicPlayerBase* player;
    std::string data;
    uint32_t leg;  // LegSensors and LegSetpoint: its leg, else 0
  };
  // The setpoints played so far, per leg (only their ticks matter): the protocol's rule says
  // whether a leg can answer a tick (a recording ends with ticks whose setpoint the finished
  // supervisor never issued; no controller can answer those, so they are not awaited).
  struct PlayedSetpoint {
    uint64_t tick = 0;
  };

  // The plant's clock with the replay's timeout; no recorder flow control: the replay's
  // writers keep all (a reader that falls behind throttles them, nothing is overwritten),
  // where the plant's keep a bounded history (docs/architecture.md, "Lockstep").
  static LockstepClockParams ClockParams(const LockstepOptions& o) {
    LockstepClockParams p;
    p.barrier.timeout_ns = static_cast<int64_t>(o.answer_timeout_s * 1e9);
    p.sync_every_ticks = 0;
    return p;
  }

  // Only periodic topics carry the tick that orders the replay.
  void SelectTickedTopics(const std::map<uint16_t, TopicPlayerBase*>& players) {
    for (const auto& [id, player] : players) {
      const std::string& topic = catalog_.channels.at(id).topic;
      bool periodic = false;
      for (int k = 0; k < comm::kTopicKindCount; ++k) {
        const auto kind = static_cast<comm::TopicKind>(k);
        if (comm::TopicName(kind) == topic) periodic = comm::NominalPeriod_s(kind).has_value();
      }
      if (!periodic) {
        std::fprintf(stderr, "play --lockstep: skipping event topic '%s' (no tick)\n", topic.c_str());
        continue;
      }
      ticked_[id] = player;
      if (topic == comm::kLegSensorsTopic) sensors_player_ = player;
      if (topic == comm::kLegSetpointTopic) setpoint_player_ = player;
    }
    if (ticked_.empty()) throw UsageError("play --lockstep: no periodic topic selected");
  }

  // The legs whose answers are awaited: --answer-legs, else every leg in the sensor stream.
  void FindAnswerLegs() {
    legs_ = o_.answer_legs;
    if (!await_answers_ || !legs_.empty()) return;
    if (sensors_player_ == nullptr)
      throw UsageError("play --answers-out needs hexa_LegSensors among the played topics");
    ReadRecording(path_, [&](const McapChannel& ch, const McapMessageView&,
                             const google::protobuf::Message& m) {
      if (ch.topic != comm::kLegSensorsTopic) return;
      if (const uint32_t leg = LegOfKey(MessageKey(m)); leg != 0) legs_.insert(leg);
    });
    if (legs_.empty()) throw UsageError("play --answers-out: the recording has no leg sensors");
  }

  // Answers: the ValveCommands of the controllers under test, recorded like `record` does.
  // The plant's lockstep clock (core/lockstep_clock.hpp) decides when a tick is complete,
  // asks a silent leg again and gives up, exactly as in the plant service.
  void StartAnswers() {
    answers_writer_ = std::make_unique<RecordingWriter>(McapWriterConfig{});
    answers_writer_->Open(o_.answers_out);
    answers_ = std::make_unique<TopicRecorder<hexa_msg_ValveCommand, rec::ValveCommand>>(
        participant_, *answers_writer_, comm::QosParams{});
    answers_->on_sample = [this](const google::protobuf::Message& m) {
      ++answers_received_;
      const auto tick = MessageTick(m);
      const uint32_t leg = LegOfKey(MessageKey(m));
      if (!tick || leg == 0) return;
      uint64_t& newest = answered_[leg];
      newest = std::max(newest, *tick);
      if (leg <= kNumLegs) clock_.Answer(static_cast<int>(leg), *tick);
    };
    answers_writer_->mcap().FlushChunk();
    waitset_.Attach(answers_->condition(), 1);
  }

  // What keeps playback from starting, "" when nothing: with answers, the controllers of every
  // awaited leg (their ValveCommand writers, sensor and setpoint readers); otherwise one
  // reader per topic.
  std::string MissingPeers() const {
    const uint32_t need = await_answers_ ? static_cast<uint32_t>(legs_.size()) : 1;
    std::string missing;
    if (await_answers_ && answers_->Status().subscription_matched_current < need)
      missing += " ValveCommand writers " +
                 std::to_string(answers_->Status().subscription_matched_current) + "/" +
                 std::to_string(need);
    for (const auto& p : owned_) {
      const bool must = !await_answers_ || p.get() == sensors_player_ || p.get() == setpoint_player_;
      if (must && p->Status().publication_matched_current < need)
        missing += " " + p->topic + " readers " +
                   std::to_string(p->Status().publication_matched_current) + "/" +
                   std::to_string(need);
    }
    return missing;
  }

  // Start when the peers are there.
  void WaitForPeers() {
    const int64_t until = comm::RealtimeNow_ns() + static_cast<int64_t>(o_.wait_readers_s * 1e9);
    for (;;) {
      const std::string missing = MissingPeers();
      if (missing.empty() || shutdown_.requested()) return;
      if (comm::RealtimeNow_ns() > until) {
        std::fprintf(stderr, "play --lockstep: peers missing after %.1f s:%s\n", o_.wait_readers_s,
                     missing.c_str());
        if (await_answers_) throw std::runtime_error("play --lockstep: the controllers under test "
                                                     "did not appear (--wait-readers-s)");
        return;
      }
      waitset_.Wait(DDS_MSECS(20));  // match counts change without data: bounded re-check
    }
  }

  void DrainAnswers() {
    if (answers_) answers_->Drain(*answers_writer_);
  }

  // Publishes one tick's messages; the legs whose answer to it is awaited.
  LegMask PublishTick(uint64_t tick, const std::vector<Pending>& msgs) {
    LegMask awaited = 0;
    for (const Pending& m : msgs) {
      if (!m.player->Publish(m.data)) {
        ++refused_;
        continue;
      }
      ++published_;
      if (m.leg == 0 || m.leg > kNumLegs) continue;
      if (m.player == setpoint_player_) {
        played_setpoints_[m.leg - 1].Add(PlayedSetpoint{tick});
      } else if (o_.answer_legs.empty() || legs_.count(m.leg)) {
        awaited = static_cast<LegMask>(awaited | LegBit(static_cast<int>(m.leg)));
      }
    }
    ++ticks_played_;
    if (o_.ack_every_ticks > 0 && ticks_played_ % o_.ack_every_ticks == 0) {
      for (const auto& p : owned_) {
        if (p->WaitForAcks(DDS_SECS(5)) == DDS_RETCODE_TIMEOUT) ++ack_timeouts_;
      }
    }
    return awaited;
  }

  // Waits until every awaited leg has answered `tick`, asking silent legs again as the plant
  // does; throws when the barrier gives up.
  void AwaitAnswers(uint64_t tick, const std::vector<Pending>& msgs, LegMask awaited) {
    if (setpoint_player_ != nullptr) {
      for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg) {
        if ((awaited & LegBit(leg)) &&
            !played_setpoints_[leg - 1].CanAnswer(tick, schedule_.supervisor_every_ticks)) {
          awaited = static_cast<LegMask>(awaited & ~LegBit(leg));
          ++unanswerable_;
        }
      }
    }
    clock_.Begin(tick, awaited, comm::MonotonicNow_ns());
    for (const auto& [leg, newest] : answered_)  // answered before this tick was played
      if (newest >= tick && leg <= kNumLegs) clock_.Answer(static_cast<int>(leg), tick);
    for (;;) {
      DrainAnswers();
      if (clock_.ReadyToStep()) return;
      if (shutdown_.requested()) throw StopPlayback{};
      const int64_t now = comm::MonotonicNow_ns();
      const LockstepClock::Silence silence = clock_.CheckSilence(now);
      if (silence.action == LockstepBarrier::Action::kTimeout) {
        std::string late;
        for (int leg = 1; leg <= static_cast<int>(kNumLegs); ++leg)
          if (silence.legs & LegBit(leg)) late += " " + std::to_string(leg);
        throw std::runtime_error("play --lockstep: tick " + std::to_string(tick) +
                                 " not answered within " + std::to_string(o_.answer_timeout_s) +
                                 " s by leg(s)" + late);
      }
      if (silence.action == LockstepBarrier::Action::kReask) {
        // As the plant does: the silent legs' sensor samples once more (a controller answers
        // a repeated tick from its cache). The supervisor is not asked again: its setpoints
        // are the recording's, published with their tick.
        for (const Pending& m : msgs) {
          if (m.player == sensors_player_ && m.leg >= 1 && m.leg <= kNumLegs &&
              (silence.legs & LegBit(static_cast<int>(m.leg))) && m.player->Publish(m.data))
            ++resent_;
        }
        continue;
      }
      waitset_.Wait(std::max<int64_t>(1'000'000, silence.next_check_ns - now));
    }
  }

  void PlayTick(uint64_t tick, const std::vector<Pending>& msgs) {
    const LegMask awaited = PublishTick(tick, msgs);
    if (await_answers_) AwaitAnswers(tick, msgs, awaited);
    const int64_t now = comm::RealtimeNow_ns();
    if (o_.progress && now - last_progress_ns_ > 250'000'000) {
      last_progress_ns_ = now;
      std::fprintf(stderr, "\rplay --lockstep: tick %" PRIu64 "  %" PRIu64 " messages  ", tick,
                   published_);
    }
  }

  void FlushBelow(uint64_t limit) {  // plays every buffered tick < limit
    while (!buffer_.empty() && buffer_.begin()->first < limit) {
      if (shutdown_.requested()) throw StopPlayback{};
      auto node = buffer_.extract(buffer_.begin());
      PlayTick(node.key(), node.mapped());
      next_tick_ = node.key() + 1;
    }
  }

  // Buffers one message by its tick; plays the ticks more than --reorder-ticks behind.
  void OnMessage(const McapMessageView& m) {
    if (shutdown_.requested()) throw StopPlayback{};
    if (m.log_time_ns < o_.start_log_ns) return;
    auto it = ticked_.find(m.channel_id);
    if (it == ticked_.end()) return;
    const google::protobuf::Message* msg = it->second->Parse(m.data);
    const std::optional<uint64_t> tick = msg ? MessageTick(*msg) : std::nullopt;
    if (!tick) {
      ++refused_;
      return;
    }
    if (started_ && *tick < next_tick_)
      throw std::runtime_error(
          "play --lockstep: a message of tick " + std::to_string(*tick) + " on '" +
          catalog_.channels.at(m.channel_id).topic + "' comes after tick " +
          std::to_string(next_tick_ - 1) + " was played: raise --reorder-ticks (now " +
          std::to_string(o_.reorder_ticks) + ")");
    uint32_t leg = 0;
    if (it->second == sensors_player_ || it->second == setpoint_player_)
      leg = LegOfKey(MessageKey(*msg));
    buffer_[*tick].push_back(Pending{it->second, std::string(m.data), leg});
    const uint64_t newest = buffer_.rbegin()->first;
    if (newest >= o_.reorder_ticks) {
      const uint64_t limit = newest - o_.reorder_ticks;
      if (!buffer_.empty() && buffer_.begin()->first < limit) {
        started_ = true;
        FlushBelow(limit);
      }
    }
  }

  void ScanAndPlay() {
    McapReader r;
    r.Open(path_);
    McapVisitor v;
    v.on_message = [this](const McapMessageView& m) { OnMessage(m); };
    r.Scan(v);
    started_ = true;
    FlushBelow(UINT64_MAX);
    for (const auto& p : owned_) {  // the last samples reach every reliable reader
      if (p->WaitForAcks(DDS_SECS(10)) == DDS_RETCODE_TIMEOUT) ++ack_timeouts_;
    }
  }

  int PrintSummary(bool interrupted, const std::string& error) const {
    std::printf("played %" PRIu64 " messages in %" PRIu64 " ticks (%" PRIu64
                " refused, %" PRIu64 " acknowledgement timeouts)%s\n",
                published_, ticks_played_, refused_, ack_timeouts_, interrupted ? ", interrupted" : "");
    if (answers_)
      std::printf("lockstep: %" PRIu64 " sensor samples re-published to silent legs; %" PRIu64
                  " leg-ticks not awaited (their setpoint is not in the recording)\n",
                  resent_, unanswerable_);
    if (answers_) {
      std::printf("answers: %" PRIu64 " ValveCommands -> %s; newest tick per leg:", answers_received_,
                  o_.answers_out.c_str());
      for (const auto& [leg, tick] : answered_) std::printf(" %u:%" PRIu64, leg, tick);
      std::printf("\n");
    }
    if (!error.empty()) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitError;
    }
    return kExitOk;
  }

  const std::string& path_;
  const LockstepOptions& o_;
  const RecordingCatalog& catalog_;
  const std::vector<std::unique_ptr<TopicPlayerBase>>& owned_;
  comm::Participant& participant_;
  comm::ShutdownGuard& shutdown_;
  const bool await_answers_ = !o_.answers_out.empty();

  std::map<uint16_t, TopicPlayerBase*> ticked_;
  TopicPlayerBase* sensors_player_ = nullptr;
  TopicPlayerBase* setpoint_player_ = nullptr;
  std::set<uint32_t> legs_;

  std::unique_ptr<RecordingWriter> answers_writer_;
  std::unique_ptr<TopicRecorderBase> answers_;
  LockstepClock clock_;
  comm::WaitSet waitset_;
  uint64_t answers_received_ = 0;
  std::map<uint32_t, uint64_t> answered_;  // leg -> newest tick answered (for the summary)

  std::map<uint64_t, std::vector<Pending>> buffer_;
  uint64_t next_tick_ = 0;  // every tick below has been played
  bool started_ = false;
  uint64_t ticks_played_ = 0, published_ = 0, refused_ = 0, ack_timeouts_ = 0, resent_ = 0;
  uint64_t unanswerable_ = 0;  // leg-ticks not awaited: their setpoint is not in the recording
  int64_t last_progress_ns_ = 0;
  LegArray<SetpointRing<PlayedSetpoint, 2>> played_setpoints_{};
  const LockstepSchedule schedule_;
};

}  // namespace

int RunLockstepPlayback(const std::string& path, const LockstepOptions& o,
                        const RecordingCatalog& catalog,
                        const std::map<uint16_t, TopicPlayerBase*>& players,
                        const std::vector<std::unique_ptr<TopicPlayerBase>>& owned,
                        comm::Participant& participant, comm::ShutdownGuard& shutdown) {
  LockstepPlayback playback(path, o, catalog, players, owned, participant, shutdown);
  return playback.Run();
}

}  // namespace hexa::recorder::cli
