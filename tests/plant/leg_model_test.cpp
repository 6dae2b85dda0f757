// Single pneumatic leg: holding, end stops, energy, friction dissipation, bad input.
#include <algorithm>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hexa/core/leg_model.hpp"

namespace hexa {
namespace {

SingleLegConfig DefaultLeg() {
  SingleLegConfig config;
  config.leg = MakeLegModelParams(MakeReferenceRig());
  return config;
}

TEST(SingleLeg, NullValveHoldsTheLoad) {
  SingleLegPlant plant(DefaultLeg());
  for (int i = 0; i < 10000; ++i) ASSERT_EQ(plant.Step(5.0, 1e-3), PlantStatus::kOk);
  EXPECT_LT(std::abs(plant.position_m()), 1e-3);
  EXPECT_LT(std::abs(plant.velocity_m_s()), 1e-6);
}

TEST(SingleLeg, StaticFrictionHoldsAnUnbalancedLoadWithinPresliding) {
  // Chambers set 20 N short of the load's weight: stiction (F_s = 91.9 N retract) holds it;
  // the LuGre bristle deflects by about F / sigma0.
  SingleLegConfig config = DefaultLeg();
  SingleLegPlant plant(config);
  SingleLegState s = plant.state();
  s.leg.chamber1_pressure_pa -= 20.0 / config.leg.cylinder.cap_area_m2;
  plant.ResetTo(s);
  for (int i = 0; i < 2000; ++i) ASSERT_EQ(plant.Step(5.0, 1e-3), PlantStatus::kOk);
  EXPECT_LT(plant.position_m(), 0.0);
  EXPECT_GT(plant.position_m(), -3.0 * 20.0 / config.leg.friction.bristle_stiffness_n_m);
  EXPECT_LT(std::abs(plant.velocity_m_s()), 1e-4);
}

TEST(SingleLeg, FullOpeningDrivesIntoEachEndStopAndBack) {
  SingleLegConfig config = DefaultLeg();
  SingleLegPlant plant(config);
  const double half = 0.5 * config.leg.cylinder.stroke_m;
  double max_x = -1.0, min_x = 1.0;
  for (double volts : {0.0, 10.0, 0.0}) {
    for (int i = 0; i < 1500; ++i) {
      ASSERT_EQ(plant.Step(volts, 1e-3), PlantStatus::kOk) << "t = " << plant.time_s();
      max_x = std::max(max_x, plant.position_m());
      min_x = std::min(min_x, plant.position_m());
    }
  }
  // Reached both stops (penetration of the stiff spring is small, a few mm at most).
  EXPECT_GT(max_x, half - 1e-3);
  EXPECT_LT(max_x, half + 5e-3);
  EXPECT_LT(min_x, -half + 1e-3);
  EXPECT_GT(min_x, -half - 5e-3);
  // Ends resting on the upper stop with chamber 1 near supply and chamber 2 near ambient.
  EXPECT_NEAR(plant.position_m(), half, 3e-3);
  EXPECT_NEAR(plant.chamber1_pressure_pa(), config.leg.air.supply_pressure_pa, 0.05e5);
  EXPECT_NEAR(plant.chamber2_pressure_pa(), config.leg.air.atmosphere_pressure_pa, 0.05e5);
}

TEST(SingleLeg, RejectsNonFiniteInputWithoutAdvancing) {
  SingleLegPlant plant(DefaultLeg());
  const SingleLegState before = plant.state();
  EXPECT_EQ(plant.Step(std::numeric_limits<double>::quiet_NaN(), 1e-3),
            PlantStatus::kInvalidInput);
  EXPECT_EQ(plant.Step(5.0, std::numeric_limits<double>::infinity()),
            PlantStatus::kInvalidInput);
  EXPECT_EQ(plant.time_s(), 0.0);
  EXPECT_EQ(plant.position_m(), before.position_m);
  EXPECT_EQ(plant.chamber1_pressure_pa(), before.leg.chamber1_pressure_pa);
}

// Closed chambers, no friction, gamma = k (adiabatic): kinetic + gravitational +
// sum P_i V_i / (k - 1) + P_a A_r x is a first integral (docs/plant.md).
SingleLegConfig ConservativeLeg(double step_s) {
  SingleLegConfig config = DefaultLeg();
  config.leg.chambers_sealed = true;
  config.leg.friction_enabled = false;
  const double k = config.leg.air.heat_ratio;
  config.leg.polytropic.extend = {k, k, k};
  config.leg.polytropic.retract = {k, k, k};
  config.integrator_step_s = step_s;
  return config;
}

double MaxEnergyDrift(double step_s, double* energy_swing) {
  SingleLegPlant plant(ConservativeLeg(step_s));
  SingleLegState s = plant.state();
  s.velocity_m_s = 0.6;  // oscillates on the pneumatic spring, about +-20 mm
  plant.ResetTo(s);
  const double e0 = plant.TotalEnergyJ();
  double drift = 0.0;
  for (int i = 0; i < 10000; ++i) {
    EXPECT_EQ(plant.Step(5.0, 1e-3), PlantStatus::kOk);
    drift = std::max(drift, std::abs(plant.TotalEnergyJ() - e0));
  }
  if (energy_swing != nullptr) *energy_swing = 0.5 * plant.moving_mass_kg() * 0.36;
  return drift;
}

TEST(SingleLegEnergy, ConservedWithClosedChambersAndNoFriction) {
  double kinetic0 = 0.0;
  const double drift = MaxEnergyDrift(1e-4, &kinetic0);
  // Bound: 1e-6 of the kinetic energy exchanged with the pneumatic springs over 10 s.
  EXPECT_LT(drift, 1e-6 * kinetic0) << "drift " << drift << " J of " << kinetic0 << " J";
  // And it is integrator error: halving the step shrinks it (RK4, order 4 -> ~16x).
  const double drift_coarse = MaxEnergyDrift(2e-4, nullptr);
  EXPECT_LT(drift, drift_coarse / 4.0) << drift << " vs " << drift_coarse;
}

TEST(SingleLegEnergy, FrictionNeverAddsEnergyWithClosedValves) {
  SingleLegConfig config = DefaultLeg();
  config.leg.chambers_sealed = true;
  const double k = config.leg.air.heat_ratio;
  config.leg.polytropic.extend = {k, k, k};
  config.leg.polytropic.retract = {k, k, k};
  SingleLegPlant plant(config);
  SingleLegState s = plant.state();
  s.velocity_m_s = 1.5;  // slides, sticks, slips back and forth on the pneumatic spring
  plant.ResetTo(s);
  double previous = plant.TotalEnergyJ();
  const double e0 = previous;
  for (int i = 0; i < 10000; ++i) {
    ASSERT_EQ(plant.Step(5.0, 1e-3), PlantStatus::kOk);
    const double e = plant.TotalEnergyJ();
    // Non-increasing up to the integrator's own error per 1 ms tick (the conservative
    // test above bounds the accumulated error over 10 s).
    EXPECT_LE(e, previous + 1e-7) << "t = " << plant.time_s();
    previous = e;
  }
  EXPECT_LT(previous, e0 - 0.5 * plant.moving_mass_kg() * 1.5 * 1.5 * 0.5);  // dissipated
  EXPECT_GE(plant.min_friction_dissipation_w(), 0.0);
}

}  // namespace
}  // namespace hexa
