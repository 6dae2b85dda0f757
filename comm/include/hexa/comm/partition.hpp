// Writer-side routing with DDS partitions. A reader matches a writer only if they share a
// partition, and a writer sends a sample only to the readers it matched: a partition per leg
// therefore delivers leg i's samples to leg i's controller process and to nobody else, while
// the topic, its type and its keyed instances stay the same (a reader that subscribes to
// every leg partition, e.g. the recorder, sees the topic exactly as before).
//
// This replaces the topic filter (Cyclone 0.10 applies it in the reader, after the datagram
// was sent, received and deserialized: a filtered reader pays for every sample of the topic).
// On loopback every reader process gets its own datagram per sample (lo has no multicast),
// so what is not routed costs a sendmsg and a receive-thread wake-up per reader and sample.
#pragma once

#include <dds/dds.h>

#include <string>
#include <vector>

#include "hexa/comm/participant.hpp"

namespace hexa::comm {

// Partition names of the control loop (docs/comm.md). The default partition (empty name)
// carries everything that is not routed.
std::string LegPartition(int leg_id);          // "hexa.leg1" .. "hexa.leg6"
inline constexpr const char* kPlantPartition = "hexa.plant";  // all legs in one writer

// Every leg partition 1..6 (readers that want every leg's samples one writer per leg).
std::vector<std::string> AllLegPartitions();

// A publisher / subscriber in `partitions` (throws DdsError). Empty `partitions`: no entity
// (0), the writer / reader is then created on the participant, in the default partition.
OwnedEntity CreatePublisher(const Participant& participant, const std::vector<std::string>& partitions);
OwnedEntity CreateSubscriber(const Participant& participant, const std::vector<std::string>& partitions);

}  // namespace hexa::comm
