// Cylinder friction: the static Stribeck curve of eq 3 per stroke direction (Table 8
// magnitudes) and the dynamic LuGre model whose steady state is that curve (the plant's
// model; the controllers keep the static eq 14). docs/plant.md, "Leg model".
#pragma once

#include <cmath>

#include "hexa/core/rig.hpp"

namespace hexa {

// Parameters of the stroke direction of velocity v (v >= 0: extend / upward stroke).
inline const FrictionDirectionParams& FrictionForDirection(const FrictionParams& f,
                                                           double velocity_m_s) {
  return velocity_m_s >= 0.0 ? f.extend : f.retract;
}

// g(v) of the LuGre model = the Stribeck part of eq 3 without the sign and the viscous
// term: F_c + (F_s - F_c) exp(-(v / v_s)^2) > 0.
inline double StribeckLevelN(const FrictionDirectionParams& d, double velocity_m_s) {
  const double q = velocity_m_s / d.stribeck_velocity_m_s;
  return d.coulomb_n + (d.static_n - d.coulomb_n) * std::exp(-q * q);
}

// Eq 3: steady-state friction magnitude with sign, F = g(v) sgn(v) + B v, the force that
// opposes the motion (the piston feels -F). Zero at v = 0 (stiction is the LuGre's job).
inline double StribeckFrictionN(const FrictionParams& f, double velocity_m_s) {
  if (velocity_m_s == 0.0) return 0.0;
  const FrictionDirectionParams& d = FrictionForDirection(f, velocity_m_s);
  const double sgn = velocity_m_s > 0.0 ? 1.0 : -1.0;
  return StribeckLevelN(d, velocity_m_s) * sgn + d.viscous_n_s_m * velocity_m_s;
}

// LuGre (Canudas de Wit et al. 1995) with bristle deflection z:
//   dz/dt = v - sigma0 |v| z / g(v)
//   F     = sigma0 z + sigma1(v) dz/dt + B v        (opposes motion; piston feels -F)
// Steady state (dz/dt = 0): F = g(v) sgn(v) + B v = eq 3. sigma1(v) = sigma1 exp(-(v/v_d)^2)
// fades the bristle damping with speed, the standard condition that keeps the model
// dissipative (docs/plant.md); v_d = `damping_fade_velocity_m_s`.
struct LugreOutput {
  double bristle_rate_m_s = 0.0;  // dz/dt
  double force_n = 0.0;           // F (opposing), the piston feels -F
  // Power dissipated: F v - d/dt(sigma0 z^2 / 2) >= 0 (the bristle spring stores the rest).
  double dissipation_w = 0.0;
};

inline LugreOutput EvaluateLugre(const FrictionParams& f, double damping_fade_velocity_m_s,
                                 double bristle_m, double velocity_m_s) {
  const FrictionDirectionParams& d = FrictionForDirection(f, velocity_m_s);
  const double g = StribeckLevelN(d, velocity_m_s);
  const double sigma0 = f.bristle_stiffness_n_m;
  const double q = velocity_m_s / damping_fade_velocity_m_s;
  const double sigma1 = f.bristle_damping_n_s_m * std::exp(-q * q);
  LugreOutput out;
  out.bristle_rate_m_s = velocity_m_s - sigma0 * std::abs(velocity_m_s) * bristle_m / g;
  out.force_n = sigma0 * bristle_m + sigma1 * out.bristle_rate_m_s +
                d.viscous_n_s_m * velocity_m_s;
  out.dissipation_w = out.force_n * velocity_m_s - sigma0 * bristle_m * out.bristle_rate_m_s;
  return out;
}

// Multiplies the forces of both directions (F_s, F_c, B) by `scale` (realistic profile).
inline FrictionParams ScaleFriction(FrictionParams f, double scale) {
  for (FrictionDirectionParams* d : {&f.extend, &f.retract}) {
    d->static_n *= scale;
    d->coulomb_n *= scale;
    d->viscous_n_s_m *= scale;
  }
  return f;
}

}  // namespace hexa
