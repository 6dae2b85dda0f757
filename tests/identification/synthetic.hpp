// A noise-free synthetic identification recording: one vertical cylinder (SingleLegPlant,
// rod up, carrying a load) driven open loop by the identification excitation, sampled every
// tick like the plant service samples the rig. The load's inertia and weight are known
// exactly (LoadSeries: f_req = M (x'' + g)), so the fit sees only the pneumatic model.
#pragma once

#include <cmath>

#include "hexa/core/excitation.hpp"
#include "hexa/core/leg_model.hpp"
#include "hexa/core/pneumatic_identification.hpp"

namespace hexa::testing {

struct SyntheticRecording {
  LegSeries leg;
  double moving_mass_kg = 0.0;
  double gravity_m_s2 = 9.81;
  LegModelParams truth;
};

inline SyntheticRecording MakeSyntheticRecording(const RigParams& rig, const LegModelParams& truth,
                                                 double duration_s, std::uint64_t seed,
                                                 double load_kg = 3.0) {
  SingleLegConfig c;
  c.leg = truth;
  c.load_mass_kg = load_kg;
  c.mount = LegMount::kRodUp;
  SingleLegPlant plant(c);
  plant.Reset(0.0);
  ExcitationParams e;
  e.start_s = 0.0;
  e.duration_s = duration_s;
  e.seed = seed;
  ExcitationGenerator gen(e, rig.valve, rig.cylinder);
  SyntheticRecording r;
  r.moving_mass_kg = plant.moving_mass_kg();
  r.gravity_m_s2 = c.gravity_m_s2;
  r.truth = truth;
  const double h = 0.001;
  const auto ticks = static_cast<std::size_t>(std::llround(duration_s / h));
  for (std::size_t k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) * h;
    const double length = rig.cylinder.mid_stroke_length_m + plant.position_m();
    const double u = gen.Update(t, length);
    r.leg.length_m.push_back(length);
    r.leg.cap_pressure_pa.push_back(plant.chamber1_pressure_pa());
    r.leg.rod_pressure_pa.push_back(plant.chamber2_pressure_pa());
    r.leg.supply_pressure_pa.push_back(plant.supply_pressure_pa());
    r.leg.valve_v.push_back(u);
    r.leg.excited.push_back(1);
    plant.Step(u, h);
  }
  return r;
}

// The vertical load: f_req = M (x'' + g), M_eff = M (no payload scale).
inline LoadSeries SingleLegLoad(const SyntheticRecording& r, const std::vector<double>& accel) {
  LoadSeries l;
  for (double a : accel) {
    l.force_fixed_n.push_back(r.moving_mass_kg * (a + r.gravity_m_s2));
    l.force_scaled_n.push_back(0.0);
    l.mass_fixed_kg.push_back(r.moving_mass_kg);
    l.mass_scaled_kg.push_back(0.0);
  }
  return l;
}

}  // namespace hexa::testing
