// External motion stream: the packet layout, the decoder's refusals (each named and counted,
// never applied), sequence handling (loss, duplicates, reordering), the limited follower under
// 1 % and 5 % loss with reordering and a 0.5 s gap (limits never exceeded, smooth return to
// neutral), and the vehicle kind through the washout.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/motion_stream.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::Sampler;
using Bytes = std::array<std::uint8_t, kStreamPacketSize>;

StreamPacket PosePacket(std::uint64_t sequence, double time_s, double x_m) {
  StreamPacket p;
  p.kind = StreamKind::kPose;
  p.sequence = sequence;
  p.time_s = time_s;
  p.values[0] = x_m;
  return p;
}

TEST(StreamPacket, LayoutIsLittleEndianAtTheDocumentedOffsets) {
  StreamPacket p = PosePacket(0x0102030405060708ull, 1.5, 0.25);
  p.values[5] = -0.125;
  Bytes b{};
  EncodeStreamPacket(p, b);
  EXPECT_EQ(std::memcmp(b.data(), "HXMS", 4), 0);
  EXPECT_EQ(b[4], 1);  // version
  EXPECT_EQ(b[5], 0);
  EXPECT_EQ(b[6], 1);  // kind pose
  EXPECT_EQ(b[8], 0x08);
  EXPECT_EQ(b[15], 0x01);
  double time_s, yaw;
  std::memcpy(&time_s, b.data() + 16, 8);  // this machine is little-endian (x86-64)
  std::memcpy(&yaw, b.data() + 24 + 40, 8);
  EXPECT_EQ(time_s, 1.5);
  EXPECT_EQ(yaw, -0.125);
  StreamPacket back;
  ASSERT_EQ(DecodeStreamPacket(b.data(), b.size(), {}, back).error, StreamPacketError::kOk);
  EXPECT_EQ(back.sequence, p.sequence);
  EXPECT_EQ(back.values, p.values);
}

TEST(StreamPacket, BadPacketsAreRefusedWithTheirReason) {
  const StreamDecodeLimits limits;
  Bytes good{};
  EncodeStreamPacket(PosePacket(1, 0.0, 0.01), good);
  StreamPacket out = PosePacket(99, 9.0, 0.0);
  const StreamPacket untouched = out;
  auto decode = [&](const Bytes& b, std::size_t size) {
    return DecodeStreamPacket(b.data(), size, limits, out);
  };
  EXPECT_EQ(decode(good, 71).error, StreamPacketError::kWrongSize);
  EXPECT_EQ(decode(good, 71).value, 71.0);
  EXPECT_EQ(decode(good, 0).error, StreamPacketError::kWrongSize);
  std::vector<std::uint8_t> longer(good.begin(), good.end());
  longer.push_back(0);
  EXPECT_EQ(DecodeStreamPacket(longer.data(), longer.size(), limits, out).error,
            StreamPacketError::kWrongSize);
  Bytes b = good;
  b[0] = 'X';
  EXPECT_EQ(decode(b, 72).error, StreamPacketError::kBadMagic);
  b = good;
  b[4] = 2;
  EXPECT_EQ(decode(b, 72).error, StreamPacketError::kWrongVersion);
  EXPECT_EQ(decode(b, 72).value, 2.0);
  b = good;
  b[6] = 3;
  EXPECT_EQ(decode(b, 72).error, StreamPacketError::kUnknownKind);
  for (int field = -1; field < 6; ++field) {
    for (double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
      StreamPacket p = PosePacket(1, 0.0, 0.0);
      (field < 0 ? p.time_s : p.values[field]) = bad;
      EncodeStreamPacket(p, b);
      const StreamDecodeResult r = decode(b, 72);
      EXPECT_EQ(r.error, StreamPacketError::kNotFinite) << field;
      EXPECT_EQ(r.field, field);
    }
  }
  StreamPacket absurd = PosePacket(1, 0.0, 10.0);  // 10 m
  EncodeStreamPacket(absurd, b);
  StreamDecodeResult r = decode(b, 72);
  EXPECT_EQ(r.error, StreamPacketError::kAbsurdValue);
  EXPECT_EQ(r.field, 0);
  EXPECT_EQ(r.value, 10.0);
  absurd.kind = StreamKind::kVehicle;
  absurd.values[0] = 5.0;
  absurd.values[4] = 50.0;  // 50 rad/s
  EncodeStreamPacket(absurd, b);
  r = decode(b, 72);
  EXPECT_EQ(r.error, StreamPacketError::kAbsurdValue);
  EXPECT_EQ(r.field, 4);
  EXPECT_EQ(out.sequence, untouched.sequence);  // nothing was written by a refusal
  EXPECT_EQ(out.values, untouched.values);
  EXPECT_STREQ(ToString(StreamPacketError::kAbsurdValue), "absurd value");
}

// Random datagrams (random sizes, random bytes, and valid packets with random bytes flipped):
// whatever is accepted is finite and inside the decode bounds.
TEST(StreamPacket, RandomBytesNeverDecodeIntoSomethingUnsafe) {
  const StreamDecodeLimits limits;
  Sampler s(2026);
  int accepted = 0;
  std::vector<std::uint8_t> buffer(128);
  for (int i = 0; i < 200000; ++i) {
    std::size_t size = static_cast<std::size_t>(s.Uniform(0, 128));
    if (i % 2 == 0) {
      Bytes b{};
      StreamPacket p = PosePacket(i, i * 0.01, s.Uniform(-0.4, 0.4));
      p.kind = i % 4 == 0 ? StreamKind::kPose : StreamKind::kVehicle;
      EncodeStreamPacket(p, b);
      std::copy(b.begin(), b.end(), buffer.begin());
      buffer[static_cast<std::size_t>(s.Uniform(0, 72))] = static_cast<std::uint8_t>(s.Uniform(0, 256));
      size = 72;
    } else {
      for (auto& byte : buffer) byte = static_cast<std::uint8_t>(s.Uniform(0, 256));
    }
    StreamPacket out;
    if (DecodeStreamPacket(buffer.data(), size, limits, out).error == StreamPacketError::kOk) {
      ++accepted;
      ASSERT_TRUE(out.values.allFinite());
      ASSERT_TRUE(std::isfinite(out.time_s));
      ASSERT_LE(out.values.cwiseAbs().maxCoeff(), limits.max_abs_acceleration_m_s2);
    }
  }
  EXPECT_GT(accepted, 10000);  // flipped bytes in the values often stay valid
}

MotionStreamConfig PoseConfig() {
  MotionStreamConfig c;
  c.kind = StreamKind::kPose;
  c.timeout_s = 0.1;
  c.period_s = 0.005;
  return c;
}

TEST(MotionStream, SequenceDuplicatesLateAndMissingAreCounted) {
  MotionStream stream(PoseConfig());
  MotionStreamOutput out;
  const StreamPacket batch[] = {PosePacket(10, 0.00, 0.01), PosePacket(10, 0.00, 0.01),
                                PosePacket(13, 0.03, 0.02), PosePacket(12, 0.02, 0.5),
                                PosePacket(14, 0.04, 0.03)};
  MotionStreamInput in;
  in.time_s = 0.0;
  in.packets = batch;
  in.packet_count = 5;
  stream.Update(in, out);
  const StreamCounters& c = stream.counters();
  EXPECT_EQ(c.applied, 3u);
  EXPECT_EQ(c.by_reason[static_cast<int>(StreamPacketError::kDuplicate)], 1u);
  EXPECT_EQ(c.by_reason[static_cast<int>(StreamPacketError::kLate)], 1u);
  EXPECT_EQ(c.missing, 2u);  // 11 and 12 skipped when 13 arrived
  EXPECT_EQ(out.target[0], 0.03);  // the newest, not the late 0.5
  EXPECT_EQ(c.last_refusal.error, StreamPacketError::kLate);
  EXPECT_EQ(c.refused(), 2u);
}

TEST(MotionStream, WrongKindIsRefused) {
  MotionStream stream(PoseConfig());
  StreamPacket p = PosePacket(1, 0.0, 0.0);
  p.kind = StreamKind::kVehicle;
  MotionStreamInput in;
  in.packets = &p;
  in.packet_count = 1;
  MotionStreamOutput out;
  stream.Update(in, out);
  EXPECT_EQ(stream.counters().by_reason[static_cast<int>(StreamPacketError::kWrongKind)], 1u);
  EXPECT_EQ(out.state, StreamState::kWaiting);
}

struct LossyRun {
  double worst_v[2] = {0, 0}, worst_a[2] = {0, 0}, worst_j[2] = {0, 0};
  double rms_error_m = 0;     // streaming, against the sender's signal at the receiver's time
  double neutral_after_s = -1; // from the last packet before the gap to |x| < 0.1 mm
  double return_jerk = 0;     // peak jerk of the return to neutral
  StreamCounters counters;
};

// A 100 Hz sender of x = 5 cm sin(2 pi 0.5 t) (and roll 0.1 rad sin) through a channel that
// drops `loss` of the packets, swaps neighbours with probability `reorder`, duplicates 1 %, and
// sends nothing from 2.5 to 3.0 s (the platform is at +5 cm when it begins); the receiver ticks at 200 Hz, packets arrive 2 ms after
// they are sent.
LossyRun RunLossy(double loss, double reorder, std::uint64_t seed) {
  const MotionStreamConfig config = PoseConfig();
  MotionStream stream(config);
  Sampler s(seed);
  std::vector<std::pair<double, StreamPacket>> in_flight;  // arrival time, packet
  std::uint64_t sequence = 1000;
  for (double t = 0.0; t < 6.0; t += 0.01) {
    StreamPacket p = PosePacket(sequence++, t, 0.05 * std::sin(3.14159265358979 * t));
    p.values[3] = 0.1 * std::sin(3.14159265358979 * t);
    if (t >= 2.5 && t < 3.0) continue;    // the gap
    if (s.Uniform(0, 1) < loss) continue;
    in_flight.push_back({t + 0.002, p});
    if (s.Uniform(0, 1) < 0.01) in_flight.push_back({t + 0.003, p});
    if (in_flight.size() >= 2 && s.Uniform(0, 1) < reorder) {
      std::swap(in_flight[in_flight.size() - 1].second, in_flight[in_flight.size() - 2].second);
    }
  }
  LossyRun r;
  MotionStreamOutput out;
  std::size_t next = 0;
  Vector6d previous_a = Vector6d::Zero();
  double error_sq = 0;
  int error_n = 0;
  std::vector<StreamPacket> batch;
  batch.reserve(16);
  for (int k = 0; k < 6.0 / config.period_s; ++k) {
    const double t = k * config.period_s;
    batch.clear();
    while (next < in_flight.size() && in_flight[next].first <= t) batch.push_back(in_flight[next++].second);
    MotionStreamInput in;
    in.time_s = t;
    in.packets = batch.data();
    in.packet_count = batch.size();
    stream.Update(in, out);
    for (int axis : {0, 3}) {
      const int i = axis == 0 ? 0 : 1;
      r.worst_v[i] = std::max(r.worst_v[i], std::abs(out.velocity[axis]));
      r.worst_a[i] = std::max(r.worst_a[i], std::abs(out.acceleration[axis]));
      const double jerk = std::abs(out.acceleration[axis] - previous_a[axis]) / config.period_s;
      r.worst_j[i] = std::max(r.worst_j[i], jerk);
      if (t > 2.5 && t < 3.0) r.return_jerk = std::max(r.return_jerk, axis == 0 ? jerk : r.return_jerk);
    }
    previous_a = out.acceleration;
    if ((t > 1.0 && t < 2.5) || t > 3.5) {
      error_sq += std::pow(out.displacement[0] - 0.05 * std::sin(3.14159265358979 * t), 2);
      ++error_n;
    }
    if (t > 2.5 && t < 3.0 && r.neutral_after_s < 0 && std::abs(out.displacement[0]) < 1e-4) {
      r.neutral_after_s = t - 2.49;
    }
  }
  r.rms_error_m = std::sqrt(error_sq / error_n);
  r.counters = stream.counters();
  return r;
}

TEST(MotionStream, LossReorderingAndAGapNeverBreakTheLimits) {
  const MotionStreamConfig config = PoseConfig();
  for (double loss : {0.0, 0.01, 0.05}) {
    const LossyRun r = RunLossy(loss, loss > 0 ? 0.02 : 0.0, 7);
    std::printf("loss %.0f %%: applied %llu missing %llu late %llu duplicate %llu timeouts %llu; "
                "x: |v| %.4f m/s |a| %.3f m/s2 |j| %.1f m/s3; roll |j| %.1f rad/s3; rms error "
                "%.2f mm; return jerk %.1f m/s3; neutral %.3f s after the last packet\n",
                loss * 100, (unsigned long long)r.counters.applied,
                (unsigned long long)r.counters.missing,
                (unsigned long long)r.counters.by_reason[static_cast<int>(StreamPacketError::kLate)],
                (unsigned long long)r.counters.by_reason[static_cast<int>(StreamPacketError::kDuplicate)],
                (unsigned long long)r.counters.timeouts, r.worst_v[0], r.worst_a[0], r.worst_j[0],
                r.worst_j[1], r.rms_error_m * 1e3, r.return_jerk, r.neutral_after_s);
    EXPECT_LE(r.worst_v[0], config.linear.max_speed * (1 + 1e-12));
    EXPECT_LE(r.worst_a[0], config.linear.max_acceleration * (1 + 1e-12));
    EXPECT_LE(r.worst_j[0], config.linear.max_jerk * (1 + 1e-9));
    EXPECT_LE(r.worst_v[1], config.angular.max_speed * (1 + 1e-12));
    EXPECT_LE(r.worst_a[1], config.angular.max_acceleration * (1 + 1e-12));
    EXPECT_LE(r.worst_j[1], config.angular.max_jerk * (1 + 1e-9));
    EXPECT_EQ(r.counters.timeouts, 1u);          // the 0.5 s gap, and only it
    EXPECT_LT(r.rms_error_m, 0.002);             // it does follow the stream
    // Back at neutral before the gap ends: timeout 0.1 s + the limited move from 5 cm.
    EXPECT_GT(r.neutral_after_s, config.timeout_s);
    EXPECT_LT(r.neutral_after_s, 0.5);
    if (loss > 0) {
      EXPECT_GT(r.counters.missing, 0u);
      EXPECT_GT(r.counters.by_reason[static_cast<int>(StreamPacketError::kLate)], 0u);
    }
  }
}

// The gap alone: the platform, held at +5 cm by the stream, returns to neutral within the
// limits and settles exactly at zero.
TEST(MotionStream, GapReturnsSmoothlyToNeutral) {
  const MotionStreamConfig config = PoseConfig();
  MotionStream stream(config);
  MotionStreamOutput out;
  std::uint64_t seq = 1;
  double timed_out_at = -1.0, neutral_at = -1.0, previous_a = 0, peak_jerk = 0;
  for (int k = 0; k < 800; ++k) {
    const double t = k * config.period_s;
    StreamPacket p = PosePacket(seq++, t, 0.05);
    MotionStreamInput in;
    in.time_s = t;
    in.packets = &p;
    in.packet_count = t < 1.0 ? 1 : 0;
    stream.Update(in, out);
    if (out.timed_out) timed_out_at = t;
    if (t > 1.0) peak_jerk = std::max(peak_jerk, std::abs(out.acceleration[0] - previous_a) / config.period_s);
    previous_a = out.acceleration[0];
    if (neutral_at < 0 && timed_out_at > 0 && out.state == StreamState::kWaiting) neutral_at = t;
  }
  std::printf("gap: timed out %.3f s after the last packet, neutral %.3f s later, peak jerk "
              "%.1f m/s3\n", timed_out_at - 0.995, neutral_at - timed_out_at, peak_jerk);
  EXPECT_NEAR(timed_out_at - 0.995, config.timeout_s, config.period_s + 1e-9);
  EXPECT_GT(neutral_at, timed_out_at);
  EXPECT_EQ(out.displacement[0], 0.0);
  EXPECT_LE(peak_jerk, config.linear.max_jerk * (1 + 1e-9));
  EXPECT_EQ(stream.counters().timeouts, 1u);
}

TEST(MotionStream, AStreamRestartedWithALowerSequenceIsAcceptedAfterATimeout) {
  MotionStream stream(PoseConfig());
  MotionStreamOutput out;
  StreamPacket p = PosePacket(500, 0.0, 0.01);
  MotionStreamInput in;
  in.packets = &p;
  in.packet_count = 1;
  stream.Update(in, out);
  in.packet_count = 0;
  in.time_s = 0.5;
  stream.Update(in, out);  // timed out
  p = PosePacket(1, 100.0, 0.02);
  in.packet_count = 1;
  in.time_s = 0.505;
  stream.Update(in, out);
  EXPECT_EQ(stream.counters().applied, 2u);
  EXPECT_EQ(out.target[0], 0.02);
  EXPECT_EQ(out.state, StreamState::kStreaming);
}

// Vehicle kind: one packet per tick, the target equals the washout run on the same samples.
TEST(MotionStream, VehicleStreamGoesThroughTheWashout) {
  MotionStreamConfig config = PoseConfig();
  config.kind = StreamKind::kVehicle;
  config.timeout_s = 0.5;
  MotionStream stream(config);
  WashoutFilter reference(config.washout);
  MotionStreamOutput out;
  WashoutOutput expected;
  for (int k = 0; k < 600; ++k) {
    const double t = k * config.period_s;
    StreamPacket p;
    p.kind = StreamKind::kVehicle;
    p.sequence = k;
    p.time_s = t;
    p.values[0] = t > 0.5 && t < 2.0 ? -5.0 : 0.0;
    MotionStreamInput in;
    in.time_s = t;
    in.packets = &p;
    in.packet_count = 1;
    stream.Update(in, out);
    WashoutInput w;
    w.acceleration_m_s2.x() = p.values[0];
    reference.Update(w, expected);
    ASSERT_EQ(out.target, expected.displacement) << t;
  }
  EXPECT_GT(out.target.cwiseAbs().maxCoeff(), 0.01);
}

TEST(MotionStream, ValidateNamesTheField) {
  MotionStreamConfig config = PoseConfig();
  config.timeout_s = 0.0;
  try {
    MotionStream stream(config);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("stream.timeout_s: stream timeout is out of range (value "
                                         "0, limit [0.005, 5])"), std::string::npos) << e.what();
  }
  config = PoseConfig();
  config.kind = StreamKind::kVehicle;
  config.washout.period_s = 0.01;
  EXPECT_THROW(MotionStream{config}, std::invalid_argument);
}

}  // namespace
}  // namespace hexa
