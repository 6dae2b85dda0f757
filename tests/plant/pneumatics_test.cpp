// Valve, orifice flow and routing: eq 4, 5, 6, 42, 43, Tables 4 and 5.
#include <cmath>

#include <gtest/gtest.h>

#include "hexa/core/leg_model.hpp"
#include "hexa/core/pneumatics.hpp"

namespace hexa {
namespace {

// Eq 4 written out independently of OrificeFlowModel (no precomputed constants).
double Eq4(const AirParams& air, double cf, double area, double pu, double pd) {
  const double k = air.heat_ratio, R = air.gas_constant_j_kg_k, T = air.temperature_k;
  const double r = pd / pu;
  const double pc = std::pow(2.0 / (k + 1.0), k / (k - 1.0));
  if (r > pc) {
    return cf * area * std::sqrt(k / R * 2.0 / (k - 1.0)) * pu / std::sqrt(T) *
           std::pow(r, 1.0 / k) * std::sqrt(1.0 - std::pow(r, (k - 1.0) / k));
  }
  return cf * area * pu / std::sqrt(T) *
         std::sqrt(k / R * std::pow(2.0 / (k + 1.0), (k + 1.0) / (k - 1.0)));
}

TEST(Pneumatics, CriticalRatioIs0528ForAir) {
  EXPECT_NEAR(CriticalPressureRatio(1.4), 0.528, 5e-4);  // eq 5, paper: 0.528
}

TEST(Pneumatics, ZeroFlowAtEqualPressures) {
  const OrificeFlowModel orifice(AirParams{}, 0.6);
  for (double p : {1.0e5, 2.5e5, 4.0e5, 7.0e5}) {
    for (double area : {1e-7, 5e-6, 15e-6}) {
      EXPECT_EQ(orifice.ForwardKgS(area, p, p), 0.0) << p << " " << area;
      EXPECT_EQ(orifice.SignedKgS(area, p, p), 0.0);
    }
  }
}

TEST(Pneumatics, MatchesEq4OutsideTheLaminarBand) {
  const AirParams air;
  const OrificeFlowModel orifice(air, 0.6);
  const double pu = 7.0e5;
  for (double r : {0.0, 0.1, 0.3, 0.5, 0.528, 0.53, 0.6, 0.8, 0.9, 0.99, 0.994}) {
    const double expected = Eq4(air, 0.6, 15e-6, pu, r * pu);
    EXPECT_NEAR(orifice.ForwardKgS(15e-6, pu, r * pu), expected, 1e-12 + 1e-12 * expected)
        << "r = " << r;
  }
}

TEST(Pneumatics, FlowContinuousAtCriticalRatio) {
  const AirParams air;
  const OrificeFlowModel orifice(air, 0.6);
  const double pc = orifice.critical_ratio();
  const double pu = 7.0e5;
  const double below = orifice.ForwardKgS(15e-6, pu, pu * pc * (1.0 - 1e-9));
  const double above = orifice.ForwardKgS(15e-6, pu, pu * pc * (1.0 + 1e-9));
  ASSERT_GT(below, 0.0);
  EXPECT_NEAR(above / below, 1.0, 1e-8);
  // The two branches of eq 4 meet at P_c (not only our code, the formula itself).
  const double k = air.heat_ratio, R = air.gas_constant_j_kg_k;
  const double unchoked_at_pc = std::sqrt(k / R * 2.0 / (k - 1.0)) * std::pow(pc, 1.0 / k) *
                                std::sqrt(1.0 - std::pow(pc, (k - 1.0) / k));
  const double choked = std::sqrt(k / R * std::pow(2.0 / (k + 1.0), (k + 1.0) / (k - 1.0)));
  EXPECT_NEAR(unchoked_at_pc / choked, 1.0, 1e-12);
}

TEST(Pneumatics, FlowContinuousAtLaminarBandAndMonotone) {
  const OrificeFlowModel orifice(AirParams{}, 0.6);
  const double pu = 4.0e5;
  const double rl = orifice.laminar_ratio();
  EXPECT_NEAR(orifice.ForwardKgS(15e-6, pu, pu * rl * (1 - 1e-10)) /
                  orifice.ForwardKgS(15e-6, pu, pu * rl * (1 + 1e-10)),
              1.0, 1e-7);
  double previous = orifice.ForwardKgS(15e-6, pu, 0.0);
  for (int i = 1; i <= 1000; ++i) {
    const double flow = orifice.ForwardKgS(15e-6, pu, pu * i / 1000.0);
    EXPECT_LE(flow, previous + 1e-15) << "downstream ratio " << i / 1000.0;
    previous = flow;
  }
  EXPECT_EQ(previous, 0.0);
}

TEST(Pneumatics, SpoolFromVoltageEq42) {
  const ValveParams valve;
  EXPECT_NEAR(SpoolTargetM(valve, 5.0), 0.0, 1e-15);       // null
  EXPECT_NEAR(SpoolTargetM(valve, 0.0), 1.5e-3, 1e-15);    // extend, full
  EXPECT_NEAR(SpoolTargetM(valve, 10.0), -1.5e-3, 1e-15);  // retract, full
  EXPECT_NEAR(SpoolTargetM(valve, -3.0), 1.5e-3, 1e-15);   // coil driver saturates
  EXPECT_NEAR(OrificeAreaM2(valve, 0.0), 0.0, 0.0);
  EXPECT_NEAR(OrificeAreaM2(valve, 1.5e-3), 15e-6, 1e-18);
  EXPECT_NEAR(OrificeAreaM2(valve, -0.75e-3), 15e-6 / 4.0, 1e-18);  // quadratic, eq 6
}

TEST(Pneumatics, RoutingMatchesTables4And5) {
  const OrificeFlowModel orifice(AirParams{}, 0.6);
  const double ps = 7e5, pa = 1e5, p1 = 3e5, p2 = 3e5;
  // Table 4 (extend): supply -> chamber 1, chamber 2 -> atmosphere.
  const ChamberMassFlows extend = ValveMassFlows(orifice, 15e-6, 1e-3, ps, pa, p1, p2);
  EXPECT_NEAR(extend.chamber1_kg_s, orifice.ForwardKgS(15e-6, ps, p1), 1e-15);
  EXPECT_NEAR(extend.chamber2_kg_s, -orifice.ForwardKgS(15e-6, p2, pa), 1e-15);
  EXPECT_GT(extend.chamber1_kg_s, 0.0);
  EXPECT_LT(extend.chamber2_kg_s, 0.0);
  // Table 5 (retract): supply -> chamber 2, chamber 1 -> atmosphere.
  const ChamberMassFlows retract = ValveMassFlows(orifice, 15e-6, -1e-3, ps, pa, p1, p2);
  EXPECT_NEAR(retract.chamber2_kg_s, orifice.ForwardKgS(15e-6, ps, p2), 1e-15);
  EXPECT_NEAR(retract.chamber1_kg_s, -orifice.ForwardKgS(15e-6, p1, pa), 1e-15);
  // Null spool: both ports closed.
  const ChamberMassFlows null = ValveMassFlows(orifice, 15e-6, 0.0, ps, pa, p1, p2);
  EXPECT_EQ(null.chamber1_kg_s, 0.0);
  EXPECT_EQ(null.chamber2_kg_s, 0.0);
}

TEST(Pneumatics, LegModelRoutesByVoltageAndIsClosedAtNull) {
  const RigParams rig = MakeReferenceRig();
  const LegModel leg(MakeLegModelParams(rig));
  LegPneumaticState s;
  s.chamber1_pressure_pa = 3e5;
  s.chamber2_pressure_pa = 3e5;
  LegPneumaticState rate;
  LegForces forces;
  // 0 V: full extend opening (spool settled at its eq 42 value).
  s.spool_m = SpoolTargetM(rig.valve, 0.0);
  leg.Evaluate(s, 0.0, 0.0, s.spool_m, rig.air.supply_pressure_pa, rate, forces);
  EXPECT_GT(rate.chamber1_pressure_pa, 0.0);
  EXPECT_LT(rate.chamber2_pressure_pa, 0.0);
  // 10 V: full retract opening.
  s.spool_m = SpoolTargetM(rig.valve, 10.0);
  leg.Evaluate(s, 0.0, 0.0, s.spool_m, rig.air.supply_pressure_pa, rate, forces);
  EXPECT_LT(rate.chamber1_pressure_pa, 0.0);
  EXPECT_GT(rate.chamber2_pressure_pa, 0.0);
  // 5 V: null.
  s.spool_m = SpoolTargetM(rig.valve, 5.0);
  leg.Evaluate(s, 0.0, 0.0, s.spool_m, rig.air.supply_pressure_pa, rate, forces);
  EXPECT_EQ(forces.chamber1_mass_flow_kg_s, 0.0);
  EXPECT_EQ(forces.chamber2_mass_flow_kg_s, 0.0);
  EXPECT_EQ(rate.chamber1_pressure_pa, 0.0);
  EXPECT_EQ(rate.chamber2_pressure_pa, 0.0);
}

}  // namespace
}  // namespace hexa
