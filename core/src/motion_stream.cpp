// External motion stream: packet, decoder, limited follower (see motion_stream.hpp,
// docs/motion_stream.md "Motion stream").
#include "hexa/core/motion_stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

void PutU16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void PutU64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void PutF64(std::uint8_t* p, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  PutU64(p, bits);
}
std::uint16_t GetU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint64_t GetU64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
double GetF64(const std::uint8_t* p) {
  const std::uint64_t bits = GetU64(p);
  double v;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

}  // namespace

const char* ToString(StreamKind kind) {
  switch (kind) {
    case StreamKind::kPose: return "pose";
    case StreamKind::kVehicle: return "vehicle";
  }
  return "unknown";
}

const char* ToString(StreamPacketError error) {
  switch (error) {
    case StreamPacketError::kOk: return "ok";
    case StreamPacketError::kWrongSize: return "wrong size";
    case StreamPacketError::kBadMagic: return "bad magic";
    case StreamPacketError::kWrongVersion: return "wrong version";
    case StreamPacketError::kUnknownKind: return "unknown kind";
    case StreamPacketError::kNotFinite: return "not finite";
    case StreamPacketError::kAbsurdValue: return "absurd value";
    case StreamPacketError::kWrongKind: return "wrong kind";
    case StreamPacketError::kDuplicate: return "duplicate";
    case StreamPacketError::kLate: return "late";
    case StreamPacketError::kCount: break;
  }
  return "unknown";
}

const char* ToString(StreamState state) {
  switch (state) {
    case StreamState::kWaiting: return "waiting";
    case StreamState::kStreaming: return "streaming";
    case StreamState::kReturning: return "returning to neutral";
  }
  return "unknown";
}

void EncodeStreamPacket(const StreamPacket& packet,
                        std::array<std::uint8_t, kStreamPacketSize>& out) {
  std::memcpy(out.data(), kStreamPacketMagic, 4);
  PutU16(out.data() + 4, kStreamPacketVersion);
  PutU16(out.data() + 6, static_cast<std::uint16_t>(packet.kind));
  PutU64(out.data() + 8, packet.sequence);
  PutF64(out.data() + 16, packet.time_s);
  for (int i = 0; i < 6; ++i) PutF64(out.data() + 24 + 8 * i, packet.values[i]);
}

StreamDecodeResult DecodeStreamPacket(const std::uint8_t* data, std::size_t size,
                                      const StreamDecodeLimits& limits, StreamPacket& packet) {
  StreamDecodeResult r;
  if (data == nullptr || size != kStreamPacketSize) {
    r.error = StreamPacketError::kWrongSize;
    r.value = static_cast<double>(data == nullptr ? 0 : size);
    return r;
  }
  if (std::memcmp(data, kStreamPacketMagic, 4) != 0) {
    r.error = StreamPacketError::kBadMagic;
    return r;
  }
  const std::uint16_t version = GetU16(data + 4);
  if (version != kStreamPacketVersion) {
    r.error = StreamPacketError::kWrongVersion;
    r.value = version;
    return r;
  }
  const std::uint16_t kind = GetU16(data + 6);
  if (kind != static_cast<std::uint16_t>(StreamKind::kPose) &&
      kind != static_cast<std::uint16_t>(StreamKind::kVehicle)) {
    r.error = StreamPacketError::kUnknownKind;
    r.value = kind;
    return r;
  }
  const double time_s = GetF64(data + 16);
  Vector6d values;
  for (int i = 0; i < 6; ++i) values[i] = GetF64(data + 24 + 8 * i);
  if (!std::isfinite(time_s)) return StreamDecodeResult{StreamPacketError::kNotFinite, -1, time_s};
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(values[i])) return StreamDecodeResult{StreamPacketError::kNotFinite, i, values[i]};
  }
  if (!(std::abs(time_s) <= limits.max_abs_time_s)) {
    return StreamDecodeResult{StreamPacketError::kAbsurdValue, -1, time_s};
  }
  const bool pose = kind == static_cast<std::uint16_t>(StreamKind::kPose);
  for (int i = 0; i < 6; ++i) {
    const double bound = pose ? (i < 3 ? limits.max_abs_position_m : limits.max_abs_angle_rad)
                              : (i < 3 ? limits.max_abs_acceleration_m_s2 : limits.max_abs_rate_rad_s);
    if (!(std::abs(values[i]) <= bound)) {
      return StreamDecodeResult{StreamPacketError::kAbsurdValue, i, values[i]};
    }
  }
  packet.kind = static_cast<StreamKind>(kind);
  packet.sequence = GetU64(data + 8);
  packet.time_s = time_s;
  packet.values = values;
  return r;
}

void StreamCounters::Count(const StreamDecodeResult& result) {
  ++by_reason[static_cast<std::size_t>(result.error)];
  if (result.error == StreamPacketError::kOk) {
    ++applied;
  } else {
    last_refusal = result;
  }
}

std::uint64_t StreamCounters::refused() const {
  std::uint64_t n = 0;
  for (std::size_t i = 1; i < by_reason.size(); ++i) n += by_reason[i];
  return n;
}

void MotionStreamConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.InClosed("stream.timeout_s", timeout_s, 0.005, 5.0, "stream timeout");
  c.InClosed("stream.period_s", period_s, 0.0005, 0.1, "update period");
  for (const auto& [name, l] : {std::pair<const char*, const AxisLimits&>{"linear", linear},
                                {"angular", angular}}) {
    const std::string p = std::string("stream.") + name + ".";
    c.Positive(p + "max_speed", l.max_speed, "speed limit");
    c.Positive(p + "max_acceleration", l.max_acceleration, "acceleration limit");
    c.Positive(p + "max_jerk", l.max_jerk, "jerk limit");
  }
  c.Positive("stream.position_gain_1_s", position_gain_1_s, "position gain");
  c.Positive("stream.decode.max_abs_time_s", decode.max_abs_time_s, "time bound");
  c.Positive("stream.decode.max_abs_position_m", decode.max_abs_position_m, "position bound");
  c.Positive("stream.decode.max_abs_angle_rad", decode.max_abs_angle_rad, "angle bound");
  c.Positive("stream.decode.max_abs_acceleration_m_s2", decode.max_abs_acceleration_m_s2,
             "acceleration bound");
  c.Positive("stream.decode.max_abs_rate_rad_s", decode.max_abs_rate_rad_s, "rate bound");
  if (kind == StreamKind::kVehicle && std::isfinite(period_s) &&
      !(std::abs(washout.period_s - period_s) <= 1e-12)) {
    c.Fail("stream.washout.period_s", "the washout must run at the stream's update period",
           FormatParam(washout.period_s), "= " + FormatParam(period_s));
  }
  ThrowIfIssues(issues, "motion stream");
}

MotionStream::MotionStream(const MotionStreamConfig& config)
    : config_(config), washout_(config.washout) {
  config_.Validate();
}

void MotionStream::Apply(const StreamPacket& packet, double time_s) {
  if (packet.kind != config_.kind) {
    counters_.Count(StreamDecodeResult{StreamPacketError::kWrongKind, -1,
                                       static_cast<double>(packet.kind)});
    return;
  }
  if (active_) {
    if (packet.sequence == newest_sequence_) {
      counters_.Count(StreamDecodeResult{StreamPacketError::kDuplicate, -1,
                                         static_cast<double>(packet.sequence)});
      return;
    }
    if (packet.sequence < newest_sequence_) {
      counters_.Count(StreamDecodeResult{StreamPacketError::kLate, -1,
                                         static_cast<double>(packet.sequence)});
      return;
    }
    counters_.missing += packet.sequence - newest_sequence_ - 1;
  }
  // Target velocity from two consecutive applied packets (pose kind): the follower's feed-forward.
  if (config_.kind == StreamKind::kPose && active_ && have_latest_) {
    const double dt = packet.time_s - latest_.time_s;
    target_velocity_ = dt > 0.0 && dt <= config_.timeout_s
                           ? Vector6d((packet.values - latest_.values) / dt)
                           : Vector6d::Zero();
  } else {
    target_velocity_.setZero();
  }
  if (!active_) washout_.Reset();
  active_ = true;
  newest_sequence_ = packet.sequence;
  latest_ = packet;
  have_latest_ = true;
  last_applied_time_s_ = time_s;
  counters_.Count(StreamDecodeResult{});
}

void MotionStream::Restart() noexcept {
  washout_.Reset();
  for (AxisMotionState& a : axis_) a = AxisMotionState{};
  displacement_.setZero();
  target_.setZero();
  target_velocity_.setZero();
  have_latest_ = false;
  active_ = false;
  newest_sequence_ = 0;
  last_applied_time_s_ = 0.0;
  state_ = StreamState::kWaiting;
}

void MotionStream::Update(const MotionStreamInput& input, MotionStreamOutput& output) noexcept {
  output.timed_out = false;
  if (input.return_to_neutral) {
    if (active_) state_ = StreamState::kReturning;
    active_ = false;
    have_latest_ = false;
  } else {
    for (std::size_t i = 0; i < input.packet_count && input.packets != nullptr; ++i) {
      Apply(input.packets[i], input.time_s);
    }
  }
  const double since = active_ ? input.time_s - last_applied_time_s_ : 0.0;
  if (active_ && !(since <= config_.timeout_s)) {
    active_ = false;  // the next packet starts afresh, whatever its sequence
    have_latest_ = false;
    ++counters_.timeouts;
    output.timed_out = true;
    state_ = StreamState::kReturning;
  }
  if (active_) {
    state_ = StreamState::kStreaming;
    if (config_.kind == StreamKind::kVehicle) {
      WashoutInput w;
      w.acceleration_m_s2 = latest_.values.head<3>();
      w.angular_rate_rad_s = latest_.values.tail<3>();
      WashoutOutput out;
      washout_.Update(w, out);
      target_velocity_ = (out.displacement - target_) / config_.period_s;
      target_ = out.displacement;
    } else {
      target_ = latest_.values;
    }
  } else {
    target_.setZero();
    target_velocity_.setZero();
    if (state_ == StreamState::kReturning && displacement_.isZero(0.0)) {
      bool still = true;
      for (const AxisMotionState& a : axis_) still = still && a.velocity == 0.0 && a.acceleration == 0.0;
      if (still) state_ = StreamState::kWaiting;
    }
  }
  const double dt = config_.period_s;
  for (int k = 0; k < 6; ++k) {
    const AxisLimits& limits = k < 3 ? config_.linear : config_.angular;
    const double e = target_[k] - displacement_[k];
    const double correction = std::min(config_.position_gain_1_s * std::abs(e),
                                       std::sqrt(limits.max_acceleration * std::abs(e)));
    const double desired = target_velocity_[k] + (e < 0.0 ? -correction : correction);
    const double v_before = axis_[k].velocity;
    StepJerkLimitedVelocity(desired, limits, dt, axis_[k]);
    displacement_[k] += 0.5 * (v_before + axis_[k].velocity) * dt;
    // Settled on a still target (sub-nanometre, sub-nm/s): end exactly there, at rest, rather
    // than creep towards it forever (the jump is below 1e-9 m/s^2).
    if (target_velocity_[k] == 0.0 && std::abs(target_[k] - displacement_[k]) < 1e-9 &&
        std::abs(axis_[k].velocity) < 1e-9 && std::abs(axis_[k].acceleration) < 1e-9) {
      displacement_[k] = target_[k];
      axis_[k] = AxisMotionState{};
    }
    output.velocity[k] = axis_[k].velocity;
    output.acceleration[k] = axis_[k].acceleration;
  }
  output.displacement = displacement_;
  output.target = target_;
  output.state = state_;
  output.since_packet_s = since;
}

}  // namespace hexa
