// External motion stream (docs/motion_stream.md "Motion stream"): the UDP packet, its decoder, and
// the unit that turns a lossy, reordered stream into a rate-, acceleration- and jerk-limited
// displacement of the pivot frame from neutral (user_frames.hpp applies it, soft_limits.hpp
// holds it inside the limits). The socket is the caller's (services/common udp_stream.hpp);
// nothing here reads a clock or allocates in Update.
//
// Packet, version 1: 72 bytes, little-endian, no padding.
//   offset size type        field
//        0    4 char[4]     magic "HXMS"
//        4    2 uint16      version = 1
//        6    2 uint16      kind: 1 = pose, 2 = vehicle motion
//        8    8 uint64      sequence: +1 per packet, any start value
//       16    8 float64     time_s: the sender's clock (monotonic, any origin)
//       24   48 float64[6]  kind 1: displacement of the pivot from neutral in the work frame's
//                           axes: x_m y_m z_m roll_rad pitch_rad yaw_rad (pose.hpp angles)
//                           kind 2: vehicle acceleration without gravity ax ay az (m/s^2) and
//                           angular rate wx wy wz (rad/s), vehicle frame x forward, y left, z up
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "hexa/core/motion_profile.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/washout.hpp"

namespace hexa {

inline constexpr std::size_t kStreamPacketSize = 72;
inline constexpr std::uint16_t kStreamPacketVersion = 1;
inline constexpr char kStreamPacketMagic[4] = {'H', 'X', 'M', 'S'};

enum class StreamKind : std::uint16_t { kPose = 1, kVehicle = 2 };
const char* ToString(StreamKind kind);  // "pose", "vehicle"

struct StreamPacket {
  StreamKind kind = StreamKind::kPose;
  std::uint64_t sequence = 0;
  double time_s = 0.0;
  Vector6d values = Vector6d::Zero();
};

void EncodeStreamPacket(const StreamPacket& packet, std::array<std::uint8_t, kStreamPacketSize>& out);

// Why a datagram was not applied. Decoder errors first, then the stream unit's verdicts.
enum class StreamPacketError {
  kOk,
  kWrongSize,       // datagram length != 72
  kBadMagic,
  kWrongVersion,
  kUnknownKind,     // kind not 1 or 2
  kNotFinite,       // time or a value NaN / inf
  kAbsurdValue,     // beyond StreamDecodeLimits
  kWrongKind,       // valid, but not the kind this stream is configured for
  kDuplicate,       // sequence already applied
  kLate,            // older than the newest applied (reordered)
  kCount,
};
const char* ToString(StreamPacketError error);  // "wrong size", "bad magic", ...

struct StreamDecodeLimits {
  double max_abs_time_s = 1e9;
  double max_abs_position_m = 0.5;        // kind 1; the soft limits hold the real envelope
  double max_abs_angle_rad = 1.0;         // kind 1
  double max_abs_acceleration_m_s2 = 100.0;  // kind 2: ~10 g
  double max_abs_rate_rad_s = 20.0;       // kind 2
};

struct StreamDecodeResult {
  StreamPacketError error = StreamPacketError::kOk;
  int field = -1;        // for kNotFinite / kAbsurdValue: -1 time, 0..5 the value index
  double value = 0.0;    // the offending number (kWrongSize: the length; versions, kinds)
};

// Never reads beyond `size` bytes; `packet` is written only when the result is kOk.
StreamDecodeResult DecodeStreamPacket(const std::uint8_t* data, std::size_t size,
                                      const StreamDecodeLimits& limits, StreamPacket& packet);

// Counts per reason, and the reason of the most recent refusal.
struct StreamCounters {
  std::array<std::uint64_t, static_cast<std::size_t>(StreamPacketError::kCount)> by_reason{};
  std::uint64_t applied = 0;
  std::uint64_t missing = 0;      // sequence numbers skipped over (lost, or late arrivals)
  std::uint64_t timeouts = 0;     // gaps longer than the timeout
  StreamDecodeResult last_refusal;
  void Count(const StreamDecodeResult& result);
  std::uint64_t refused() const;  // every reason but kOk
};

struct MotionStreamConfig {
  StreamKind kind = StreamKind::kPose;
  double timeout_s = 0.1;            // no applied packet for longer -> return to neutral
  double period_s = 0.005;           // Update period (= washout period for kVehicle)
  AxisLimits linear{0.3, 3.0, 60.0};     // per axis of the displacement
  AxisLimits angular{0.5, 5.0, 100.0};
  double position_gain_1_s = 20.0;   // k of the follower (header of MotionStream)
  StreamDecodeLimits decode;
  WashoutConfig washout;             // kVehicle only
  // Throws std::invalid_argument naming field, value and limit.
  void Validate() const;
};

struct MotionStreamInput {
  double time_s = 0.0;                    // receiver's clock, this tick
  const StreamPacket* packets = nullptr;  // decoded packets received since the last tick,
  std::size_t packet_count = 0;           // in arrival order
  // An operator stop: the target is neutral from this tick on, packets are not applied (nor
  // counted); the follower brings the displacement back within the same limits.
  bool return_to_neutral = false;
};

enum class StreamState { kWaiting, kStreaming, kReturning };
const char* ToString(StreamState state);  // "waiting", "streaming", "returning to neutral"

struct MotionStreamOutput {
  Vector6d displacement = Vector6d::Zero();  // limited, [x y z roll pitch yaw]
  Vector6d velocity = Vector6d::Zero();
  Vector6d acceleration = Vector6d::Zero();
  Vector6d target = Vector6d::Zero();        // what the stream asks for (after washout)
  StreamState state = StreamState::kWaiting;
  bool timed_out = false;                    // a timeout began at this tick
  double since_packet_s = 0.0;
};

// Follower, per axis: the target's velocity v_ff (from the last two applied packets, by the
// sender's clock) plus a correction of the error e = target - displacement,
//   v_d = v_ff + sign(e) min(k |e|, sqrt(2 (A/2) |e|)),
// then StepJerkLimitedVelocity(v_d): |v| <= V, |a| <= A, |jerk| <= J whatever arrives.
// Sequence: a packet is applied if its sequence is newer than the newest applied; equal ->
// kDuplicate, older -> kLate (counted, dropped). After a timeout (or before the first packet)
// any sequence starts the stream afresh. During a gap longer than timeout_s the target is
// neutral (zero): the follower brings the platform back within the same limits.
class MotionStream {
 public:
  explicit MotionStream(const MotionStreamConfig& config);  // throws on an invalid config
  void Update(const MotionStreamInput& input, MotionStreamOutput& output) noexcept;
  const StreamCounters& counters() const { return counters_; }
  // A decoder refusal, counted beside the unit's own (the receiver calls it).
  void CountRefused(const StreamDecodeResult& result) { counters_.Count(result); }
  const MotionStreamConfig& config() const { return config_; }
  // A new stream from neutral, at rest (the counters are kept). Neither throws nor allocates.
  void Restart() noexcept;

 private:
  void Apply(const StreamPacket& packet, double time_s);

  MotionStreamConfig config_;
  WashoutFilter washout_;
  StreamCounters counters_;
  AxisMotionState axis_[6];
  Vector6d displacement_ = Vector6d::Zero();
  Vector6d target_ = Vector6d::Zero();
  Vector6d target_velocity_ = Vector6d::Zero();
  StreamPacket latest_;
  bool have_latest_ = false;
  bool active_ = false;
  std::uint64_t newest_sequence_ = 0;
  double last_applied_time_s_ = 0.0;
  StreamState state_ = StreamState::kWaiting;
};

}  // namespace hexa
