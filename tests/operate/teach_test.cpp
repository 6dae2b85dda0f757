// Teach and replay: measured poses -> CSV rows (resampling, smoothing, unwrapping, refusals),
// the eased start's duration against the minimum-jerk peaks, and a jog session taught and
// replayed: the replayed pose stays within a stated bound of the taught one.
#include "hexa/core/teach.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "hexa/core/motion_profile.hpp"
#include "hexa/core/user_frames.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using operate_test::kDeg;
using operate_test::Sampler;

std::vector<TeachSample> SineSamples(double rate_hz, double seconds) {
  std::vector<TeachSample> samples;
  for (int k = 0; k <= seconds * rate_hz; ++k) {
    const double t = 10.0 + k / rate_hz;  // any origin
    Vector6d v;
    v << 0.03 * std::sin(0.5 * t), 0.0, 0.45 + 0.02 * std::cos(0.5 * t), 0.05 * std::sin(0.3 * t),
        0.0, 0.0;
    samples.push_back({t, PoseFromVector(v)});
  }
  return samples;
}

TEST(Teach, RowsAreResampledFromZeroAndFollowTheSamples) {
  TeachConfig config;
  config.smoothing_window_s = 0.0;
  const auto samples = SineSamples(200.0, 4.0);
  const TeachResult r = TrajectoryRowsFromSamples(samples, config);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.time_s.front(), 0.0);
  EXPECT_NEAR(r.time_s.back(), 4.0, 1e-9);
  EXPECT_EQ(r.time_s.size(), 201u);  // 0, 0.02, ..., 4.0
  double worst = 0.0;
  for (std::size_t i = 0; i < r.time_s.size(); ++i) {
    const double t = 10.0 + r.time_s[i];
    worst = std::max(worst, std::abs(r.xyz_rpy[i][0] - 0.03 * std::sin(0.5 * t)));
    if (i > 0) {
      EXPECT_GE(r.time_s[i] - r.time_s[i - 1], 1e-3);
    }
  }
  EXPECT_LT(worst, 1e-9);  // rows fall on samples (0.02 s = 4 samples of 5 ms)
}

TEST(Teach, SmoothingRemovesNoiseWithoutLag) {
  auto samples = SineSamples(200.0, 6.0);
  Sampler s(4);
  for (TeachSample& sample : samples) sample.pose.p_BP_B_m.x() += s.Uniform(-0.5e-3, 0.5e-3);
  const TeachResult r = TrajectoryRowsFromSamples(samples, TeachConfig{});  // 50 ms window
  ASSERT_TRUE(r.ok);
  double worst = 0.0, sum_sq = 0.0;
  int n = 0;
  for (std::size_t i = 10; i + 10 < r.time_s.size(); ++i) {
    const double e = r.xyz_rpy[i][0] - 0.03 * std::sin(0.5 * (10.0 + r.time_s[i]));
    worst = std::max(worst, std::abs(e));
    sum_sq += e * e;
    ++n;
  }
  const double rms = std::sqrt(sum_sq / n);
  std::printf("noise +-0.5 mm (rms 0.289 mm): smoothed rows rms %.3f mm, largest %.3f mm\n",
              rms * 1e3, worst * 1e3);
  // 11 samples averaged: rms 0.289 / sqrt(11) = 0.087 mm expected.
  EXPECT_LT(rms, 0.12e-3);
  EXPECT_LT(worst, 0.4e-3);
}

TEST(Teach, YawIsUnwrappedAndRefusedBeyondPi) {
  std::vector<TeachSample> samples;
  for (int k = 0; k <= 100; ++k) {
    Vector6d v;
    v << 0, 0, 0.45, 0, 0, 3.0 + 0.002 * k;  // crosses +pi at k = 71
    samples.push_back({k * 0.005, PoseFromVector(v)});
  }
  const TeachResult r = TrajectoryRowsFromSamples(samples, TeachConfig{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("turned beyond +-pi"), std::string::npos) << r.message;
}

TEST(Teach, BadRecordingsAreRefusedWithTheirReason) {
  auto samples = SineSamples(200.0, 1.0);
  samples[50].pose.p_BP_B_m.y() = std::nan("");
  TeachResult r = TrajectoryRowsFromSamples(samples, TeachConfig{});
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.dropped_not_finite, 1u);
  samples[60].time_s = samples[59].time_s;
  r = TrajectoryRowsFromSamples(samples, TeachConfig{});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.message,
            "sample 60: time 10.295000 s is not after the previous sample's 10.295000 s");
  samples = SineSamples(200.0, 1.0);
  for (std::size_t i = 100; i < samples.size(); ++i) samples[i].time_s += 1.0;
  r = TrajectoryRowsFromSamples(samples, TeachConfig{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("a gap of 1.005 s"), std::string::npos) << r.message;
  r = TrajectoryRowsFromSamples({samples[0]}, TeachConfig{});
  EXPECT_FALSE(r.ok);
  TeachConfig bad;
  bad.row_period_s = 0.0005;
  EXPECT_THROW(TrajectoryRowsFromSamples(samples, bad), std::invalid_argument);
}

// The eased blend's peaks equal the limit that sets its duration.
TEST(Teach, EasedStartKeepsTheMinimumJerkPeaksWithinTheLimits) {
  const EaseLimits limits;
  Vector6d from, to;
  from << 0, 0, 0.45, 0, 0, 0;
  to << 0.06, -0.03, 0.47, 0.0, 0.05, 0.0;
  const double T = EasedBlendDuration(from, to, limits);
  const double h = (to - from).head<3>().norm();
  EXPECT_NEAR(T, 1.875 * h / limits.max_speed_m_s, 1e-12);  // speed binds here
  const std::vector<double> time_s{0.0, 1.0};
  const std::vector<Vector6d> rows{to, to};
  TrajectoryTiming timing;
  timing.blend_duration_s = 0.5;
  const Trajectory replay = MakeReplayTrajectory(time_s, rows, from, timing, limits);
  EXPECT_NEAR(replay.tracking_start_s(), T, 1e-12);
  TrajectorySample sample;
  double peak_v = 0, peak_a = 0;
  for (double t = 0; t <= T; t += 1e-3) {
    replay.Evaluate(t, sample);
    peak_v = std::max(peak_v, sample.twist_B.head<3>().norm());
    peak_a = std::max(peak_a, sample.twist_rate_B.head<3>().norm());
  }
  EXPECT_LE(peak_v, limits.max_speed_m_s * (1 + 1e-9));
  EXPECT_GT(peak_v, limits.max_speed_m_s * 0.999);
  EXPECT_LE(peak_a, limits.max_acceleration_m_s2);
  EXPECT_EQ(EasedBlendDuration(from, from, limits), limits.min_duration_s);
}

// A jog session (x, then a roll about a pivot 10 cm above the platform, then y in the tool
// frame), its setpoints recorded at 200 Hz, taught into rows and replayed from a pose 2 cm
// away: in the replay's tracking window the pose is within 1 um / 1 urad of the session's
// (0.1 mm / 0.4 mrad with the 50 ms smoothing).
TEST(Teach, AJogSessionTaughtAndReplayedFollowsTheSession) {
  JogProfileConfig jog_config;
  JogProfile jog(jog_config);
  UserFramesConfig frames;
  frames.p_PC_P_m = Eigen::Vector3d(0, 0, 0.1);
  Pose X_BP;
  X_BP.p_BP_B_m = Eigen::Vector3d(0, 0, 0.45);
  std::vector<TeachSample> recording;
  JogOutput out;
  const double dt = 0.005;
  for (int k = 0; k < 1600; ++k) {
    const double t = k * dt;
    JogInput in;
    in.time_s = t;
    in.dt_s = dt;
    in.command_received = (t < 1.5) || (t > 2.5 && t < 4.0) || (t > 5.0 && t < 6.5);
    if (t < 1.5) in.twist_jog << 0.03, 0, 0, 0, 0, 0;
    if (t > 2.5 && t < 4.0) in.twist_jog << 0, 0, 0, 0.1, 0, 0;
    if (t > 5.0) {
      in.twist_jog << 0, 0.02, 0, 0, 0, 0;
      in.R_B_jog = JogAxes(JogFrame::kTool, X_BP, frames);
    }
    jog.Update(in, out);
    X_BP = IntegratePivotTwist(X_BP, frames.p_PC_P_m, out.twist_C_B, dt);
    recording.push_back({t, X_BP});
  }
  for (const double window_s : {0.0, 0.05}) {
    TeachConfig teach;
    teach.smoothing_window_s = window_s;
    const TeachResult rows = TrajectoryRowsFromSamples(recording, teach);
    ASSERT_TRUE(rows.ok) << rows.message;
    Vector6d current = rows.xyz_rpy.front();
    current[1] += 0.02;
    const Trajectory replay =
        MakeReplayTrajectory(rows.time_s, rows.xyz_rpy, current, TrajectoryTiming{}, EaseLimits{});
    TrajectorySample sample;
    double worst_m = 0, worst_rad = 0;
    for (const TeachSample& taught : recording) {
      const double t = replay.tracking_start_s() + taught.time_s;
      if (t >= replay.tracking_end_s()) break;
      replay.Evaluate(t, sample);
      const Vector6d e = PoseError(sample.pose, taught.pose);
      worst_m = std::max(worst_m, e.head<3>().norm());
      worst_rad = std::max(worst_rad, e.tail<3>().norm());
    }
    std::printf(
        "jog session replayed, smoothing %.0f ms: largest deviation %.4f mm, %.4f mrad "
        "(eased start %.2f s)\n",
        window_s * 1e3, worst_m * 1e3, worst_rad * 1e3, replay.tracking_start_s());
    // Setpoints are noise-free: without smoothing only the spline between 20 ms rows is left.
    // The 50 ms moving average (meant for a noisy measured estimate) bends the corners of the
    // jerk-limited motion: bias ~ q'' w^2 / 24 and more at the jerk steps.
    EXPECT_LT(worst_m, window_s == 0.0 ? 1e-6 : 1e-4);
    EXPECT_LT(worst_rad, window_s == 0.0 ? 1e-6 : 4e-4);
  }
}

}  // namespace
}  // namespace hexa
