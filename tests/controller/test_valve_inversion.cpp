// One implementation of eq 4, 5, 7, 42, 43, 64, 65 (pneumatics.hpp): the BS-SMC's valve
// inversion (eq 44) is the exact inverse of the plant's pressure dynamics. For random
// chamber states and force-rate demands, the spool the controller commands, put into the
// plant's LegModel (same parameters, spool at its target), gives the force rate
// A1 P1' - A2 P2' the controller asked for (eq 38), wherever the valve is not saturated.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/leg_model.hpp"

namespace hexa {
namespace {

TEST(BsSmcValveInversion, CommandedSpoolGivesTheDemandedForceRateInThePlantModel) {
  RigParams rig = MakeReferenceRig();
  // The plant blends the Table 8 sets across v = 0; at rest both sets must agree for the
  // comparison to be exact (the controller picks the set of the routing).
  rig.polytropic.retract = rig.polytropic.extend;
  BsSmcConfig c;
  c.model = NominalLegModel::FromRig(rig);
  c.params.null_band_area_fraction = 0.0;       // the exact square root of eq 43
  c.params.spool_filter_time_constant_s = 0.0;  // no command filter
  c.params.integral_gain_n_m = 0.0;
  const LegModel plant(MakeLegModelParams(rig));
  const CylinderParams& cyl = rig.cylinder;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> pressure(1.3e5, 6.5e5), position(-0.1, 0.1), error(-0.02, 0.02);
  int checked = 0;
  for (int trial = 0; trial < 400; ++trial) {
    BsSmcController ctrl(c);
    BsSmcInput in;
    in.cap_pressure_pa = pressure(rng);
    in.rod_pressure_pa = pressure(rng);
    in.supply_pressure_pa = rig.air.supply_pressure_pa;
    in.length_m = cyl.mid_stroke_length_m + position(rng);
    in.desired_length_m = in.length_m + error(rng);
    BsSmcOutput out;
    for (int k = 0; k < 40; ++k) ctrl.Update(in, out);  // the leg at rest: v = 0, phi_dot = 0
    if (out.saturated || std::abs(out.spool_m) >= rig.valve.max_spool_m) continue;
    const double demanded = out.desired_force_rate_n_s - c.params.backstepping_beta_1_s * out.force_error_n;
    LegPneumaticState s;
    s.chamber1_pressure_pa = in.cap_pressure_pa;
    s.chamber2_pressure_pa = in.rod_pressure_pa;
    s.spool_m = out.spool_m;
    LegPneumaticState rate;
    LegForces forces;
    plant.Evaluate(s, in.length_m - cyl.mid_stroke_length_m, 0.0, out.spool_m, in.supply_pressure_pa,
                   rate, forces);
    const double delivered = cyl.cap_area_m2 * rate.chamber1_pressure_pa -
                             cyl.annulus_area_m2 * rate.chamber2_pressure_pa;
    EXPECT_NEAR(delivered, demanded, 1e-9 * std::abs(demanded) + 1e-6) << "trial " << trial;
    ++checked;
  }
  EXPECT_GT(checked, 100);  // most random demands are within the valve's reach
}

}  // namespace
}  // namespace hexa
