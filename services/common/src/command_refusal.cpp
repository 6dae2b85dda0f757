#include "hexa/services/command_refusal.hpp"

#include <cstdio>
#include <exception>
#include <string>

namespace hexa::node {

void CommandRefusals::Refuse(dds_entity_t reader, const dds_sample_info_t& info,
                             comm::CommandTrust trust, const char* topic, std::uint8_t leg,
                             std::uint64_t tick, FaultPublisher& faults, spdlog::logger& log) {
  ++samples_;
  const dds_instance_handle_t writer = info.publication_handle;
  std::size_t reported = 0;
  while (reported < reported_.size() && reported_[reported] != 0 && reported_[reported] != writer)
    ++reported;
  const bool known = reported < reported_.size() && reported_[reported] == writer;
  if (known || (reported == reported_.size() && writer == last_unreported_)) {
    if (samples_ % 1000 == 0)
      log.warn("{}: {} samples refused so far, from {} writer(s) not of this session", topic,
               samples_, writers_);
    return;
  }
  ++writers_;
  if (reported == reported_.size()) {  // past the bound: counted only
    last_unreported_ = writer;
    return;
  }
  reported_[reported] = writer;
  try {
    const std::string who = comm::DescribeWriterIdentity(reader, writer);
    char detail[160];
    // The reason says why (FAULT_COMMAND_REFUSED); the detail names the writer, within the
    // wire's 160 characters.
    std::snprintf(detail, sizeof detail, "foreign %s writer refused: %s", topic, who.c_str());
    faults.Publish(leg, tick, hexa_msg_FAULT_COMMAND_REFUSED, detail);
    log.error("tick {}: FAULT_COMMAND_REFUSED: {} for leg {} from a writer not of this session "
              "({}): {}; its samples are refused (writer {} refused here{})", tick, topic,
              static_cast<int>(leg), comm::ToString(trust), who, writers_,
              writers_ == kMaxReported ? "; further writers are only counted" : "");
  } catch (const std::exception& e) {
    log.error("tick {}: FAULT_COMMAND_REFUSED: {} ({}) not described: {}", tick, topic,
              comm::ToString(trust), e.what());
  }
}

}  // namespace hexa::node
