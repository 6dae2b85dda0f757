// The identification excitation (excitation.hpp): deterministic, in the valve's range, both
// directions, the guard keeps the piston off the end stops, and the leg controller drives the
// valve open loop only inside the leg's window.
#include <gtest/gtest.h>

#include <cmath>

#include "hexa/core/excitation.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/leg_model.hpp"

namespace hexa {
namespace {

TEST(Excitation, PlanExcitesTheLegsOneAfterTheOther) {
  const ExcitationPlan plan = PlanIdentificationExperiment({2, 5}, 10.0, 4, 1.0, 1.5);
  EXPECT_FALSE(plan.legs[0].enabled());
  EXPECT_DOUBLE_EQ(plan.legs[1].start_s, 1.0);
  EXPECT_DOUBLE_EQ(plan.legs[4].start_s, 12.5);
  EXPECT_NE(plan.legs[1].seed, plan.legs[4].seed);
  EXPECT_DOUBLE_EQ(plan.total_duration_s, 24.0);
  EXPECT_THROW(PlanIdentificationExperiment({7}, 10.0, 1), std::invalid_argument);
}

TEST(Excitation, SingleLegStaysOffTheEndStopsAndCoversBothDirectionsAndSpeeds) {
  const RigParams rig = MakeReferenceRig();
  SingleLegConfig c;
  c.leg = MakeLegModelParams(rig, 1.2, 1.1);
  c.load_mass_kg = 3.0;
  SingleLegPlant plant(c);
  ExcitationParams p;
  p.duration_s = 30.0;
  ExcitationGenerator a(p, rig.valve, rig.cylinder), b(p, rig.valve, rig.cylinder);
  double x_max = 0.0, v_up = 0.0, v_down = 0.0;
  for (int k = 0; k < 30000; ++k) {
    const double t = k * 1e-3;
    const double l = rig.cylinder.mid_stroke_length_m + plant.position_m();
    const double u = a.Update(t, l);
    ASSERT_EQ(u, b.Update(t, l));  // deterministic
    ASSERT_GE(u, rig.valve.min_voltage_v);
    ASSERT_LE(u, rig.valve.max_voltage_v);
    ASSERT_EQ(plant.Step(u, 1e-3), PlantStatus::kOk);
    x_max = std::max(x_max, std::abs(plant.position_m()));
    v_up = std::max(v_up, plant.velocity_m_s());
    v_down = std::min(v_down, plant.velocity_m_s());
  }
  EXPECT_LT(x_max, 0.5 * rig.cylinder.stroke_m - 0.01);  // the guard: never near an end stop
  EXPECT_GT(v_up, 0.8);
  EXPECT_LT(v_down, -0.8);
}

TEST(Excitation, LegControllerIsOpenLoopOnlyInsideItsWindow) {
  LegControllerConfig c = LegControllerConfig::FromRig(MakeReferenceRig(), LegControllerParams{},
                                                       LegControllerKind::kExcitation);
  c.excitation.start_s = 1.0;
  c.excitation.duration_s = 2.0;
  LegController leg(c);
  LegControllerInput in;
  in.length_m = c.model.cylinder.mid_stroke_length_m;
  in.cap_pressure_pa = 4e5;
  in.rod_pressure_pa = 4e5;
  in.supply_pressure_pa = 7e5;
  in.has_setpoint = true;
  in.setpoint_length_m = in.length_m;
  LegControllerOutput out;
  for (const auto& [t, open] : {std::pair{0.5, false}, {1.0, true}, {2.9, true}, {3.0, false}}) {
    in.time_s = t;
    in.setpoint_time_s = t;
    leg.Update(in, out);
    EXPECT_EQ(out.open_loop, open) << "t = " << t;
    EXPECT_EQ(out.status, LegControlStatus::kOk);
  }
}

}  // namespace
}  // namespace hexa
