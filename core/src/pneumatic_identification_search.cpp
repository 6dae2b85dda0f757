// The identification's search spaces (the GA's gene maps) and the curvature analysis of the
// objective at a fit (pneumatic_identification.hpp).
#include "hexa/core/pneumatic_identification.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hexa/core/pneumatics.hpp"

namespace hexa {

// ---- Search space ---------------------------------------------------------------------------

StrokeSearchSpace StrokeSearchSpace::Default() {
  StrokeSearchSpace s;
  //        v_s    B      F_s-F_c F_c    g_o  g_i  g_k
  s.lower << 0.02, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0;
  s.upper << 1.5, 150.0, 150.0, 250.0, 2.0, 2.0, 2.0;
  return s;
}

StrokeSearchSpace StrokeSearchSpace::AroundNominal(const StrokeParams& nominal, double factor) {
  if (!(factor > 1.0) || !std::isfinite(factor)) {
    throw std::invalid_argument("StrokeSearchSpace::AroundNominal: factor = " + std::to_string(factor) +
                                " must be finite and > 1");
  }
  StrokeSearchSpace s = Default();
  StrokeParams::Vector v = nominal.ToVector();
  v[2] -= v[3];  // the GA's variable: F_s - F_c
  for (int j = 0; j < 4; ++j) {
    if (!(v[j] > 0.0) || !std::isfinite(v[j])) continue;
    s.lower[j] = v[j] / factor;
    s.upper[j] = v[j] * factor;
  }
  return s;
}

namespace {
// Eq 3 at speed v_i for (F_c, F_s - F_c, B): F_c + (F_s - F_c) exp(-(v_i / v_s)^2) + B v_i.
Eigen::Matrix3d ForceAtSpeedsMatrix(double stribeck_m_s, const std::array<double, 3>& speeds) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) {
    const double u = speeds[static_cast<std::size_t>(i)] / stribeck_m_s;
    m(i, 0) = 1.0;
    m(i, 1) = std::exp(-u * u);
    m(i, 2) = speeds[static_cast<std::size_t>(i)];
  }
  return m;
}
}  // namespace

StrokeSearchSpace StrokeSearchSpace::ForceAtSpeeds(const StrokeParams& nominal, double factor,
                                                   const std::array<double, 3>& speeds) {
  StrokeSearchSpace s = AroundNominal(nominal, factor);
  if (!(speeds[0] > 0.0 && speeds[1] > speeds[0] && speeds[2] > speeds[1])) {
    throw std::invalid_argument("StrokeSearchSpace::ForceAtSpeeds: the reference speeds must be > 0 and increasing");
  }
  s.force_at_speeds = true;
  s.reference_speeds_m_s = speeds;
  const Eigen::Vector3d f =
      ForceAtSpeedsMatrix(nominal.stribeck_velocity_m_s, speeds) *
      Eigen::Vector3d(nominal.coulomb_n, nominal.static_n - nominal.coulomb_n, nominal.viscous_n_s_m);
  for (int i = 0; i < 3; ++i) {
    s.lower[1 + i] = f[i] / factor;
    s.upper[1 + i] = f[i] * factor;
  }
  return s;
}

StrokeParams StrokeSearchSpace::Decode(const Genome& genes) const {
  StrokeParams::Vector v;
  for (int j = 0; j < StrokeParams::kCount; ++j) {
    const double g = j < static_cast<int>(genes.size()) ? std::clamp(genes[static_cast<std::size_t>(j)], 0.0, 1.0) : 0.0;
    v[j] = lower[j] + g * (upper[j] - lower[j]);
  }
  if (force_at_speeds) {
    const Eigen::Vector3d c =
        ForceAtSpeedsMatrix(v[0], reference_speeds_m_s).partialPivLu().solve(Eigen::Vector3d(v[1], v[2], v[3]));
    // Not projected onto B >= 0, F_s >= F_c: a projection would make a flat plateau the GA
    // can stall on; the rig validator refuses such values if they are ever the result.
    v[1] = c[2];  // B
    v[3] = c[0];  // F_c
    v[2] = c[1];  // F_s - F_c
  }
  v[2] += v[3];  // F_s = F_c + excess
  return StrokeParams::FromVector(v);
}

Genome StrokeSearchSpace::Encode(const StrokeParams& p) const {
  StrokeParams::Vector v = p.ToVector();
  v[2] -= v[3];
  if (force_at_speeds) {
    const Eigen::Vector3d f = ForceAtSpeedsMatrix(v[0], reference_speeds_m_s) * Eigen::Vector3d(v[3], v[2], v[1]);
    v[1] = f[0];
    v[2] = f[1];
    v[3] = f[2];
  }
  Genome g(StrokeParams::kCount);
  for (int j = 0; j < StrokeParams::kCount; ++j) {
    g[static_cast<std::size_t>(j)] = std::clamp((v[j] - lower[j]) / (upper[j] - lower[j]), 0.0, 1.0);
  }
  return g;
}

// ---- Curvature ------------------------------------------------------------------------------

CurvatureReport AnalyseCurvature(const StrokeDataset& data, const StrokeParams& at, double flat) {
  CurvatureReport c;
  c.effective_samples = data.EffectiveSamples();
  c.flat_threshold = flat > 0.0 ? flat : 1.0 / std::max(c.effective_samples, 1.0);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  data.Residuals(at, r, &J);
  const double fit = data.FitObjective(at);
  c.objective = fit;
  // The friction parameters act on the acceleration channel only, the polytropic
  // coefficients on the pressure channels only: each is judged against its own channels'
  // share of Z^2 (|r|^2 of the acceleration rows is exactly that share).
  const auto n = static_cast<Eigen::Index>(data.samples.size());
  const double z2_accel = r.head(n).squaredNorm();
  const double z2_pressure = std::max(fit * fit - z2_accel, 0.0);
  const StrokeParams::Vector theta = at.ToVector();
  // Relative units: d r / d delta_i = theta_i d r / d theta_i.
  for (int i = 0; i < StrokeParams::kCount; ++i) J.col(i) *= theta[i];
  const Eigen::Matrix<double, 7, 7> H = 2.0 * J.transpose() * J;  // Gauss-Newton Hessian of Z^2
  // Profile curvature of parameter i: 1 / (H^-1)_ii (the others re-fitted). A pseudo-inverse
  // through the eigen-decomposition so that an exactly flat direction gives 0, not garbage.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 7, 7>> eig(H);
  const auto& values = eig.eigenvalues();
  const double top = values.cwiseAbs().maxCoeff();
  Eigen::Matrix<double, 7, 7> inverse = Eigen::Matrix<double, 7, 7>::Zero();
  for (int k = 0; k < 7; ++k) {
    if (values[k] > 1e-14 * top) {
      inverse += eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose() / values[k];
    }
  }
  const double step = 0.1;  // 10 %
  for (int i = 0; i < StrokeParams::kCount; ++i) {
    const double z2 = i < 4 ? z2_accel : z2_pressure;
    c.hessian_diagonal_rel[i] = H(i, i);
    c.increase_alone_10pct[i] = z2 > 0.0 ? 0.5 * H(i, i) * step * step / z2 : 0.0;
    const double profile = inverse(i, i) > 0.0 ? 1.0 / inverse(i, i) : 0.0;
    c.increase_profile_10pct[i] = z2 > 0.0 ? 0.5 * profile * step * step / z2 : 0.0;
    c.identifiable[static_cast<std::size_t>(i)] = c.increase_profile_10pct[i] >= c.flat_threshold;
    c.standard_error_pct[i] =
        c.increase_profile_10pct[i] > 0.0
            ? 10.0 * std::sqrt(1.0 / (std::max(c.effective_samples, 1.0) * c.increase_profile_10pct[i]))
            : std::numeric_limits<double>::infinity();
  }
  return c;
}

}  // namespace hexa
