// The platform's inverse dynamics used by the identification (platform_inverse_dynamics.hpp)
// against the plant: for the plant's true lengths and rates and a payload scale, the leg
// forces it computes equal the forces the plant's legs exert (LegForces::total_n).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "hexa/core/platform_inverse_dynamics.hpp"
#include "hexa/core/platform_plant.hpp"

namespace hexa {
namespace {

TEST(PlatformInverseDynamics, ReproducesThePlantsLegForces) {
  PlatformPlantConfig c;
  c.disturbance = MakeIdealDisturbanceProfile();
  c.disturbance.payload_scale = 1.3;
  PlatformPlant plant(c);
  const int n = 3000;
  std::vector<LegArray<double>> len(n), vel(n), force(n);
  for (int k = 0; k < n; ++k) {
    len[k] = plant.truth().length_m;
    vel[k] = plant.truth().piston_velocity_m_s;
    for (std::size_t i = 0; i < kNumLegs; ++i) force[k][i] = plant.output().leg_forces[i].total_n;
    LegArray<double> u;
    for (std::size_t i = 0; i < kNumLegs; ++i) u[i] = 5.0 + 0.6 * std::sin(2.0 * 3.14159 * (1.0 + 0.37 * i) * k * 1e-3 + i);
    ASSERT_EQ(plant.Step(u, 1e-3), PlantStatus::kOk);
  }
  PlatformInverseDynamics dynamics(c.rig);
  std::vector<double> errors;
  double scale = 0.0;
  for (int k = 1; k + 1 < n; ++k) {
    LegArray<double> a;
    for (std::size_t i = 0; i < kNumLegs; ++i) a[i] = (vel[k + 1][i] - vel[k - 1][i]) / 2e-3;
    PlatformLoad load;
    ASSERT_EQ(dynamics.Evaluate(len[k], vel[k], a, load), KinStatus::kOk);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      errors.push_back(std::abs(load.force_fixed_n[i] + 1.3 * load.force_scaled_n[i] - force[k][i]));
      scale = std::max(scale, std::abs(force[k][i]));
    }
  }
  std::sort(errors.begin(), errors.end());
  // Central differences of the velocity: second-order accurate at 1 ms.
  EXPECT_LT(errors[errors.size() / 2], 0.01);
  EXPECT_LT(errors[errors.size() * 99 / 100], 1e-3 * scale);
  // Wrong payload: clearly off (the check can fail).
  PlatformInverseDynamics again(c.rig);
  LegArray<double> a;
  for (std::size_t i = 0; i < kNumLegs; ++i) a[i] = (vel[1001][i] - vel[999][i]) / 2e-3;
  PlatformLoad load;
  ASSERT_EQ(again.Evaluate(len[1000], vel[1000], a, load), KinStatus::kOk);
  EXPECT_GT(std::abs(load.force_fixed_n[0] + 1.0 * load.force_scaled_n[0] - force[1000][0]), 1.0);
}

}  // namespace
}  // namespace hexa
