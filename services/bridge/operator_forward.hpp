// Operator input from Foxglove clients -> the supervisor's operator topic (docs/foxglove.md,
// "Operator input"). The WebSocket I/O thread hands over inputs that passed every check
// (operator_input.hpp) with Submit(); the DDS thread writes them with WritePending() as
// OperatorCommand, the message hexa_operator writes, on the same reliable keep-all topic.
#pragma once

#include <cstdint>
#include <deque>
#include <mutex>
#include <string>

#include <spdlog/logger.h>

#include "hexa/comm/participant.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/comm/writer.hpp"
#include "operator_input.hpp"

namespace hexa::bridge {

class OperatorForwarder {
 public:
  // `wake` is set on each Submit (a guard condition of the DDS thread's wait set).
  OperatorForwarder(const comm::Participant& participant, comm::GuardCondition& wake,
                    std::shared_ptr<spdlog::logger> log);

  // I/O thread: queues the input; returns what the client is told, or "" when it is refused
  // (no supervisor matched: nothing would read it; the reason is logged).
  std::string Submit(uint64_t client_id, const std::string& remote, const OperatorInput& input);
  // DDS thread: writes what was queued.
  void WritePending();

 private:
  struct Item {
    uint64_t client_id;
    std::string remote;
    OperatorInput input;
  };
  comm::Topic<hexa_msg_OperatorCommand> topic_;
  comm::Writer<hexa_msg_OperatorCommand> writer_;
  comm::GuardCondition& wake_;
  std::shared_ptr<spdlog::logger> log_;
  std::mutex mutex_;
  std::deque<Item> pending_;  // at most kMaxPending
  uint32_t sequence_ = 0;
  static constexpr std::size_t kMaxPending = 64;
};

}  // namespace hexa::bridge
