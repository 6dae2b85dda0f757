// Inverse dynamics of the platform (core/platform_dynamics) against the plant's forward
// dynamics: leg forces computed for a desired motion, applied to the plant model in that
// state, must give the desired twist rate (residual acceleration ~ 0), at rest and in motion.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/platform_dynamics.hpp"
#include "hexa/core/platform_plant.hpp"

namespace hexa {
namespace {

// Plant with friction off (its total leg force is then the pneumatic force alone) and the
// given profile; the inertial parameters of the inverse dynamics are the plant's TRUE ones.
struct Bench {
  explicit Bench(bool realistic) : plant(Config(realistic)) {
    inertial.platform_mass_kg = plant.platform_mass_kg();
    const double scale = plant.config().disturbance.payload_scale;
    inertial.platform_inertia_P_kg_m2 =
        (plant.config().rig.platform.inertia_diag_kg_m2 * scale).asDiagonal();
    inertial.leg_moving_mass_kg = plant.config().rig.cylinder.moving_mass_kg;
    inertial.gravity_m_s2 = plant.config().rig.platform.gravity_m_s2;
  }
  static PlatformPlantConfig Config(bool realistic) {
    PlatformPlantConfig c;
    c.disturbance = realistic ? MakeRealisticDisturbanceProfile() : MakeIdealDisturbanceProfile();
    c.seed = 5;
    c.friction_enabled = false;
    return c;
  }
  // Puts the plant in `motion` with chamber pressures that make each leg's pneumatic force
  // equal to `force_n`, and returns the plant's twist rate.
  Vector6d Apply(const PlatformMotion& motion, const LegArray<double>& force_n) {
    PlatformTrueState s = plant.truth();
    s.pose = motion.pose;
    s.q_BP = Eigen::Quaterniond(motion.pose.R_BP);
    s.twist_B = motion.twist_B;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      // P2 such that P1 stays well above ambient for pulling forces too.
      const CylinderParams& c = plant.config().rig.cylinder;
      const double p2 = std::max(3.0e5, (3.0e5 * c.cap_area_m2 - force_n[i] -
                                         1.0e5 * c.rod_area_m2) / c.annulus_area_m2);
      s.legs[i] = plant.leg_model().Equilibrium(force_n[i], p2);
    }
    plant.SetState(s);
    for (const auto& f : plant.output().leg_forces) EXPECT_EQ(f.end_stop_n, 0.0);
    return plant.twist_rate_B();
  }
  PlatformPlant plant;
  PlatformInertialParams inertial;
};

PlatformMotion RandomMotion(std::mt19937_64& rng, double speed_scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector6d q;
  q << 0.04 * u(rng), 0.04 * u(rng), 0.45 + 0.04 * u(rng), 0.12 * u(rng), 0.12 * u(rng),
      0.12 * u(rng);  // legs inside the stroke (no end-stop force)
  PlatformMotion m;
  m.pose = PoseFromVector(q);
  for (int k = 0; k < 3; ++k) {
    m.twist_B[k] = speed_scale * 0.6 * u(rng);        // m/s
    m.twist_B[3 + k] = speed_scale * 1.5 * u(rng);    // rad/s
    m.twist_rate_B[k] = speed_scale * 5.0 * u(rng);   // m/s^2
    m.twist_rate_B[3 + k] = speed_scale * 20.0 * u(rng);  // rad/s^2
  }
  return m;
}

void ExpectResidualAccelerationZero(bool realistic, double speed_scale) {
  Bench bench(realistic);
  std::mt19937_64 rng(42);
  double worst_linear = 0.0, worst_angular = 0.0;
  for (int n = 0; n < 200; ++n) {
    const PlatformMotion m = RandomMotion(rng, speed_scale);
    LegForceResult f;
    ASSERT_EQ(LegForcesForMotion(bench.plant.true_geometry(), bench.inertial, m, f), KinStatus::kOk);
    const Vector6d rate = bench.Apply(m, f.force_n);
    worst_linear = std::max(worst_linear, (rate - m.twist_rate_B).head<3>().norm());
    worst_angular = std::max(worst_angular, (rate - m.twist_rate_B).tail<3>().norm());
  }
  // Forces are tens to hundreds of N, accelerations up to ~10 m/s^2: the residual is
  // round-off (the plant solves the mass matrix, the inverse dynamics J^T).
  EXPECT_LT(worst_linear, 1e-9) << "m/s^2";
  EXPECT_LT(worst_angular, 1e-8) << "rad/s^2";
  std::printf("speed scale %.0f, %s: worst residual %.2e m/s^2, %.2e rad/s^2\n", speed_scale,
              realistic ? "realistic (true geometry, payload x1.2)" : "ideal", worst_linear,
              worst_angular);
}

TEST(PlatformDynamics, AtRestResidualAccelerationIsZero) {
  ExpectResidualAccelerationZero(false, 0.0);
  ExpectResidualAccelerationZero(true, 0.0);
}

TEST(PlatformDynamics, InMotionResidualAccelerationIsZero) {
  ExpectResidualAccelerationZero(false, 1.0);
  ExpectResidualAccelerationZero(true, 1.0);
}

TEST(PlatformDynamics, HomeAtRestCarriesTheWeight) {
  // Static balance: the six forces carry platform + leg weight (sum of vertical components).
  const RigParams rig = MakeReferenceRig();
  const PlatformInertialParams inertial = PlatformInertialParams::FromRig(rig);
  PlatformMotion m;
  m.pose.p_BP_B_m = rig.geometry.home_position_m;
  LegForceResult f;
  ASSERT_EQ(LegForcesForMotion(rig.geometry, inertial, m, f), KinStatus::kOk);
  double vertical = 0.0;
  LegArray<double> lengths;
  LegArray<Eigen::Vector3d> unit;
  InverseKinematics(rig.geometry, m.pose, lengths, &unit);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    vertical += f.force_n[i] * unit[i].z();
    EXPECT_NEAR(f.force_n[i], f.force_n[0], 1e-9);  // symmetric rig: equal shares
  }
  EXPECT_NEAR(vertical, (6.0 + 6 * 0.25) * 9.81, 1e-9);
  // docs/controller.md: 6 kg / 6 legs / cos(26.64 deg) = 10.97 N + the rod's share.
  EXPECT_NEAR(f.force_n[0], (6.0 + 6 * 0.25) * 9.81 / 6.0 / unit[0].z(), 1e-9);
}

// Leg-space mass matrix (coupled leg feedback): at rest, M_ls applied to leg
// accelerations equals the leg forces that produce them minus the static (zero-acceleration)
// forces, the forces computed independently by LegForcesForMotion (J^T f = wrench solved, not
// J^-T M_p J^-1). And those forces, applied to the plant, give the accelerations.
TEST(PlatformDynamics, LegSpaceMassMatrixMapsLegAccelerationsToForcesAtRest) {
  for (const bool realistic : {false, true}) {
    Bench bench(realistic);
    const GeometryParams& geometry = bench.plant.true_geometry();
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    double worst_force = 0.0, worst_asym = 0.0, worst_plant = 0.0, min_eig = 1e9;
    for (int n = 0; n < 200; ++n) {
      PlatformMotion rest = RandomMotion(rng, 0.0);  // zero twist and twist rate
      Matrix6d m_ls;
      ASSERT_EQ(LegSpaceMassMatrix(geometry, bench.inertial, rest.pose, m_ls), KinStatus::kOk);
      Vector6d l_ddot;
      for (int k = 0; k < 6; ++k) l_ddot[k] = 5.0 * u(rng);  // m/s^2
      Matrix6d J;
      LegJacobian(geometry, rest.pose, J);
      PlatformMotion moving = rest;
      moving.twist_rate_B = J.inverse() * l_ddot;  // at rest l_ddot = J t_dot (c = 0)
      LegForceResult f0, f1;
      ASSERT_EQ(LegForcesForMotion(geometry, bench.inertial, rest, f0), KinStatus::kOk);
      ASSERT_EQ(LegForcesForMotion(geometry, bench.inertial, moving, f1), KinStatus::kOk);
      const Vector6d predicted = m_ls * l_ddot;
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        const int ii = static_cast<int>(i);
        worst_force = std::max(worst_force, std::abs(f1.force_n[i] - f0.force_n[i] - predicted[ii]));
        EXPECT_NEAR(f1.leg_acceleration_m_s2[i], l_ddot[ii], 1e-9);
      }
      worst_asym = std::max(worst_asym, (m_ls - m_ls.transpose()).cwiseAbs().maxCoeff());
      min_eig = std::min(min_eig, Eigen::SelfAdjointEigenSolver<Matrix6d>(m_ls).eigenvalues()[0]);
      // The plant, given static + M_ls l_ddot, accelerates the platform by J^-1 l_ddot.
      LegArray<double> force{};
      for (std::size_t i = 0; i < kNumLegs; ++i) force[i] = f0.force_n[i] + predicted[static_cast<int>(i)];
      const Vector6d rate = bench.Apply(rest, force);
      worst_plant = std::max(worst_plant, (J * rate - l_ddot).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(worst_force, 1e-9) << "N";
    EXPECT_EQ(worst_asym, 0.0);
    EXPECT_GT(min_eig, 0.0);
    EXPECT_LT(worst_plant, 1e-9) << "m/s^2";
    std::printf("%s: worst |f - f0 - M_ls l_ddot| %.2e N, plant leg-acceleration residual %.2e m/s^2, "
                "smallest modal mass %.3f kg\n", realistic ? "realistic" : "ideal", worst_force,
                worst_plant, min_eig);
  }
}

TEST(PlatformDynamics, LegSpaceMassMatrixModalMassesAtHome) {
  // docs/measurements/control_light_modes.md "Leg-space modes": eigenvalues 0.877 (x2), 1.502,
  // 2.787, 10.27 (x2) kg on the reference rig.
  const RigParams rig = MakeReferenceRig();
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  Matrix6d m_ls;
  ASSERT_EQ(LegSpaceMassMatrix(rig.geometry, PlatformInertialParams::FromRig(rig), home, m_ls),
            KinStatus::kOk);
  const Vector6d e = Eigen::SelfAdjointEigenSolver<Matrix6d>(m_ls).eigenvalues();
  const double expected[6] = {0.877, 0.877, 1.502, 2.787, 10.27, 10.27};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(e[k], expected[k], 0.006) << k;
  // z mode: m_p / (6 cos^2 of the leg's angle from vertical) + m_leg.
  LegArray<double> lengths;
  LegArray<Eigen::Vector3d> unit;
  InverseKinematics(rig.geometry, home, lengths, &unit);
  EXPECT_NEAR(e[2], 6.0 / (6.0 * unit[0].z() * unit[0].z()) + 0.25, 1e-9);
}

TEST(PlatformDynamics, LegSpaceMassMatrixRejectsNonFinitePose) {
  const RigParams rig = MakeReferenceRig();
  Pose pose;
  pose.p_BP_B_m = Eigen::Vector3d(0.0, std::nan(""), 0.45);
  Matrix6d m_ls = Matrix6d::Constant(1.0);
  EXPECT_EQ(LegSpaceMassMatrix(rig.geometry, PlatformInertialParams::FromRig(rig), pose, m_ls),
            KinStatus::kInvalidInput);
  EXPECT_EQ(m_ls.cwiseAbs().maxCoeff(), 0.0);
}

TEST(PlatformDynamics, NonFiniteInputIsRejected) {
  const RigParams rig = MakeReferenceRig();
  PlatformMotion m;
  m.pose.p_BP_B_m = rig.geometry.home_position_m;
  m.twist_rate_B[2] = std::nan("");
  LegForceResult f;
  EXPECT_EQ(LegForcesForMotion(rig.geometry, PlatformInertialParams::FromRig(rig), m, f),
            KinStatus::kInvalidInput);
  for (double x : f.force_n) EXPECT_EQ(x, 0.0);
}

}  // namespace
}  // namespace hexa
