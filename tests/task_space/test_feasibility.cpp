// Feasibility: the paper's trajectories fit the reference rig; a trajectory scaled 20 %
// beyond the stroke is rejected naming the leg, time and excess found by an independent
// computation; speed and acceleration envelopes are enforced.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <regex>

#include "hexa/core/feasibility.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Independent leg lengths: rotation composed from Eigen angle-axis (not pose.cpp) and
// eq 46 written out.
LegArray<double> IndependentLengths(const GeometryParams& g, const Vector6d& q) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(q[5], Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(q[4], Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(q[3], Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  LegArray<double> l{};
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    l[i] = (q.head<3>() + R * g.p_PB_P[i] - g.p_BA_B[i]).norm();
  }
  return l;
}

struct WorstExcess {
  bool found = false;
  int leg = 0;  // 1-based
  double time_s = 0.0, length_m = 0.0, limit_m = 0.0;
  double max_excess_m = -1e9;  // over the whole trajectory, any leg (negative: inside)
};

// Independent scan on the same 1 ms grid: the largest excess beyond [lo, hi], earliest first.
WorstExcess ScanStroke(const RigParams& rig, const Trajectory& traj, double lo, double hi) {
  WorstExcess r;
  const double dt = 1e-3;
  const long n = static_cast<long>(std::ceil(traj.duration_s() / dt));
  for (long k = 0; k <= n; ++k) {
    const double t = std::min(k * dt, traj.duration_s());
    TrajectorySample s;
    traj.Evaluate(t, s);
    const LegArray<double> l = IndependentLengths(rig.geometry, s.vector.q);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double excess = std::max(l[i] - hi, lo - l[i]);
      if (excess > r.max_excess_m) {
        r.max_excess_m = excess;
        r.leg = static_cast<int>(i) + 1;
        r.time_s = t;
        r.length_m = l[i];
        r.limit_m = l[i] > hi ? hi : lo;
      }
    }
  }
  r.found = r.max_excess_m > 0.0;
  return r;
}

TEST(Feasibility, PaperTrajectoriesFitTheReferenceRig) {
  const RigParams rig = MakeReferenceRig();
  const SupervisorParams params;
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  for (PaperMotion m : {PaperMotion::kX, PaperMotion::kY, PaperMotion::kZ, PaperMotion::kRoll,
                        PaperMotion::kPitch, PaperMotion::kYaw, PaperMotion::kCombined}) {
    const Trajectory traj = MakePaperTrajectory(m, home, home, TimingFrom(params));
    const FeasibilityReport report = CheckFeasibility(rig, params, traj);
    EXPECT_TRUE(report.feasible) << ToString(m) << ": " << report.message;
    EXPECT_TRUE(report.message.empty());
    double max_dev = 0.0, max_v = 0.0, max_a = 0.0;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      max_dev = std::max({max_dev, report.max_length_m[i] - rig.cylinder.mid_stroke_length_m,
                          rig.cylinder.mid_stroke_length_m - report.min_length_m[i]});
      max_v = std::max(max_v, report.max_abs_speed_m_s[i]);
      max_a = std::max(max_a, report.max_abs_acceleration_m_s2[i]);
    }
    // Measured figures for docs/task_space.md.
    std::printf("%-8s legs: max |excursion| %.1f mm, max |speed| %.3f m/s, max |accel| %.2f m/s2\n",
                ToString(m), max_dev * 1e3, max_v, max_a);
  }
}

class StrokeRejection : public ::testing::TestWithParam<PaperMotion> {};

TEST_P(StrokeRejection, TwentyPercentBeyondTheStrokeNamesTheRightLegTimeAndExcess) {
  const RigParams rig = MakeReferenceRig();
  SupervisorParams params;
  // Isolate the stroke check (the valve-derived speed/acceleration bounds still apply).
  params.max_leg_speed_m_s = 1e3;
  params.max_leg_acceleration_m_s2 = 1e3;
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  const double half = 0.5 * rig.cylinder.stroke_m - params.stroke_margin_m;
  const double lo = rig.cylinder.mid_stroke_length_m - half;
  const double hi = rig.cylinder.mid_stroke_length_m + half;
  auto make = [&](double scale) {
    return MakePaperTrajectory(GetParam(), home, home, TimingFrom(params), 1, scale);
  };
  // Amplitude scale at which the motion just touches the stroke limit (bisection on the
  // independent scan), then 20 % more.
  double a = 1.0, b = 4.0;
  ASSERT_LT(ScanStroke(rig, make(a), lo, hi).max_excess_m, 0.0);
  ASSERT_GT(ScanStroke(rig, make(b), lo, hi).max_excess_m, 0.0);
  for (int it = 0; it < 40; ++it) {
    const double m = 0.5 * (a + b);
    (ScanStroke(rig, make(m), lo, hi).max_excess_m > 0.0 ? b : a) = m;
  }
  const Trajectory traj = make(1.2 * b);
  const WorstExcess expected = ScanStroke(rig, traj, lo, hi);
  ASSERT_TRUE(expected.found);

  const FeasibilityReport report = CheckFeasibility(rig, params, traj);
  ASSERT_FALSE(report.feasible);
  EXPECT_EQ(report.violation, FeasibilityViolation::kStroke) << report.message;
  EXPECT_EQ(report.leg, expected.leg) << report.message;
  EXPECT_NEAR(report.time_s, expected.time_s, 1e-9) << report.message;
  char msg[200];
  std::snprintf(msg, sizeof(msg), "leg %d at t=%.3f s: length %.4f m %s the stroke limit %.4f m by %.1f mm",
                expected.leg, expected.time_s, expected.length_m,
                expected.length_m > hi ? "exceeds" : "is below", expected.limit_m,
                std::abs(expected.length_m - expected.limit_m) * 1e3);
  EXPECT_EQ(report.message, msg);
  std::cout << ToString(GetParam()) << " x" << 1.2 * b << ": " << report.message << "\n";
}

INSTANTIATE_TEST_SUITE_P(AsymmetricMotions, StrokeRejection,
                         // Motions without a rig symmetry that would tie two legs or
                         // two peaks (x, z, pitch, yaw, roll have one).
                         ::testing::Values(PaperMotion::kY, PaperMotion::kCombined),
                         [](const ::testing::TestParamInfo<PaperMotion>& info) {
                           return std::string(ToString(info.param));
                         });

TEST(Feasibility, SpeedEnvelopeEnforced) {
  const RigParams rig = MakeReferenceRig();
  SupervisorParams params;
  params.max_leg_acceleration_m_s2 = 1e3;  // isolate the speed limit (valve bound remains)
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  Vector6d amp = Vector6d::Zero();
  amp[2] = 0.08;  // 8 cm in z at 2 Hz: platform 1.0 m/s, legs about 0.9 m/s
  auto motion = std::make_shared<const SinusoidMotion>(home, amp, Vector6d::Zero(), 2.0, 2);
  const FeasibilityReport report =
      CheckFeasibility(rig, params, Trajectory(motion, home, home, TimingFrom(params)));
  ASSERT_FALSE(report.feasible);
  EXPECT_EQ(report.violation, FeasibilityViolation::kSpeed);
  EXPECT_TRUE(std::regex_match(
      report.message,
      std::regex(R"(leg [1-6] at t=[0-9]+\.[0-9]{3} s: speed 0\.8[0-9]{2} m/s exceeds the speed limit 0\.800 m/s by 0\.0[0-9]{2} m/s)")))
      << report.message;
}

TEST(Feasibility, AccelerationEnvelopeEnforced) {
  const RigParams rig = MakeReferenceRig();
  const SupervisorParams params;
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  Vector6d amp = Vector6d::Zero();
  amp[2] = 0.04;  // 4 cm in z at 3 Hz: 14 m/s2 on the platform, speed 0.75 m/s
  auto motion = std::make_shared<const SinusoidMotion>(home, amp, Vector6d::Zero(), 3.0, 2);
  const FeasibilityReport report =
      CheckFeasibility(rig, params, Trajectory(motion, home, home, TimingFrom(params)));
  ASSERT_FALSE(report.feasible);
  EXPECT_EQ(report.violation, FeasibilityViolation::kAcceleration) << report.message;
  EXPECT_TRUE(std::regex_match(
      report.message,
      std::regex(R"(leg [1-6] at t=[0-9.]+ s: acceleration [0-9.]+ m/s2 exceeds the limit 8\.00 m/s2 by [0-9.]+ m/s2)")))
      << report.message;
}

TEST(Feasibility, LegSpeedAndAccelerationAreDerivativesOfTheLength) {
  const RigParams rig = MakeReferenceRig();
  const Vector6d home = HomePoseVector(rig.geometry.home_position_m);
  Vector6d start = home;
  start[3] = 0.05;
  const Trajectory traj = MakePaperTrajectory(PaperMotion::kCombined, start, home,
                                              TrajectoryTiming{2.0, 1.0}, 2);
  const double h = 1e-5;
  for (double t = 0.11; t < traj.duration_s(); t += 0.173) {
    TrajectorySample a, m, b;
    traj.Evaluate(t - h, a);
    traj.Evaluate(t, m);
    traj.Evaluate(t + h, b);
    LegArray<double> la, lm, lb, va, vm, vb, aa, am, ab;
    LegKinematicsOf(rig.geometry, a, la, va, aa);
    LegKinematicsOf(rig.geometry, m, lm, vm, am);
    LegKinematicsOf(rig.geometry, b, lb, vb, ab);
    const LegArray<double> independent = IndependentLengths(rig.geometry, m.vector.q);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      EXPECT_NEAR(lm[i], independent[i], 1e-12);
      EXPECT_NEAR((lb[i] - la[i]) / (2 * h), vm[i], 1e-7) << t;
      EXPECT_NEAR((vb[i] - va[i]) / (2 * h), am[i], 1e-5) << t;
    }
  }
}

TEST(Feasibility, ValveEnvelopeOfTheReferenceRig) {
  const RigParams rig = MakeReferenceRig();
  const ValveEnvelope env = DeriveValveEnvelope(rig);
  // eq 4 choked branch by hand: 0.6 * 15e-6 * 7e5 / sqrt(294) * sqrt(1.4/287 * (2/2.4)^6).
  const double by_hand = 0.6 * 15e-6 * 7e5 / std::sqrt(294.0) *
                         std::sqrt(1.4 / 287.0 * std::pow(2.0 / 2.4, 6.0));
  EXPECT_NEAR(env.choked_mass_flow_kg_s, by_hand, 1e-12);
  std::printf("valve envelope: m_dot %.5f kg/s, speed extend %.2f retract %.2f m/s, "
              "force extend %.1f retract %.1f N, mass %.3f kg, accel %.1f m/s2\n",
              env.choked_mass_flow_kg_s, env.extend_speed_m_s, env.retract_speed_m_s,
              env.extend_force_n, env.retract_force_n, env.effective_mass_kg,
              env.max_acceleration_m_s2);
  // The configured envelope is a derating of the physical one, never beyond it.
  const LegEnvelope leg = MakeLegEnvelope(rig, SupervisorParams{});
  EXPECT_LE(leg.max_speed_m_s, env.max_speed_m_s);
  EXPECT_LE(leg.max_acceleration_m_s2, env.max_acceleration_m_s2);
  EXPECT_NEAR(leg.max_length_m, 0.5034 + 0.125 - 0.01, 1e-12);
  EXPECT_NEAR(leg.min_length_m, 0.5034 - 0.125 + 0.01, 1e-12);
  // More supply pressure -> more force and flow.
  RigParams stronger = rig;
  stronger.air.supply_pressure_pa = 8e5;
  EXPECT_GT(DeriveValveEnvelope(stronger).max_acceleration_m_s2, env.max_acceleration_m_s2);
}

}  // namespace
}  // namespace hexa
