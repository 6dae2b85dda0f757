// The operator's inputs from a Foxglove client (docs/foxglove.md, "Operator input"): one JSON
// message on the client channel kOperatorInputTopic, checked before anything reaches the
// supervisor, and a per-client rate limit. Pure: no sockets, no DDS, no clock (time is an
// argument).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace hexa::bridge {

// The only topic a client may advertise, and the only encoding.
inline constexpr const char* kOperatorInputTopic = "hexa_OperatorInput";
inline constexpr const char* kOperatorInputEncoding = "json";
inline constexpr const char* kOperatorInputSchemaName = "hexa.OperatorInput";

// {"command": "start", "trajectory": "combined"} | {"command": "stop" | "reset" | "home"}.
// start's trajectory is one of the named trajectories (x y z roll pitch yaw combined; default
// combined); a CSV path is not accepted from the network (hexa_operator on the host takes one).
struct OperatorInput {
  enum class Command { kStart, kStop, kReset, kHome } command = Command::kStop;
  std::string trajectory;  // start only
};
const char* CommandName(OperatorInput::Command c);

struct OperatorInputResult {
  bool ok = false;
  OperatorInput input;
  std::string error;  // what is wrong, for the client's status message
};
OperatorInputResult ParseOperatorInput(std::string_view json_text);

// Token bucket: at most `burst` messages at once, refilled at `rate_hz`. Allow(now) takes a
// token if there is one.
class RateLimiter {
 public:
  RateLimiter(double rate_hz, double burst) : rate_hz_(rate_hz), burst_(burst), tokens_(burst) {}
  bool Allow(int64_t now_ns);

 private:
  double rate_hz_, burst_, tokens_;
  int64_t last_ns_ = 0;
  bool started_ = false;
};

}  // namespace hexa::bridge
