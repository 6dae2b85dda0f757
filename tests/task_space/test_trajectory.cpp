// Trajectories: continuity of position and velocity at every phase boundary (limits from
// both sides), analytic derivatives consistent with the motion, and the paper's amplitudes
// and frequencies inside the tracking window.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hexa/core/rig.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Case {
  PaperMotion motion;
  int axis;            // index in [x y z roll pitch yaw] of the moving component
  double amplitude;    // m or rad
  double frequency_hz;
};

const std::vector<Case> kCases = {
    {PaperMotion::kX, 0, 0.08, 0.1},
    {PaperMotion::kY, 1, 0.08, 0.1},
    {PaperMotion::kZ, 2, 0.08, 0.1},
    {PaperMotion::kRoll, 3, 15.0 * kPi / 180.0, 0.1},
    {PaperMotion::kPitch, 4, 15.0 * kPi / 180.0, 0.1},
    {PaperMotion::kYaw, 5, 15.0 * kPi / 180.0, 0.1},
    {PaperMotion::kCombined, 0, 0.08, 1.0},
};

Vector6d Home() { return HomePoseVector(MakeReferenceRig().geometry.home_position_m); }

// A start pose away from home, so that the blend really has to move.
Vector6d OffHomeStart() {
  Vector6d start = Home();
  start += (Vector6d() << 0.012, -0.007, 0.004, 0.02, -0.015, 0.01).finished();
  return start;
}

PoseVectorState At(const Trajectory& traj, double t) {
  TrajectorySample s;
  traj.Evaluate(t, s);
  return s.vector;
}

// Position and velocity limits from both sides of t agree (a step of even 0.1 mm or
// 0.1 mm/s would fail: the tolerances are the change a smooth motion makes in 2 eps).
void ExpectContinuousAt(const Trajectory& traj, double t, const char* where) {
  const double eps = 1e-7;
  const PoseVectorState left = At(traj, t - eps);
  const PoseVectorState right = At(traj, t + eps);
  EXPECT_LT((left.q - right.q).cwiseAbs().maxCoeff(), 1e-6) << where << " position, t=" << t;
  EXPECT_LT((left.q_dot - right.q_dot).cwiseAbs().maxCoeff(), 1e-5)
      << where << " velocity, t=" << t;
  EXPECT_LT((left.q_ddot - right.q_ddot).cwiseAbs().maxCoeff(), 1e-3)
      << where << " acceleration, t=" << t;
}

class PaperTrajectory : public ::testing::TestWithParam<Case> {};

TEST_P(PaperTrajectory, ContinuousAtBlendStartBlendEndStopStartAndEnd) {
  const Case& c = GetParam();
  const Trajectory traj =
      MakePaperTrajectory(c.motion, OffHomeStart(), Home(), TrajectoryTiming{2.0, 1.0});
  // Starts exactly at the start pose at rest and ends exactly at home at rest.
  const PoseVectorState first = At(traj, 0.0);
  EXPECT_LT((first.q - OffHomeStart()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT(first.q_dot.cwiseAbs().maxCoeff(), 1e-15);
  const PoseVectorState before = At(traj, -0.5);
  EXPECT_LT((before.q - OffHomeStart()).cwiseAbs().maxCoeff(), 1e-15);
  const PoseVectorState last = At(traj, traj.duration_s());
  EXPECT_LT((last.q - Home()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(last.q_dot.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(last.q_ddot.cwiseAbs().maxCoeff(), 1e-12);
  // Velocity right after the start and right before the end tends to zero (no step).
  EXPECT_LT(At(traj, 1e-4).q_dot.cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(At(traj, traj.duration_s() - 1e-4).q_dot.cwiseAbs().maxCoeff(), 1e-6);

  ExpectContinuousAt(traj, 0.0, "blend start");
  ExpectContinuousAt(traj, traj.tracking_start_s(), "blend end");
  ExpectContinuousAt(traj, traj.tracking_end_s(), "stop start");
  ExpectContinuousAt(traj, traj.duration_s(), "stop end");
}

TEST_P(PaperTrajectory, DerivativesAreThoseOfThePoseAndTwistMatchesRotationRate) {
  const Case& c = GetParam();
  const Trajectory traj =
      MakePaperTrajectory(c.motion, OffHomeStart(), Home(), TrajectoryTiming{2.0, 1.0});
  const double h = 1e-6;
  for (double t = 0.013; t < traj.duration_s(); t += traj.duration_s() / 97.0) {
    TrajectorySample a, b, m;
    traj.Evaluate(t - h, a);
    traj.Evaluate(t, m);
    traj.Evaluate(t + h, b);
    EXPECT_LT(((b.vector.q - a.vector.q) / (2 * h) - m.vector.q_dot).cwiseAbs().maxCoeff(), 1e-6)
        << t;
    EXPECT_LT(
        ((b.vector.q_dot - a.vector.q_dot) / (2 * h) - m.vector.q_ddot).cwiseAbs().maxCoeff(),
        1e-4)
        << t;
    // w^ = R_dot R^T, and alpha = d/dt w.
    const Eigen::Matrix3d W = (b.pose.R_BP - a.pose.R_BP) / (2 * h) * m.pose.R_BP.transpose();
    const Eigen::Vector3d w(W(2, 1), W(0, 2), W(1, 0));
    EXPECT_LT((w - m.twist_B.tail<3>()).cwiseAbs().maxCoeff(), 1e-6) << t;
    EXPECT_LT(((b.twist_B - a.twist_B) / (2 * h) - m.twist_rate_B).cwiseAbs().maxCoeff(), 1e-4)
        << t;
  }
}

TEST_P(PaperTrajectory, AmplitudeAndFrequencyInsideTheTrackingWindow) {
  const Case& c = GetParam();
  const int periods = DefaultPeriods(c.motion);
  const Trajectory traj =
      MakePaperTrajectory(c.motion, OffHomeStart(), Home(), TrajectoryTiming{2.0, 1.0});
  ASSERT_NEAR(traj.tracking_end_s() - traj.tracking_start_s(), periods / c.frequency_hz, 1e-12);
  const double dt = 1e-4;
  double max_dev = -1e9, min_dev = 1e9;
  std::vector<double> crossings;  // of the moving component through its centre
  double prev = NAN;
  Vector6d other_max_dev = Vector6d::Zero();
  for (double t = traj.tracking_start_s(); t < traj.tracking_end_s(); t += dt) {
    const PoseVectorState s = At(traj, t);
    const double dev = s.q[c.axis] - Home()[c.axis];
    max_dev = std::max(max_dev, dev);
    min_dev = std::min(min_dev, dev);
    // Sign changes away from the window start (where the sine starts at its centre).
    if (t > traj.tracking_start_s() + 0.1 / c.frequency_hz && (prev < 0.0) != (dev < 0.0)) {
      crossings.push_back(t - dt * dev / (dev - prev));
    }
    prev = dev;
    for (int k = 0; k < 6; ++k) {
      if (c.motion == PaperMotion::kCombined && k < 3) continue;
      if (k == c.axis) continue;
      other_max_dev[k] = std::max(other_max_dev[k], std::abs(s.q[k] - Home()[k]));
    }
  }
  EXPECT_NEAR(max_dev, c.amplitude, 1e-6 * c.amplitude);
  EXPECT_NEAR(min_dev, -c.amplitude, 1e-6 * c.amplitude);
  EXPECT_LT(other_max_dev.maxCoeff(), 1e-15) << "only the specified axes move";
  // Zero crossings half a period apart, 2 periods - 1 of them inside the window.
  ASSERT_EQ(crossings.size(), static_cast<std::size_t>(2 * periods - 1));
  for (std::size_t i = 1; i < crossings.size(); ++i) {
    EXPECT_NEAR(crossings[i] - crossings[i - 1], 0.5 / c.frequency_hz, 1e-6);
  }
  // Phase: sin starts at the centre going up at the window start (paper's t = 0).
  const PoseVectorState s0 = At(traj, traj.tracking_start_s());
  EXPECT_NEAR(s0.q[c.axis], Home()[c.axis], 1e-12);
  EXPECT_NEAR(s0.q_dot[c.axis], 2 * kPi * c.frequency_hz * c.amplitude, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(AllPaperMotions, PaperTrajectory, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::string(ToString(info.param.motion));
                         });

TEST(CombinedTrajectory, Eq49YStartsAtPlus8cmAndZFollowsX) {
  const Trajectory traj = MakePaperTrajectory(PaperMotion::kCombined, Home(), Home(),
                                              TrajectoryTiming{2.0, 1.0});
  for (double tau = 0.0; tau < 10.0; tau += 0.0137) {
    const PoseVectorState s = At(traj, traj.tracking_start_s() + tau);
    const Vector6d d = s.q - Home();
    EXPECT_NEAR(d[0], 0.08 * std::sin(2 * kPi * tau), 1e-9);
    EXPECT_NEAR(d[1], 0.08 * std::cos(2 * kPi * tau), 1e-9);
    EXPECT_NEAR(d[2], 0.08 * std::sin(2 * kPi * tau), 1e-9);
    EXPECT_LT(d.tail<3>().cwiseAbs().maxCoeff(), 1e-15);
  }
  // The blend starts at home at rest although the reference starts at y = +8 cm.
  EXPECT_LT((At(traj, 0.0).q - Home()).cwiseAbs().maxCoeff(), 1e-15);
  ExpectContinuousAt(traj, traj.tracking_start_s(), "blend end");
}

TEST(TrajectoryStop, EarlyStopIsContinuousAndEndsAtRest) {
  const Trajectory traj = MakePaperTrajectory(PaperMotion::kCombined, OffHomeStart(), Home(),
                                              TrajectoryTiming{2.0, 1.0});
  for (double t_stop : {0.7, 2.0, 3.3}) {  // during the blend, at its end, while tracking
    const double eps = 1e-7;
    TrajectorySample left, right, end;
    traj.EvaluateStopped(t_stop - eps, t_stop, left);
    traj.EvaluateStopped(t_stop + eps, t_stop, right);
    EXPECT_LT((left.vector.q - right.vector.q).cwiseAbs().maxCoeff(), 1e-6) << t_stop;
    EXPECT_LT((left.vector.q_dot - right.vector.q_dot).cwiseAbs().maxCoeff(), 1e-5) << t_stop;
    EXPECT_EQ(right.phase, TrajectoryPhase::kStop);
    const double end_t = traj.StoppedDuration(t_stop);
    EXPECT_NEAR(end_t, t_stop + 1.0, 1e-12);
    traj.EvaluateStopped(end_t, t_stop, end);
    EXPECT_EQ(end.phase, TrajectoryPhase::kDone);
    EXPECT_LT((end.vector.q - Home()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT(end.vector.q_dot.cwiseAbs().maxCoeff(), 1e-12);
    TrajectorySample near_end;
    traj.EvaluateStopped(end_t - 1e-7, t_stop, near_end);
    EXPECT_LT((near_end.vector.q_dot).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(TrajectoryPhases, PhasesFollowTheWindow) {
  const Trajectory traj =
      MakePaperTrajectory(PaperMotion::kX, Home(), Home(), TrajectoryTiming{2.0, 1.0}, 3);
  EXPECT_DOUBLE_EQ(traj.tracking_start_s(), 2.0);
  EXPECT_NEAR(traj.tracking_end_s(), 32.0, 1e-12);
  EXPECT_NEAR(traj.duration_s(), 33.0, 1e-12);
  TrajectorySample s;
  traj.Evaluate(1.999, s);
  EXPECT_EQ(s.phase, TrajectoryPhase::kBlend);
  traj.Evaluate(2.0, s);
  EXPECT_EQ(s.phase, TrajectoryPhase::kTracking);
  traj.Evaluate(32.5, s);
  EXPECT_EQ(s.phase, TrajectoryPhase::kStop);
  traj.Evaluate(33.0, s);
  EXPECT_EQ(s.phase, TrajectoryPhase::kDone);
}

TEST(TrajectoryValidation, BadArgumentsThrow) {
  EXPECT_THROW(Trajectory(nullptr, Home(), Home(), TrajectoryTiming{}), std::invalid_argument);
  auto motion = MakePaperMotion(PaperMotion::kX, Home());
  EXPECT_THROW(Trajectory(motion, Home(), Home(), TrajectoryTiming{0.0, 1.0}),
               std::invalid_argument);
  EXPECT_THROW(Trajectory(motion, Home(), Home(), TrajectoryTiming{1.0, -1.0}),
               std::invalid_argument);
  Vector6d bad = Home();
  bad[2] = NAN;
  EXPECT_THROW(Trajectory(motion, bad, Home(), TrajectoryTiming{}), std::invalid_argument);
  EXPECT_THROW(SinusoidMotion(Home(), Home(), Vector6d::Zero(), 0.0, 1), std::invalid_argument);
  PaperMotion m;
  EXPECT_TRUE(ParsePaperMotion("combined", m));
  EXPECT_EQ(m, PaperMotion::kCombined);
  EXPECT_FALSE(ParsePaperMotion("circle", m));
}

}  // namespace
}  // namespace hexa
