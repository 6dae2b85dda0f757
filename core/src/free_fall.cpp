#include "hexa/core/free_fall.hpp"

#include <cmath>
#include <limits>

namespace hexa {
namespace {

// Best A for a given tau and the residual sum of squares.
double ResidualForTau(const double* t, const double* x, std::size_t n, double tau, double* a) {
  double phi_x = 0.0, phi_phi = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double phi = t[i] + tau * std::exp(-t[i] / tau) - tau;  // eq 67 with A = 1
    phi_x += phi * x[i];
    phi_phi += phi * phi;
  }
  if (!(phi_phi > 0.0)) return std::numeric_limits<double>::infinity();
  const double best_a = phi_x / phi_phi;
  double ss = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = x[i] - best_a * (t[i] + tau * std::exp(-t[i] / tau) - tau);
    ss += r * r;
  }
  if (a != nullptr) *a = best_a;
  return ss;
}

}  // namespace

FreeFallFit FitFreeFall(const double* time_s, const double* position_m, std::size_t count,
                        double falling_mass_kg, double gravity_m_s2,
                        const FreeFallFitConfig& config) {
  FreeFallFit fit;
  if (count < 3 || time_s == nullptr || position_m == nullptr || !(falling_mass_kg > 0.0) ||
      !(gravity_m_s2 > 0.0) || config.scan_points < 3) {
    return fit;
  }
  // Coarse log-spaced scan of tau, then golden-section refinement in log tau.
  const double lo = std::log(config.min_time_constant_s);
  const double hi = std::log(config.max_time_constant_s);
  int best = 0;
  double best_ss = std::numeric_limits<double>::infinity();
  for (int k = 0; k < config.scan_points; ++k) {
    const double tau = std::exp(lo + (hi - lo) * k / (config.scan_points - 1));
    const double ss = ResidualForTau(time_s, position_m, count, tau, nullptr);
    if (ss < best_ss) {
      best_ss = ss;
      best = k;
    }
  }
  const double step = (hi - lo) / (config.scan_points - 1);
  double a = lo + step * std::max(best - 1, 0);
  double b = lo + step * std::min(best + 1, config.scan_points - 1);
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - ratio * (b - a), d = a + ratio * (b - a);
  double fc = ResidualForTau(time_s, position_m, count, std::exp(c), nullptr);
  double fd = ResidualForTau(time_s, position_m, count, std::exp(d), nullptr);
  for (int it = 0; it < config.refine_iterations && (b - a) > 1e-14; ++it) {
    if (fc < fd) {
      b = d; d = c; fd = fc;
      c = b - ratio * (b - a);
      fc = ResidualForTau(time_s, position_m, count, std::exp(c), nullptr);
    } else {
      a = c; c = d; fc = fd;
      d = a + ratio * (b - a);
      fd = ResidualForTau(time_s, position_m, count, std::exp(d), nullptr);
    }
  }
  const double tau = std::exp(0.5 * (a + b));
  double amp = 0.0;
  const double ss = ResidualForTau(time_s, position_m, count, tau, &amp);
  const double weight_n = falling_mass_kg * gravity_m_s2;
  fit.terminal_velocity_m_s = amp;
  fit.time_constant_s = tau;
  fit.coulomb_n = weight_n * (1.0 - amp / (gravity_m_s2 * tau));  // eq 72 (eq 11)
  fit.viscous_n_s_m = (weight_n - fit.coulomb_n) / amp;            // eq 72 (eq 12)
  fit.rms_residual_m = std::sqrt(ss / static_cast<double>(count));
  fit.ok = std::isfinite(fit.coulomb_n) && std::isfinite(fit.viscous_n_s_m) && amp > 0.0;
  return fit;
}

}  // namespace hexa
