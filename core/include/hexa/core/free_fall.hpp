// Free-fall identification of Coulomb friction and viscous coefficient (paper Sec. 3.1,
// eq 9-12, Appendix B eq 66-72): the cylinder hangs rod down with both chambers vented and
// the load falls from rest; x(t) = A (t + tau exp(-t/tau) - tau) (eq 67) is fitted by least
// squares, then F_c = W (1 - A / (g tau)) and B = (W - F_c) / A (eq 72 = eq 11, 12).
#pragma once

#include <cstddef>

namespace hexa {

struct FreeFallFitConfig {
  double min_time_constant_s = 1e-3;  // search range of tau (log-spaced scan + golden section)
  double max_time_constant_s = 1e3;
  int scan_points = 400;
  int refine_iterations = 200;
};

struct FreeFallFit {
  bool ok = false;
  double terminal_velocity_m_s = 0.0;  // A of eq 67
  double time_constant_s = 0.0;        // tau of eq 67
  double coulomb_n = 0.0;              // F_fric, eq 72 / eq 11
  double viscous_n_s_m = 0.0;          // b, eq 72 / eq 12
  double rms_residual_m = 0.0;
};

// Samples (t_i, x_i) with x(0) = 0, v(0) = 0, x positive downwards; falling mass
// M = load + piston (W = M g). Variable projection: for a given tau the best A is linear
// least squares; tau minimises the residual. No allocation.
FreeFallFit FitFreeFall(const double* time_s, const double* position_m, std::size_t count,
                        double falling_mass_kg, double gravity_m_s2,
                        const FreeFallFitConfig& config = {});

}  // namespace hexa
