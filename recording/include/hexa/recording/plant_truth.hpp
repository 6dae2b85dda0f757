// The simulated plant's true parameters and the session description as recording messages
// (proto/identification.proto), and a file-level tool that adds such messages to a finished
// recording as their own channels (hexa_recorder attach). docs/identification.md.
#pragma once

#include <google/protobuf/message.h>

#include <string>
#include <utility>
#include <vector>

#include "hexa/core/platform_plant.hpp"
#include "identification.pb.h"

namespace hexa::recorder {

inline constexpr const char* kPlantTruthTopic = "hexa_PlantTruth";    // evaluation only
inline constexpr const char* kSessionInfoTopic = "hexa_SessionInfo";

// What the plant simulates for this profile and seed: per leg the friction and polytropic
// coefficients after the profile's scales, the true joints and potentiometer calibration;
// the payload.
rec::PlantTruth MakePlantTruth(const PlatformPlant& plant, const std::string& rig_name,
                               const std::string& profile);

// Copies `path` into a new file with one more channel per message (topic, message), each
// message logged at the recording's first log time, then replaces `path`. A channel that
// already exists is an error (McapError). Returns the number of messages copied.
std::uint64_t AttachMessages(const std::string& path,
                             const std::vector<std::pair<std::string, const google::protobuf::Message*>>& messages);

}  // namespace hexa::recorder
