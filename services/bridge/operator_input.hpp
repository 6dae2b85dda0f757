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

// {"command": "start", "trajectory": "combined"} | {"command": "stop" | "reset" | "home" | "stream"}
// | {"command": "jog", "frame": "work" | "tool", "velocity_m_s": [vx, vy, vz],
//    "angular_velocity_rad_s": [wx, wy, wz]}     (repeat within the dead-man time, 0.25 s)
// | {"command": "goal", "position_m": [x, y, z], "orientation_wxyz": [w, x, y, z]}
// | {"command": "frames", "pivot_m": [x, y, z], "tool_position_m": [x, y, z],
//    "tool_orientation_wxyz": [w, x, y, z], "work_position_m": [x, y, z],
//    "work_orientation_wxyz": [w, x, y, z]}   (pivot_m required; the tool and work fields
//    default to the identity: a frames command sets all three frames).
// start's trajectory is one of the named trajectories (x y z roll pitch yaw combined; default
// combined); a CSV path is not accepted from the network (hexa_operator on the host takes one).
// Every field of a jog or a goal must be present (frame defaults to work); the values are
// checked as the supervisor checks them (services/common operator_motion_wire.hpp): finite,
// not absurd, a unit quaternion; so are the frames' (a pivot more than 2 m away is absurd; the
// supervisor refuses beyond its own bounds, 0.5 m).
struct OperatorInput {
  enum class Command { kStart, kStop, kReset, kHome, kJog, kGoal, kStream, kFrames } command = Command::kStop;
  std::string trajectory;  // start only
  bool tool_frame = false;                    // jog
  double velocity_m_s[3] = {0, 0, 0};         // jog
  double angular_velocity_rad_s[3] = {0, 0, 0};  // jog
  double position_m[3] = {0, 0, 0};           // goal, base frame
  double orientation_wxyz[4] = {1, 0, 0, 0};  // goal
  double pivot_m[3] = {0, 0, 0};                   // frames: in the platform frame
  double tool_position_m[3] = {0, 0, 0};           // frames: in the platform frame
  double tool_orientation_wxyz[4] = {1, 0, 0, 0};  // frames
  double work_position_m[3] = {0, 0, 0};           // frames: in the base frame
  double work_orientation_wxyz[4] = {1, 0, 0, 0};  // frames
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
