// The supervisor's STREAMING mode in the in-process lockstep simulation (six leg controllers,
// the plant, the supervisor; fixed seed), against the plant's ground truth: a pose stream of
// 100 Hz is followed; when the sender stops, the timeout is raised once and the platform returns
// smoothly to neutral (every setpoint step within the stream's speed and acceleration limits);
// an operator stop brings it back to neutral and IDLE; a stream that crosses a soft limit is
// clamped at it. Packets are delivered at the supervisor tick after their sender time.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/washout.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTick_s = 0.001;
constexpr double kSupervisorPeriod_s = 0.005;

// The stream: x = a sin(2 pi f t), roll = r sin(2 pi f t), from the sender's t = 0.
struct Sine {
  double amplitude_m = 0.03;
  double roll_rad = 0.05;
  double frequency_hz = 0.5;
  Vector6d At(double t) const {
    Vector6d d = Vector6d::Zero();
    d[0] = amplitude_m * std::sin(2 * kPi * frequency_hz * t);
    d[3] = roll_rad * std::sin(2 * kPi * frequency_hz * t);
    return d;
  }
};

class StreamSession {
 public:
  StreamSession() : sim_([] {
      LockstepConfig c;
      c.seed = 7;
      return c;
    }()) {
    sim_.Tick();  // tick 0: the rest pose is latched
    Run(0.5);
  }

  // Runs `duration_s`; with `sine`, a packet every 1/rate_hz of the sender's clock (started at
  // stream_start_s_), each handed to the first supervisor tick at or after its time.
  void Run(double duration_s, const Sine* sine = nullptr, double rate_hz = 100.0) {
    const auto end = sim_.tick() + static_cast<std::uint64_t>(std::llround(duration_s / kTick_s));
    while (sim_.tick() < end) {
      if (!sim_.supervisor_due()) {
        ASSERT_EQ(sim_.Tick(), PlantStatus::kOk);
        continue;
      }
      packets_.clear();
      while (sine != nullptr && next_packet_s_ <= sim_.time_s() + 1e-9) {
        StreamPacket p;
        p.kind = StreamKind::kPose;
        p.sequence = ++sequence_;
        p.time_s = next_packet_s_ - stream_start_s_;
        p.values = sine->At(p.time_s);
        packets_.push_back(p);
        last_packet_s_ = next_packet_s_;
        next_packet_s_ += 1.0 / rate_hz;
      }
      ASSERT_EQ(sim_.Tick(OperatorCommandKind::kNone, nullptr, nullptr, nullptr, packets_.data(),
                          packets_.size()),
                PlantStatus::kOk);
      Observe();
    }
  }

  const SupervisorOutput& Command(OperatorCommandKind cmd) {
    while (!sim_.supervisor_due()) EXPECT_EQ(sim_.Tick(), PlantStatus::kOk);
    EXPECT_EQ(sim_.Tick(cmd), PlantStatus::kOk);
    Observe();
    return sim_.supervisor_output();
  }

  // The sender starts now (its clock reads 0 at the next supervisor tick).
  void StartSender() {
    stream_start_s_ = sim_.time_s();
    next_packet_s_ = stream_start_s_;
  }

  const LockstepSimulation& sim() const { return sim_; }
  const SupervisorOutput& out() const { return sim_.supervisor_output(); }
  Pose truth() const { return sim_.plant().truth().pose; }
  Pose setpoint() const { return out().desired.pose; }
  double stream_start_s() const { return stream_start_s_; }
  double last_packet_s() const { return last_packet_s_; }
  // Per supervisor tick since ResetPeaks: the largest setpoint step of one axis of x, y, z
  // (m) and of roll, pitch, yaw (rad), and the largest second difference / T^2 of the position.
  double peak_step_m() const { return peak_step_m_; }
  double peak_step_rad() const { return peak_step_rad_; }
  double peak_acceleration_m_s2() const { return peak_acceleration_; }
  int timeouts_seen() const { return timeouts_; }
  double timeout_at_s() const { return timeout_at_s_; }
  void ResetPeaks() { peak_step_m_ = peak_step_rad_ = peak_acceleration_ = 0.0; }

 private:
  void Observe() {
    const Vector6d q = out().desired_xyz_rpy;
    if (samples_ >= 1) {
      peak_step_m_ = std::max(peak_step_m_, (q.head<3>() - q1_.head<3>()).cwiseAbs().maxCoeff());
      peak_step_rad_ = std::max(peak_step_rad_, (q.tail<3>() - q1_.tail<3>()).cwiseAbs().maxCoeff());
    }
    if (samples_ >= 2) {
      const double T = kSupervisorPeriod_s;
      peak_acceleration_ = std::max(
          peak_acceleration_, (q.head<3>() - 2 * q1_.head<3>() + q2_.head<3>()).cwiseAbs().maxCoeff() / (T * T));
    }
    q2_ = q1_;
    q1_ = q;
    ++samples_;
    if (out().operator_motion.stream.timed_out) {
      ++timeouts_;
      timeout_at_s_ = sim_.time_s();
    }
  }

  LockstepSimulation sim_;
  std::vector<StreamPacket> packets_ = std::vector<StreamPacket>(64);
  std::uint64_t sequence_ = 1000;
  double stream_start_s_ = 0.0, next_packet_s_ = 0.0, last_packet_s_ = 0.0;
  Vector6d q1_ = Vector6d::Zero(), q2_ = Vector6d::Zero();
  int samples_ = 0;
  double peak_step_m_ = 0.0, peak_step_rad_ = 0.0, peak_acceleration_ = 0.0;
  int timeouts_ = 0;
  double timeout_at_s_ = -1.0;
};

const MotionStreamConfig kStream{};

TEST(SupervisorStream, APoseSineAt100HzIsFollowedByThePlatform) {
  StreamSession s;
  const Pose neutral_truth = s.truth();
  const Vector6d neutral = s.out().desired_xyz_rpy;
  ASSERT_EQ(s.Command(OperatorCommandKind::kStream).command_result, CommandResult::kAccepted);
  EXPECT_EQ(s.out().state, SupervisorState::kStreaming);
  const Sine sine;
  s.StartSender();
  // 2 s to settle into the motion, then 4 s (two periods) measured, each supervisor tick.
  s.Run(2.0, &sine);
  double sum_sq_x = 0.0, max_x = 0.0, max_roll = 0.0, max_setpoint_x = 0.0;
  int n = 0;
  std::vector<double> moved_x_log, t_log;
  for (int k = 0; k < 800; ++k) {
    s.Run(kSupervisorPeriod_s, &sine);
    const double t = s.sim().time_s() - s.stream_start_s();
    const Vector6d asked = sine.At(t);
    const Pose truth = s.truth();
    const double moved_x = truth.p_BP_B_m.x() - neutral_truth.p_BP_B_m.x();
    const double roll = RollPitchYawFromRotation(truth.R_BP).x() -
                        RollPitchYawFromRotation(neutral_truth.R_BP).x();
    const double e_x = moved_x - asked[0];
    moved_x_log.push_back(moved_x);
    t_log.push_back(t);
    sum_sq_x += e_x * e_x;
    max_x = std::max(max_x, std::abs(e_x));
    max_roll = std::max(max_roll, std::abs(roll - asked[3]));
    max_setpoint_x = std::max(max_setpoint_x, std::abs(s.out().desired_xyz_rpy[0] - neutral[0] - asked[0]));
    ++n;
  }
  const double rms_x = std::sqrt(sum_sq_x / n);
  // The platform's lag behind the stream: the delay (5 ms steps) that minimises the x rms.
  double best_delay_s = 0.0, best_rms = rms_x;
  for (int d = 1; d <= 30; ++d) {
    double sq = 0.0;
    for (std::size_t i = 0; i < t_log.size(); ++i) {
      const double e = moved_x_log[i] - sine.At(t_log[i] - d * kSupervisorPeriod_s)[0];
      sq += e * e;
    }
    const double r = std::sqrt(sq / static_cast<double>(t_log.size()));
    if (r < best_rms) best_rms = r, best_delay_s = d * kSupervisorPeriod_s;
  }
  const StreamCounters& c = s.sim().supervisor().operator_motion().stream().counters();
  std::printf("pose stream x = 30 mm sin(pi t), roll = 0.05 rad sin(pi t) at 100 Hz: platform "
              "(truth, from its neutral) against the stream: x rms %.3f mm, max %.3f mm; roll "
              "max %.3f mrad; setpoint against the stream max %.4f mm; x rms %.3f mm against the "
              "stream %.0f ms earlier; applied %llu, missing %llu\n",
              rms_x * 1e3, max_x * 1e3, max_roll * 1e3, max_setpoint_x * 1e3, best_rms * 1e3,
              best_delay_s * 1e3,
              static_cast<unsigned long long>(c.applied), static_cast<unsigned long long>(c.missing));
  EXPECT_EQ(s.out().state, SupervisorState::kStreaming);
  EXPECT_EQ(c.missing, 0u);
  EXPECT_EQ(s.timeouts_seen(), 0);
  // Bounds: the measured figures (docs/measurements/operate.md: setpoint 0.35 mm; platform x
  // rms 3.4 mm, max 9.3 mm, roll 16.3 mrad) with about 1.5x margin. The platform lags the
  // setpoint by the closed loop's lag (no setpoint lead: a stream's future is not known).
  EXPECT_LT(max_setpoint_x, 0.0006);
  EXPECT_LT(rms_x, 0.005);
  EXPECT_LT(max_x, 0.014);
  EXPECT_LT(max_roll, 0.025);
  // It moved: the stream's amplitude is 10x the largest error.
  EXPECT_GT(sine.amplitude_m, 10 * max_setpoint_x);
}

TEST(SupervisorStream, StoppedSenderTimesOutAndReturnsSmoothlyToNeutral) {
  StreamSession s;
  const Vector6d neutral = s.out().desired_xyz_rpy;
  ASSERT_EQ(s.Command(OperatorCommandKind::kStream).command_result, CommandResult::kAccepted);
  const Sine sine;
  s.StartSender();
  // The sender stops at t = 2.0 s: x is crossing neutral at full speed (a pi 30 mm/s = 94 mm/s).
  s.Run(2.0, &sine);
  const double speed_at_stop = std::abs(s.out().desired.twist_B[0]);
  s.ResetPeaks();
  s.Run(2.0, nullptr);
  const double timeout_after_s = s.timeout_at_s() - s.last_packet_s();
  const Vector6d end = s.out().desired_xyz_rpy;
  const double T = kSupervisorPeriod_s;
  std::printf("sender stopped at %.3f m/s: timeout %d time(s), %.4f s after the last packet "
              "(timeout %.3f s); largest setpoint step %.4f mm, %.4f mrad per tick, peak "
              "acceleration %.3f m/s2; 2 s later %.2e m, %.2e rad from neutral, state %s\n",
              speed_at_stop, s.timeouts_seen(), timeout_after_s, kStream.timeout_s,
              s.peak_step_m() * 1e3, s.peak_step_rad() * 1e3, s.peak_acceleration_m_s2(),
              (end - neutral).head<3>().cwiseAbs().maxCoeff(),
              (end - neutral).tail<3>().cwiseAbs().maxCoeff(), ToString(s.out().state));
  EXPECT_GT(speed_at_stop, 0.05);
  // The timeout: once, at the first supervisor tick more than timeout_s after the last packet.
  EXPECT_EQ(s.timeouts_seen(), 1);
  EXPECT_GT(timeout_after_s, kStream.timeout_s);
  EXPECT_LE(timeout_after_s, kStream.timeout_s + T + 1e-9);
  EXPECT_EQ(s.sim().supervisor().operator_motion().stream().counters().timeouts, 1u);
  // Smooth: no setpoint step above the stream's speed limit per tick (0.3 m/s * 5 ms = 1.5 mm
  // per axis), the position's acceleration within the stream's 3 m/s2 (1 % for the rounding
  // of the second difference).
  EXPECT_LE(s.peak_step_m(), kStream.linear.max_speed * T + 1e-9);
  EXPECT_LE(s.peak_step_rad(), kStream.angular.max_speed * T + 1e-9);
  EXPECT_LE(s.peak_acceleration_m_s2(), kStream.linear.max_acceleration * 1.01);
  // Back at neutral exactly, still STREAMING (waiting for packets).
  EXPECT_LT((end - neutral).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(s.out().state, SupervisorState::kStreaming);
  EXPECT_EQ(s.out().operator_motion.stream.state, StreamState::kWaiting);
}

TEST(SupervisorStream, OperatorStopReturnsToNeutralThenIdle) {
  StreamSession s;
  const Vector6d neutral = s.out().desired_xyz_rpy;
  ASSERT_EQ(s.Command(OperatorCommandKind::kStream).command_result, CommandResult::kAccepted);
  const Sine sine;
  s.StartSender();
  s.Run(1.5, &sine);  // x near its peak
  // Neither a jog, a goal nor a start is taken while streaming.
  EXPECT_EQ(s.Command(OperatorCommandKind::kJog).command_result, CommandResult::kRefused);
  EXPECT_EQ(s.Command(OperatorCommandKind::kHome).command_result, CommandResult::kRefused);
  EXPECT_EQ(s.Command(OperatorCommandKind::kStream).command_result, CommandResult::kRefused);
  const double away_m = std::abs(s.out().desired_xyz_rpy[0] - neutral[0]);
  ASSERT_EQ(s.Command(OperatorCommandKind::kStop).command_result, CommandResult::kAccepted);
  s.ResetPeaks();
  double idle_after_s = -1.0;
  const double t0 = s.sim().time_s();
  for (int k = 0; k < 400 && idle_after_s < 0.0; ++k) {
    s.Run(kSupervisorPeriod_s, &sine);  // the sender goes on: ignored after the stop
    if (s.out().state == SupervisorState::kIdle) idle_after_s = s.sim().time_s() - t0;
  }
  std::printf("operator stop %.2f mm from neutral: IDLE after %.3f s, largest step %.4f mm, peak "
              "acceleration %.3f m/s2\n", away_m * 1e3, idle_after_s, s.peak_step_m() * 1e3,
              s.peak_acceleration_m_s2());
  EXPECT_GT(away_m, 0.02);
  ASSERT_GT(idle_after_s, 0.0);
  EXPECT_LT((s.out().desired_xyz_rpy - neutral).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((s.sim().supervisor().rest_xyz_rpy() - neutral).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE(s.peak_step_m(), kStream.linear.max_speed * kSupervisorPeriod_s + 1e-9);
  EXPECT_LE(s.peak_acceleration_m_s2(), kStream.linear.max_acceleration * 1.01);
  s.Run(0.2, &sine);
  EXPECT_EQ(s.out().state, SupervisorState::kIdle);  // packets move nothing outside STREAMING
  EXPECT_LT((s.out().desired_xyz_rpy - neutral).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(SupervisorStream, AStreamAcrossTheSoftLimitIsClampedAtIt) {
  StreamSession s;
  const double limit_x = s.sim().supervisor().operator_motion().limits().config().box_max[0];
  const double neutral_x = s.out().desired_xyz_rpy[0];
  ASSERT_EQ(s.Command(OperatorCommandKind::kStream).command_result, CommandResult::kAccepted);
  Sine wide;
  wide.amplitude_m = 0.15;  // the pose box is +-0.10 m about home
  wide.roll_rad = 0.0;
  s.StartSender();
  double peak_x = -1.0;
  int clamped = 0;
  for (int k = 0; k < 600; ++k) {
    s.Run(kSupervisorPeriod_s, &wide);
    peak_x = std::max(peak_x, s.out().desired_xyz_rpy[0]);
    if (s.out().operator_motion.limits.result != SoftLimitsResult::kInside) ++clamped;
  }
  std::printf("pose stream x = 150 mm sin(pi t) from x = %.4f m: setpoint peak %.7f m (limit "
              "%.4f m), clamped on %d of 600 ticks\n", neutral_x, peak_x, limit_x, clamped);
  EXPECT_LE(peak_x, limit_x + 1e-6);
  EXPECT_GT(peak_x, limit_x - 0.001);
  EXPECT_GT(clamped, 0);
}

// Vehicle packets (a supervisor configured for them) are cued through the classical washout:
// a sustained deceleration becomes a pitch that follows the washout's own output (the same
// filter run beside it on the same samples), the surge washes out, and all returns to neutral.
// A kinematic plant (the measured lengths are the setpoint's), so that only the cueing is seen.
TEST(SupervisorStream, VehiclePacketsAreCuedThroughTheWashout) {
  const RigParams rig = MakeReferenceRig();
  const SupervisorParams params;
  OperatorMotionConfig motion = MakeOperatorMotionConfig(rig, params);
  motion.stream.kind = StreamKind::kVehicle;
  Supervisor sup(rig, params, {}, motion);
  WashoutFilter reference(motion.stream.washout);  // the period is the supervisor's: 5 ms
  SupervisorInput in;
  SupervisorOutput out;
  Pose pose;
  pose.p_BP_B_m = rig.geometry.home_position_m;
  StreamPacket packet;
  packet.kind = StreamKind::kVehicle;
  const auto tick = [&](OperatorCommandKind cmd, bool send) {
    for (std::size_t i = 0; i < kNumLegs; ++i)
      in.length_m[i] = (pose.p_BP_B_m + pose.R_BP * rig.geometry.p_PB_P[i] - rig.geometry.p_BA_B[i]).norm();
    const Eigen::Quaterniond q(pose.R_BP);
    in.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    in.command = cmd;
    in.stream_packets = send ? &packet : nullptr;
    in.stream_packet_count = send ? 1 : 0;
    sup.Update(in, out);
    in.time_s += kSupervisorPeriod_s;
    pose = out.desired.pose;
  };
  tick(OperatorCommandKind::kNone, false);
  const Vector6d neutral = out.desired_xyz_rpy;
  tick(OperatorCommandKind::kStream, false);
  ASSERT_EQ(out.state, SupervisorState::kStreaming);
  double worst_pitch_gap = 0.0, peak_pitch = 0.0, peak_surge = 0.0;
  WashoutOutput cue;
  for (int k = 0; k < 2400; ++k) {  // 12 s: braking at 1 m/s2 for 4 s, then coasting
    packet.sequence = static_cast<std::uint64_t>(k + 1);
    packet.time_s = k * kSupervisorPeriod_s;
    packet.values.setZero();
    packet.values[0] = k * kSupervisorPeriod_s < 4.0 ? -1.0 : 0.0;
    tick(OperatorCommandKind::kNone, true);
    WashoutInput w;
    w.acceleration_m_s2 = packet.values.head<3>();
    reference.Update(w, cue);
    const Vector6d d = out.desired_xyz_rpy - neutral;
    worst_pitch_gap = std::max(worst_pitch_gap, std::abs(d[4] - cue.displacement[4]));
    peak_pitch = std::max(peak_pitch, std::abs(d[4]));
    peak_surge = std::max(peak_surge, std::abs(d[0]));
  }
  const Vector6d end = out.desired_xyz_rpy - neutral;
  std::printf("vehicle stream, braking 1 m/s2 for 4 s: peak pitch %.4f rad (washout steady tilt "
              "%.4f), setpoint pitch within %.2e rad of the washout's, peak surge %.2f mm; at 12 s "
              "%.2e m, %.2e rad from neutral\n", peak_pitch,
              motion.stream.washout.tilt.scale / motion.stream.washout.gravity_m_s2, worst_pitch_gap,
              peak_surge * 1e3, end.head<3>().cwiseAbs().maxCoeff(), end.tail<3>().cwiseAbs().maxCoeff());
  EXPECT_EQ(out.state, SupervisorState::kStreaming);
  EXPECT_GT(peak_pitch, 0.04);            // the tilt carried the deceleration
  EXPECT_LT(worst_pitch_gap, 0.001);      // the setpoint follows the washout's cue (measured 3.3e-4)
  EXPECT_GT(peak_surge, 0.001);           // the onset
  EXPECT_LT(end.cwiseAbs().maxCoeff(), 1e-4);  // washed out, back at neutral (measured 6e-6 m)
}

}  // namespace
}  // namespace hexa
