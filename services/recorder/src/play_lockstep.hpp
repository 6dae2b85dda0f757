// Lockstep playback (play --lockstep): the recording is published tick by tick, in tick order,
// through keep-all writers (a reliable reader that falls behind throttles the writer, nothing
// is overwritten) and, with --answers-out, the next tick starts only when every leg controller
// whose sensors were published has answered this one with its ValveCommand. That is the plant's lockstep
// protocol (docs/architecture.md), so a controller that keeps only the newest sensor sample
// (keep-last 1) never has a tick overwritten, whatever the machine's load: the replay is
// deterministic, unlike pacing by recorded log times (which carry the recorder's batching).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "hexa/comm/participant.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/recording/recording.hpp"
#include "topic_player.hpp"

namespace hexa::recorder::cli {

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

// Plays `path` through `players` (channel id -> writer; `owned` holds each writer once) and
// prints the summary; the exit code.
int RunLockstepPlayback(const std::string& path, const LockstepOptions& o,
                        const RecordingCatalog& catalog,
                        const std::map<uint16_t, TopicPlayerBase*>& players,
                        const std::vector<std::unique_ptr<TopicPlayerBase>>& owned,
                        comm::Participant& participant, comm::ShutdownGuard& shutdown);

}  // namespace hexa::recorder::cli
