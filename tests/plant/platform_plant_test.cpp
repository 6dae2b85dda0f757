// 6-DoF plant: holding, energy, friction dissipation, end stops, disturbances, lockstep
// determinism, invalid input.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/platform_plant.hpp"

namespace hexa {
namespace {

constexpr double kTick = 1e-3;
constexpr double kPi = 3.14159265358979323846;
LegArray<double> Null() { LegArray<double> v; v.fill(5.0); return v; }

PlatformPlantConfig Config(bool realistic, std::uint64_t seed = 11) {
  PlatformPlantConfig c;
  c.disturbance = realistic ? MakeRealisticDisturbanceProfile() : MakeIdealDisturbanceProfile();
  c.seed = seed;
  return c;
}

void ExpectHolds(bool realistic) {
  PlatformPlant plant(Config(realistic));
  const Eigen::Vector3d p0 = plant.truth().pose.p_BP_B_m;
  double max_drift = 0.0, max_angle = 0.0;
  for (int k = 0; k < 10000; ++k) {
    ASSERT_EQ(plant.Step(Null(), kTick), PlantStatus::kOk);
    max_drift = std::max(max_drift, (plant.truth().pose.p_BP_B_m - p0).norm());
    max_angle = std::max(max_angle, Eigen::AngleAxisd(plant.truth().pose.R_BP).angle());
  }
  EXPECT_LT(max_drift, 1e-3);
  EXPECT_LT(max_angle, 1e-3);
  EXPECT_NEAR(plant.truth().time_s, 10.0, 1e-9);
}

TEST(PlatformPlant, NullValvesHoldIdeal) { ExpectHolds(false); }
TEST(PlatformPlant, NullValvesHoldRealistic) { ExpectHolds(true); }

TEST(PlatformPlant, HomeEquilibriumBalancesGravityAndLegsAreMidStroke) {
  PlatformPlant plant(Config(false));
  const auto& t = plant.truth();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_NEAR(t.length_m[i], 0.5034, 2e-4);  // docs/design.md: every leg 0.5034 m at home
    EXPECT_NEAR(t.piston_velocity_m_s[i], 0.0, 1e-15);
    // Legs push (compressive load) and chamber 1 is between ambient and supply.
    EXPECT_GT(plant.output().leg_forces[i].pneumatic_n, 0.0);
    EXPECT_GT(t.legs[i].chamber1_pressure_pa, 1e5);
    EXPECT_LT(t.legs[i].chamber1_pressure_pa, 7e5);
  }
}

TEST(PlatformPlant, PistonRatesMatchTheKinematicsJacobian) {
  PlatformPlant plant(Config(false));
  PlatformTrueState s = plant.truth();
  s.twist_B << 0.05, -0.02, 0.1, 0.2, -0.1, 0.3;
  plant.SetState(s);
  Matrix6d J;
  LegJacobian(plant.true_geometry(), plant.truth().pose, J);  // eq 48 (kinematics.cpp)
  const Vector6d l_dot = J * s.twist_B;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    EXPECT_NEAR(plant.truth().piston_velocity_m_s[i], l_dot[static_cast<int>(i)], 1e-12);
  }
}

PlatformPlantConfig Conservative(double step_s,
                                 PlantIntegrator integrator = PlatformPlantConfig{}.integrator) {
  PlatformPlantConfig c = Config(false);
  c.integrator = integrator;
  c.chambers_sealed = true;  // chambers closed
  c.friction_enabled = false;
  const double k = c.rig.air.heat_ratio;
  c.rig.polytropic.extend = {k, k, k};
  c.rig.polytropic.retract = {k, k, k};
  c.integrator_step_s = step_s;
  return c;
}

double PlatformEnergyDrift(double step_s, double* kinetic0,
                           PlantIntegrator integrator = PlatformPlantConfig{}.integrator) {
  PlatformPlant plant(Conservative(step_s, integrator));
  PlatformTrueState s = plant.truth();
  s.twist_B << 0.05, -0.04, 0.08, 0.3, -0.2, 0.4;  // rattles on the pneumatic springs
  plant.SetState(s);
  const double e0 = plant.TotalEnergyJ();
  double drift = 0.0;
  for (int k = 0; k < 10000; ++k) {
    EXPECT_EQ(plant.Step(Null(), kTick), PlantStatus::kOk);
    drift = std::max(drift, std::abs(plant.TotalEnergyJ() - e0));
  }
  if (kinetic0 != nullptr) {
    PlatformPlant fresh(Conservative(step_s));
    const double rest = fresh.TotalEnergyJ();
    fresh.SetState(s);
    *kinetic0 = fresh.TotalEnergyJ() - rest;
  }
  return drift;
}

// Stated bounds (docs/plant.md, "Integrator"): over 10 s at the default 0.5 ms step the
// energy drift stays below 1e-5 of the initial kinetic energy with RK4 and below 1e-3 with
// SSPRK3 (the default; measured 3.4e-8 and 3.3e-4). Both drifts are integration error: a
// 2x larger step gives at least 4x the drift (orders 4 and 3 give 16x and 8x).
TEST(PlatformEnergy, ConservedWithClosedChambersAndNoFriction) {
  const double step = PlatformPlantConfig{}.integrator_step_s;
  ASSERT_DOUBLE_EQ(step, 5e-4);
  for (const auto& [integrator, bound] :
       {std::pair{PlantIntegrator::kRk4, 1e-5}, std::pair{PlantIntegrator::kSsprk3, 1e-3}}) {
    SCOPED_TRACE(integrator == PlantIntegrator::kRk4 ? "RK4" : "SSPRK3");
    double kinetic0 = 0.0;
    const double drift = PlatformEnergyDrift(step, &kinetic0, integrator);
    ASSERT_GT(kinetic0, 0.01);
    EXPECT_LT(drift, bound * kinetic0) << drift << " J of " << kinetic0 << " J";
    EXPECT_LT(drift, PlatformEnergyDrift(2.0 * step, nullptr, integrator) / 4.0);
  }
}

TEST(PlatformEnergy, FrictionNeverAddsEnergyWithClosedValves) {
  PlatformPlantConfig c = Conservative(PlatformPlantConfig{}.integrator_step_s);
  c.friction_enabled = true;
  PlatformPlant plant(c);
  PlatformTrueState s = plant.truth();
  s.twist_B << 0.1, -0.05, 0.2, 0.5, -0.3, 0.6;
  plant.SetState(s);
  const double e0 = plant.TotalEnergyJ();
  double previous = e0;
  for (int k = 0; k < 10000; ++k) {
    ASSERT_EQ(plant.Step(Null(), kTick), PlantStatus::kOk);
    const double e = plant.TotalEnergyJ();
    EXPECT_LE(e, previous + 1e-7) << "t = " << plant.truth().time_s;
    previous = e;
  }
  EXPECT_LT(previous, e0 - 0.01);
  EXPECT_GE(plant.min_friction_dissipation_w(), 0.0);
}

TEST(PlatformPlant, FullValveOpeningIntoEndStopsAndBackStaysFinite) {
  PlatformPlant plant(Config(true));
  const double half = 0.5 * plant.config().rig.cylinder.stroke_m;
  std::vector<LegArray<double>> phases;
  LegArray<double> all_extend, all_retract, mixed;
  all_extend.fill(0.0);
  all_retract.fill(10.0);
  for (std::size_t i = 0; i < kNumLegs; ++i) mixed[i] = i % 2 == 0 ? 0.0 : 10.0;
  double max_x = -1.0, min_x = 1.0;
  for (const auto& valves : {all_extend, all_retract, mixed, all_extend}) {
    for (int k = 0; k < 1500; ++k) {
      ASSERT_EQ(plant.Step(valves, kTick), PlantStatus::kOk) << plant.truth().time_s;
      for (double x : plant.truth().piston_position_m) {
        ASSERT_TRUE(std::isfinite(x));
        max_x = std::max(max_x, x);
        min_x = std::min(min_x, x);
      }
    }
  }
  EXPECT_GT(max_x, half - 2e-3);
  EXPECT_LT(max_x, half + 5e-3);
  EXPECT_LT(min_x, -half + 2e-3);
  EXPECT_GT(min_x, -half - 5e-3);
}

TEST(PlatformPlant, RejectsNonFiniteInputAndKeepsState) {
  PlatformPlant plant(Config(true));
  LegArray<double> v = Null();
  v[3] = std::numeric_limits<double>::quiet_NaN();
  const PlatformTrueState before = plant.truth();
  EXPECT_EQ(plant.Step(v, kTick), PlantStatus::kInvalidInput);
  EXPECT_EQ(plant.output().status, PlantStatus::kInvalidInput);
  EXPECT_EQ(plant.truth().tick, before.tick);
  EXPECT_EQ(plant.truth().pose.p_BP_B_m, before.pose.p_BP_B_m);
  EXPECT_EQ(plant.Step(Null(), std::numeric_limits<double>::quiet_NaN()),
            PlantStatus::kInvalidInput);
  EXPECT_EQ(plant.Step(Null(), kTick), PlantStatus::kOk);  // recovers on good input
}

TEST(PlatformPlant, RealisticProfileDrawsBoundedErrorsFromTheSeed) {
  const PlatformPlantConfig c = Config(true, 5);
  PlatformPlant plant(c);
  double max_err = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double ea = (plant.true_geometry().p_BA_B[i] - c.rig.geometry.p_BA_B[i]).norm();
    const double eb = (plant.true_geometry().p_PB_P[i] - c.rig.geometry.p_PB_P[i]).norm();
    EXPECT_LE(ea, 2e-3);
    EXPECT_LE(eb, 2e-3);
    max_err = std::max({max_err, ea, eb});
    EXPECT_LE(std::abs(plant.sensors().calibration().offset_m[i]), 1e-3);
    EXPECT_LE(std::abs(plant.sensors().calibration().gain_error[i]), 0.005);
  }
  EXPECT_GT(max_err, 0.5e-3);  // the errors are really there
  EXPECT_NEAR(plant.platform_mass_kg(), 1.2 * c.rig.platform.mass_kg, 1e-12);
  // Supply ripple +-0.2 bar at 0.5 Hz: at t = 0.5 s the ripple is at its maximum.
  for (int k = 0; k < 500; ++k) plant.Step(Null(), kTick);
  EXPECT_NEAR(plant.truth().supply_pressure_pa, 7.2e5, 1.0);
  // The ideal profile has the nominal geometry.
  PlatformPlant ideal(Config(false, 5));
  EXPECT_EQ(ideal.true_geometry().p_BA_B[2], c.rig.geometry.p_BA_B[2]);
}

TEST(PlatformPlant, SensorsQuantiseAndAddNoise) {
  PlatformPlant plant(Config(true, 3));
  const double lsb = 0.25 / 4095.0;
  double sum_sq = 0.0;
  int n = 0;
  int imu_samples = 0;
  for (int k = 0; k < 1000; ++k) {
    plant.Step(Null(), kTick);
    const auto& out = plant.output();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double counts = (out.legs[i].length_m - 0.5034 + 0.125) / lsb;
      EXPECT_NEAR(counts, std::round(counts), 1e-6);
      const double e = out.legs[i].chamber1_pressure_pa - out.truth.legs[i].chamber1_pressure_pa;
      sum_sq += e * e;
      ++n;
    }
    imu_samples += out.imu.fresh ? 1 : 0;
  }
  EXPECT_NEAR(std::sqrt(sum_sq / n), 2e3, 0.2e3);  // sigma 2 kPa
  EXPECT_EQ(imu_samples, 200);                     // 200 Hz over 1 s
}

// Records every true state and sensor value of a 2 s run with moving valves.
std::vector<double> RecordRun(std::uint64_t seed) {
  PlatformPlant plant(Config(true, seed));
  std::vector<double> trace;
  for (int k = 0; k < 2000; ++k) {
    LegArray<double> v;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      v[i] = 5.0 + 1.5 * std::sin(2.0 * kPi * (1.0 + 0.3 * i) * k * kTick);
    }
    EXPECT_EQ(plant.Step(v, kTick), PlantStatus::kOk);
    const auto& o = plant.output();
    for (int j = 0; j < 3; ++j) trace.push_back(o.truth.pose.p_BP_B_m[j]);
    for (int j = 0; j < 6; ++j) trace.push_back(o.truth.twist_B[j]);
    trace.push_back(o.truth.q_BP.w());
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      trace.push_back(o.truth.legs[i].chamber1_pressure_pa);
      trace.push_back(o.truth.legs[i].chamber2_pressure_pa);
      trace.push_back(o.truth.legs[i].bristle_m);
      trace.push_back(o.legs[i].length_m);
      trace.push_back(o.legs[i].chamber1_pressure_pa);
    }
    trace.push_back(o.imu.q_BP_measured.x());
  }
  return trace;
}

TEST(PlatformPlant, LockstepDeterminism) {
  const std::vector<double> a = RecordRun(42);
  const std::vector<double> b = RecordRun(42);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "index " << i;  // bitwise
  const std::vector<double> c = RecordRun(43);
  std::size_t differing = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differing += a[i] != c[i] ? 1 : 0;
  EXPECT_GT(differing, a.size() / 2);
}

TEST(PlatformPlant, ResetRepeatsTheRun) {
  PlatformPlant plant(Config(true, 9));
  LegArray<double> v; v.fill(4.0);
  for (int k = 0; k < 300; ++k) plant.Step(v, kTick);
  const PlatformTrueState first = plant.truth();
  const double first_len = plant.output().legs[0].length_m;
  plant.Reset();
  for (int k = 0; k < 300; ++k) plant.Step(v, kTick);
  EXPECT_EQ(plant.truth().pose.p_BP_B_m, first.pose.p_BP_B_m);
  EXPECT_EQ(plant.output().legs[0].length_m, first_len);
}


// Rig faults (docs/faults.md): each changes what it should from its time on, nothing before,
// and the truth of the other legs not at all.
TEST(PlantFaults, SensorFaultsChangeOnlyTheirReadingFromTheirTimeOn) {
  PlatformPlantConfig c = Config(true, 21);
  c.faults.faults = {{PlantFaultKind::kPotStuck, 2, 0.3},
                     {PlantFaultKind::kPotDrift, 4, 0.3},
                     {PlantFaultKind::kPressureDead, 5, 0.3},
                     {PlantFaultKind::kImuDropout, 0, 0.3}};
  PlatformPlant faulty(c);
  PlatformPlant healthy(Config(true, 21));
  LegArray<double> v;
  double stuck = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < 600; ++k) {
    for (std::size_t i = 0; i < kNumLegs; ++i) v[i] = 5.0 + 1.0 * std::sin(2.0 * kPi * 2.0 * k * kTick + i);
    ASSERT_EQ(faulty.Step(v, kTick), PlantStatus::kOk);
    ASSERT_EQ(healthy.Step(v, kTick), PlantStatus::kOk);
    const auto& f = faulty.output();
    const auto& h = healthy.output();
    ASSERT_EQ(f.truth.pose.p_BP_B_m, h.truth.pose.p_BP_B_m) << k;  // sensors only: same physics
    const double t = f.truth.time_s;
    if (t < 0.3) {
      for (std::size_t i = 0; i < kNumLegs; ++i) ASSERT_EQ(f.legs[i].length_m, h.legs[i].length_m);
      ASSERT_FALSE(f.imu.dropped_out);
      continue;
    }
    if (std::isnan(stuck)) {  // the fault's first tick: the reading it keeps
      EXPECT_EQ(f.legs[1].length_m, h.legs[1].length_m);
      stuck = f.legs[1].length_m;
    }
    EXPECT_EQ(f.legs[1].length_m, stuck);
    EXPECT_NEAR(f.legs[3].length_m - h.legs[3].length_m, 0.01 * (t - 0.3), 1e-12);
    EXPECT_EQ(f.legs[4].chamber1_pressure_pa, 0.0);
    EXPECT_EQ(f.legs[4].chamber2_pressure_pa, h.legs[4].chamber2_pressure_pa);
    EXPECT_EQ(f.legs[0].length_m, h.legs[0].length_m);
    EXPECT_TRUE(f.imu.dropped_out);
    EXPECT_FALSE(f.imu.fresh);
  }
  EXPECT_GT(std::abs(healthy.output().legs[1].length_m - stuck), 1e-4);  // the leg moved on
}

TEST(PlantFaults, SupplyLossEmptiesTheSupplyAndChangesThePhysics) {
  PlatformPlantConfig c = Config(false);
  c.faults.faults = {{PlantFaultKind::kSupplyLoss, 0, 0.1}};
  c.faults.supply_loss_time_constant_s = 0.1;
  PlatformPlant plant(c);
  LegArray<double> v;
  v.fill(7.0);  // valves open to the supply on the cap side
  for (int k = 0; k < 100; ++k) plant.Step(v, kTick);
  EXPECT_NEAR(plant.output().legs[0].supply_pressure_pa, 7e5, 1.0);
  for (int k = 0; k < 100; ++k) plant.Step(v, kTick);
  // 0.1 s after the fault: P_a + (P_s - P_a) e^-1.
  EXPECT_NEAR(plant.truth().supply_pressure_pa, 1e5 + 6e5 * std::exp(-1.0), 2e3);
  for (int k = 0; k < 600; ++k) plant.Step(v, kTick);
  EXPECT_LT(plant.truth().supply_pressure_pa, 1.01e5);
}

TEST(PlantFaults, ParseNamesWhatIsWrong) {
  PlantFault f;
  EXPECT_EQ(ParsePlantFault("pot-stuck:3:1.5", f), "");
  EXPECT_EQ(f.kind, PlantFaultKind::kPotStuck);
  EXPECT_EQ(f.leg, 3);
  EXPECT_EQ(f.at_time_s, 1.5);
  EXPECT_EQ(ParsePlantFault("supply-loss:0:2", f), "");
  EXPECT_NE(ParsePlantFault("supply-loss:2:2", f).find("takes leg 0"), std::string::npos);
  EXPECT_NE(ParsePlantFault("pot-drift:0:2", f).find("needs a leg"), std::string::npos);
  EXPECT_NE(ParsePlantFault("pot-drift:7:2", f).find("leg '7'"), std::string::npos);
  EXPECT_NE(ParsePlantFault("stuck:1:2", f).find("unknown kind"), std::string::npos);
  EXPECT_NE(ParsePlantFault("pot-stuck:1:inf", f).find("time 'inf'"), std::string::npos);
  EXPECT_NE(ParsePlantFault("pot-stuck:1:-1", f).find("time"), std::string::npos);
  EXPECT_NE(ParsePlantFault("pot-stuck:1", f).find("expected"), std::string::npos);
  std::vector<PlantFault> list;
  EXPECT_EQ(ParsePlantFaultList("pot-stuck:3:1.5,supply-loss:0:2", list), "");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].kind, PlantFaultKind::kSupplyLoss);
  // One bad item: nothing appended, the item named.
  EXPECT_EQ(ParsePlantFaultList("pot-drift:2:1,imu-dropout:2:1", list).rfind("'imu-dropout:2:1': ", 0), 0u);
  EXPECT_EQ(list.size(), 2u);
  EXPECT_NE(ParsePlantFaultList("pot-drift:2:1,", list).find("''"), std::string::npos);
}

TEST(PlantFaults, ValidationNamesFieldValueAndLimit) {
  PlantFaultParams ok;
  ok.faults.push_back({PlantFaultKind::kPotStuck, 3, 1.5});
  ok.faults.push_back({PlantFaultKind::kSupplyLoss, 0, 2.0});
  EXPECT_NO_THROW(ok.Validate());
  auto message = [](const PlantFaultParams& p) {
    try {
      p.Validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  PlantFaultParams p = ok;
  p.supply_loss_time_constant_s = 0.0;
  EXPECT_NE(message(p).find("faults.supply_loss_time_constant_s"), std::string::npos) << message(p);
  p = ok;
  p.pot_drift_m_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(p).find("faults.pot_drift_m_s"), std::string::npos) << message(p);
  p = ok;
  p.faults[0].leg = 7;  // a sensor fault on a leg that does not exist
  EXPECT_NE(message(p).find("faults.faults[0].leg"), std::string::npos) << message(p);
  p = ok;
  p.faults[1].leg = 2;  // supply loss is not a leg fault
  EXPECT_NE(message(p).find("faults.faults[1].leg"), std::string::npos) << message(p);
  p = ok;
  p.faults[1].at_time_s = -1.0;
  EXPECT_NE(message(p).find("faults.faults[1].at_time_s"), std::string::npos) << message(p);
}

}  // namespace
}  // namespace hexa
