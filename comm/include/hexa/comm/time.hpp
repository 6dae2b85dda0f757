// Source timestamps. Every sample carries CLOCK_REALTIME at write (header.source_time_ns or
// source_time_ns) and the same value is handed to dds_write_ts, so a recording shows
// latency (reception - source) and ordering per writer.
#pragma once

#include <cstdint>

#include "hexa.h"

namespace hexa::comm {

// CLOCK_REALTIME in ns since the epoch (the unit of dds_time_t).
int64_t RealtimeNow_ns();

// Fills a header with the plant tick and simulated time it belongs to and a source time.
inline void FillHeader(hexa_msg_SampleHeader& header, uint64_t tick, double sim_time_s,
                       int64_t source_time_ns) {
  header.tick = tick;
  header.sim_time_s = sim_time_s;
  header.source_time_ns = source_time_ns;
}

}  // namespace hexa::comm
