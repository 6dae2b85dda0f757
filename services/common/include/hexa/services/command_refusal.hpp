// Refused commands (docs/faults.md, "Foreign commands"): a reader of a command topic that
// refuses a sample (comm::CommandTrust not trusted) publishes FAULT_COMMAND_REFUSED naming the
// writer (GUID, partition, USER_DATA) the first time that writer is refused, and counts every
// refused sample. Bounded: at most kMaxReported writers are reported per reader, later ones
// are only counted (a process creating writers by the thousand cannot flood the fault topic).
#pragma once

#include <dds/dds.h>

#include <array>
#include <cstdint>

#include <spdlog/spdlog.h>

#include "hexa/comm/command_auth.hpp"
#include "hexa/services/node.hpp"

namespace hexa::node {

class CommandRefusals {
 public:
  static constexpr std::size_t kMaxReported = 16;

  // A sample of `topic` written by `info.publication_handle`, refused by `reader` for `trust`.
  // The first refusal of a writer is published (`leg`: the leg whose command it was, 0 none)
  // and logged with the writer's identity (allocates: the writer's discovery data); later ones
  // are counted, and logged at every 1000th. Never throws.
  void Refuse(dds_entity_t reader, const dds_sample_info_t& info, comm::CommandTrust trust,
              const char* topic, std::uint8_t leg, std::uint64_t tick, FaultPublisher& faults,
              spdlog::logger& log);

  std::uint64_t samples() const { return samples_; }
  std::size_t writers() const { return writers_; }

 private:
  std::array<dds_instance_handle_t, kMaxReported> reported_{};
  std::size_t writers_ = 0;  // distinct writers refused (reported or not)
  std::uint64_t samples_ = 0;
  dds_instance_handle_t last_unreported_ = 0;
};

}  // namespace hexa::node
