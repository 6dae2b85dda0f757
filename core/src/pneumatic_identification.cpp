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
namespace {

// Eq 3 and its derivatives wrt (v_s, B, F_s, F_c).
struct FrictionTerms {
  double force = 0.0;
  double d_vs = 0.0, d_b = 0.0, d_fs = 0.0, d_fc = 0.0;
};
FrictionTerms Friction(const FrictionDirectionParams& f, double v) {
  FrictionTerms t;
  const double sgn = v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
  const double q = v / f.stribeck_velocity_m_s;
  const double e = std::exp(-q * q);
  t.force = sgn * (f.coulomb_n + (f.static_n - f.coulomb_n) * e) + f.viscous_n_s_m * v;
  t.d_vs = sgn * (f.static_n - f.coulomb_n) * e * 2.0 * q * q / f.stribeck_velocity_m_s;
  t.d_b = v;
  t.d_fs = sgn * e;
  t.d_fc = sgn * (1.0 - e);
  return t;
}

}  // namespace

const char* ToString(Stroke stroke) { return stroke == Stroke::kExtend ? "extend" : "retract"; }

StrokeParams::Vector StrokeParams::ToVector() const {
  Vector v;
  v << stribeck_velocity_m_s, viscous_n_s_m, static_n, coulomb_n, outflow, inflow, volume;
  return v;
}

StrokeParams StrokeParams::FromVector(const Vector& v) {
  StrokeParams p;
  p.stribeck_velocity_m_s = v[0];
  p.viscous_n_s_m = v[1];
  p.static_n = v[2];
  p.coulomb_n = v[3];
  p.outflow = v[4];
  p.inflow = v[5];
  p.volume = v[6];
  return p;
}

StrokeParams StrokeParams::From(const FrictionDirectionParams& f, const PolytropicParams& g) {
  StrokeParams p;
  p.stribeck_velocity_m_s = f.stribeck_velocity_m_s;
  p.viscous_n_s_m = f.viscous_n_s_m;
  p.static_n = f.static_n;
  p.coulomb_n = f.coulomb_n;
  p.outflow = g.outflow;
  p.inflow = g.inflow;
  p.volume = g.volume;
  return p;
}

FrictionDirectionParams StrokeParams::Friction() const {
  return FrictionDirectionParams{stribeck_velocity_m_s, viscous_n_s_m, static_n, coulomb_n};
}

PolytropicParams StrokeParams::Polytropic() const { return PolytropicParams{inflow, outflow, volume}; }

const char* StrokeParams::Name(int i) {
  static constexpr const char* kNames[kCount] = {"v_s", "B", "F_s", "F_c", "gamma_o", "gamma_i", "gamma_k"};
  return i >= 0 && i < kCount ? kNames[i] : "?";
}

const char* StrokeParams::Unit(int i) {
  static constexpr const char* kUnits[kCount] = {"m/s", "N s/m", "N", "N", "-", "-", "-"};
  return i >= 0 && i < kCount ? kUnits[i] : "?";
}

double StaticFrictionN(const StrokeParams& p, double v) { return Friction(p.Friction(), v).force; }

void IdentificationConfig::Validate() const {
  differentiator.Validate();
  regressor_differentiator.Validate();
  auto fail = [](const std::string& m) { throw std::invalid_argument("identification: " + m); };
  if (!(period_s > 0.0) || !std::isfinite(period_s)) fail("period_s must be finite and > 0");
  if (!(min_speed_m_s >= 0.0) || !std::isfinite(min_speed_m_s)) fail("min_speed_m_s must be >= 0");
  if (!(end_stop_margin_m >= 0.0) || !std::isfinite(end_stop_margin_m)) fail("end_stop_margin_m must be >= 0");
  if (!(pressure_smoothing_samples >= 0.0 && pressure_smoothing_samples <= 50.0)) {
    fail("pressure_smoothing_samples must be in [0, 50]");
  }
  if (!(pressure_noise_sigma_pa >= 0.0) || !std::isfinite(pressure_noise_sigma_pa)) {
    fail("pressure_noise_sigma_pa must be >= 0");
  }
  if (pressure_noise_sigma_pa > 0.0 && pressure_smoothing_samples > 0.0) {
    fail("the pressure-noise compensation assumes unsmoothed pressures (pressure_smoothing_samples 0)");
  }
  if (!(range_quantile >= 0.0 && range_quantile < 0.5)) fail("range_quantile must be in [0, 0.5)");
  if (direction_margin_samples < 0) fail("direction_margin_samples must be >= 0");
}

// ---- Dataset --------------------------------------------------------------------------------

void StrokeDataset::SetStribeckSource(std::uint32_t first_tick, std::vector<double> velocity,
                                      std::vector<double> kernel) {
  first_tick_ = first_tick;
  tick_velocity_ = std::move(velocity);
  kernel_ = std::move(kernel);
  grid_.clear();
  grid_log_vs_.clear();
}

double StrokeDataset::EffectiveSamples() const {
  double sum_sq = 0.0;
  for (double k : kernel_) sum_sq += k * k;
  return static_cast<double>(samples.size()) * (kernel_.empty() ? 1.0 : sum_sq);
}

void StrokeDataset::Bind(double s) {
  payload_scale_ = s;
  const std::size_t n = samples.size();
  accel_offset_.resize(n);
  inv_mass_.resize(n);
  for (auto& m : xx_) m.setZero();
  for (auto& v : xy_) v.setZero();
  for (auto& v : xyc_) v.setZero();
  yy_.fill(0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const IdentSample& q = samples[k];
    const double inv_m = 1.0 / (q.mass_fixed_kg + s * q.mass_scaled_kg);
    inv_mass_[k] = inv_m;
    accel_offset_[k] = (q.force_fixed_n + s * q.force_scaled_n) * inv_m;
    if (!q.pressure_ok) continue;
    const Eigen::Vector3d x1(q.p1_in, q.p1_out, q.p1_vol);
    const Eigen::Vector3d x2(q.p2_in, q.p2_out, q.p2_vol);
    xx_[0] += x1 * x1.transpose();
    xy_[0] += q.p1_rate_pa_s * x1;
    yy_[0] += q.p1_rate_pa_s * q.p1_rate_pa_s;
    xx_[1] += x2 * x2.transpose();
    xy_[1] += q.p2_rate_pa_s * x2;
    yy_[1] += q.p2_rate_pa_s * q.p2_rate_pa_s;
    xyc_[0] += q.p1_rate_pa_s * x1 - Eigen::Vector3d(q.p1_cov_in, q.p1_cov_out, q.p1_cov_vol);
    xyc_[1] += q.p2_rate_pa_s * x2 - Eigen::Vector3d(q.p2_cov_in, q.p2_cov_out, q.p2_cov_vol);
  }
  const double range[2] = {range_p1_rate_pa_s, range_p2_rate_pa_s};
  for (int c = 0; c < 2; ++c) {
    const Eigen::Matrix3d a = xx_[static_cast<std::size_t>(c)] / (range[c] * range[c]);
    const Eigen::LLT<Eigen::Matrix3d> llt(a);
    chol_[static_cast<std::size_t>(c)] = llt.matrixU();
    gamma_star_[static_cast<std::size_t>(c)] = xx_[static_cast<std::size_t>(c)].ldlt().solve(xyc_[static_cast<std::size_t>(c)]);
  }
}

void StrokeDataset::StribeckTerm(double vs, std::vector<double>& value, std::vector<double>* d_vs) const {
  const std::size_t n = samples.size();
  value.assign(n, 0.0);
  if (d_vs != nullptr) d_vs->assign(n, 0.0);
  if (n == 0 || kernel_.empty()) return;
  const std::size_t half = kernel_.size() / 2;
  // E and dE/dv_s on the ticks the samples reach (once per tick, then the kernel).
  const std::size_t lo = samples.front().tick - first_tick_ - half;
  const std::size_t hi = samples.back().tick - first_tick_ + half + 1;
  std::vector<double> e(hi - lo), de(d_vs != nullptr ? hi - lo : 0);
  const double inv = 1.0 / vs;
  for (std::size_t t = lo; t < hi; ++t) {
    const double q = tick_velocity_[t] * inv;
    const double ex = std::exp(-q * q);
    e[t - lo] = ex;
    if (d_vs != nullptr) de[t - lo] = ex * 2.0 * q * q * inv;  // d/dv_s exp(-(v/v_s)^2)
  }
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t first = samples[k].tick - first_tick_ - half - lo;
    double sum = 0.0, dsum = 0.0;
    for (std::size_t j = 0; j < kernel_.size(); ++j) {
      sum += kernel_[j] * e[first + j];
      if (d_vs != nullptr) dsum += kernel_[j] * de[first + j];
    }
    value[k] = sum;
    if (d_vs != nullptr) (*d_vs)[k] = dsum;
  }
}

double StrokeDataset::AccelSumSquares(const StrokeParams& p, const double* stribeck) const {
  const double excess = p.static_n - p.coulomb_n;
  double ss = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const IdentSample& q = samples[k];
    const double f = q.direction * (p.coulomb_n + excess * stribeck[k]) + p.viscous_n_s_m * q.velocity_m_s;
    const double e = accel_offset_[k] + inv_mass_[k] * f;
    ss += e * e;
  }
  return ss;
}

double StrokeDataset::PressureSumSquares(const StrokeParams& p) const {
  const Eigen::Vector3d g(p.inflow, p.outflow, p.volume);
  const double ss_1 = std::max(0.0, yy_[0] - 2.0 * g.dot(xy_[0]) + g.dot(xx_[0] * g));
  const double ss_2 = std::max(0.0, yy_[1] - 2.0 * g.dot(xy_[1]) + g.dot(xx_[1] * g));
  return ss_1 / (range_p1_rate_pa_s * range_p1_rate_pa_s) + ss_2 / (range_p2_rate_pa_s * range_p2_rate_pa_s);
}

double StrokeDataset::FitObjective(const StrokeParams& p) const {
  const std::size_t n = samples.size();
  if (n == 0 || accel_offset_.size() != n || !(p.stribeck_velocity_m_s > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  std::vector<double> stribeck;
  StribeckTerm(p.stribeck_velocity_m_s, stribeck, nullptr);
  const Eigen::Vector3d g(p.inflow, p.outflow, p.volume);
  double pressure = 0.0;
  const double range[2] = {range_p1_rate_pa_s, range_p2_rate_pa_s};
  for (std::size_t c = 0; c < 2; ++c) {
    pressure += std::max(0.0, yy_[c] - 2.0 * g.dot(xyc_[c]) + g.dot(xx_[c] * g)) / (range[c] * range[c]);
  }
  const double z2 = AccelSumSquares(p, stribeck.data()) / (range_accel_m_s2 * range_accel_m_s2) + pressure;
  return std::sqrt(z2 / static_cast<double>(n));
}

double StrokeDataset::Nrmse(const StrokeParams& p) const {
  const std::size_t n = samples.size();
  if (n == 0 || accel_offset_.size() != n || !(p.stribeck_velocity_m_s > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  std::vector<double> stribeck;
  StribeckTerm(p.stribeck_velocity_m_s, stribeck, nullptr);
  const double z2 = AccelSumSquares(p, stribeck.data()) / (range_accel_m_s2 * range_accel_m_s2) +
                    PressureSumSquares(p);
  return std::sqrt(z2 / static_cast<double>(n));  // eq 13
}

void StrokeDataset::PrepareSearch(double lo, double hi, int points) {
  const std::size_t n = samples.size();
  grid_log_vs_.resize(static_cast<std::size_t>(points));
  grid_.assign(static_cast<std::size_t>(points) * n, 0.0);
  std::vector<double> v;
  for (int g = 0; g < points; ++g) {
    const double log_vs = std::log(lo) + (std::log(hi) - std::log(lo)) * g / (points - 1);
    grid_log_vs_[static_cast<std::size_t>(g)] = log_vs;
    StribeckTerm(std::exp(log_vs), v, nullptr);
    std::copy(v.begin(), v.end(), grid_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(g) * n));
  }
}

double StrokeDataset::NrmseForSearch(const StrokeParams& p) const {
  const std::size_t n = samples.size();
  if (n == 0 || grid_log_vs_.size() < 2 || accel_offset_.size() != n || !(p.stribeck_velocity_m_s > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  const std::size_t m = grid_log_vs_.size();
  const double step = grid_log_vs_[1] - grid_log_vs_[0];
  const double u = std::clamp((std::log(p.stribeck_velocity_m_s) - grid_log_vs_[0]) / step, 0.0,
                              static_cast<double>(m - 1));
  const std::size_t g0 = std::min(static_cast<std::size_t>(u), m - 2);
  const double w = u - static_cast<double>(g0);
  const double* a = grid_.data() + g0 * n;
  const double* b = a + n;
  const double excess = p.static_n - p.coulomb_n;
  double ss = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const IdentSample& q = samples[k];
    const double stribeck = a[k] + w * (b[k] - a[k]);
    const double f = q.direction * (p.coulomb_n + excess * stribeck) + p.viscous_n_s_m * q.velocity_m_s;
    const double e = accel_offset_[k] + inv_mass_[k] * f;
    ss += e * e;
  }
  const Eigen::Vector3d g(p.inflow, p.outflow, p.volume);
  double pressure = 0.0;
  const double range[2] = {range_p1_rate_pa_s, range_p2_rate_pa_s};
  for (std::size_t c = 0; c < 2; ++c) {
    pressure += std::max(0.0, yy_[c] - 2.0 * g.dot(xyc_[c]) + g.dot(xx_[c] * g)) / (range[c] * range[c]);
  }
  const double z2 = ss / (range_accel_m_s2 * range_accel_m_s2) + pressure;
  return std::sqrt(z2 / static_cast<double>(n));  // FitObjective, with the table
}

void StrokeDataset::Residuals(const StrokeParams& p, Eigen::VectorXd& r, Eigen::MatrixXd* J) const {
  const std::size_t n = samples.size();
  r.resize(static_cast<Eigen::Index>(n + 6));
  if (J != nullptr) J->setZero(static_cast<Eigen::Index>(n + 6), StrokeParams::kCount);
  const double root_n = std::sqrt(static_cast<double>(std::max<std::size_t>(n, 1)));
  const double wa = 1.0 / (range_accel_m_s2 * root_n);
  std::vector<double> stribeck, d_stribeck;
  StribeckTerm(p.stribeck_velocity_m_s, stribeck, J != nullptr ? &d_stribeck : nullptr);
  const double excess = p.static_n - p.coulomb_n;
  for (std::size_t k = 0; k < n; ++k) {
    const IdentSample& q = samples[k];
    const auto row = static_cast<Eigen::Index>(k);
    const double f = q.direction * (p.coulomb_n + excess * stribeck[k]) + p.viscous_n_s_m * q.velocity_m_s;
    r[row] = wa * (accel_offset_[k] + inv_mass_[k] * f);
    if (J == nullptr) continue;
    const double g = wa * inv_mass_[k];
    (*J)(row, 0) = g * q.direction * excess * d_stribeck[k];  // v_s
    (*J)(row, 1) = g * q.velocity_m_s;                        // B
    (*J)(row, 2) = g * q.direction * stribeck[k];             // F_s
    (*J)(row, 3) = g * q.direction * (1.0 - stribeck[k]);     // F_c
  }
  // Pressure channels: U (gamma - gamma*) / sqrt(n), gamma = (gamma_i, gamma_o, gamma_k);
  // Table 8 order of the columns: gamma_o (4), gamma_i (5), gamma_k (6).
  const Eigen::Vector3d g(p.inflow, p.outflow, p.volume);
  for (std::size_t c = 0; c < 2; ++c) {
    const Eigen::Vector3d rc = chol_[c] * (g - gamma_star_[c]) / root_n;
    for (int i = 0; i < 3; ++i) {
      const auto row = static_cast<Eigen::Index>(n + 3 * c) + i;
      r[row] = rc[i];
      if (J == nullptr) continue;
      (*J)(row, 5) = chol_[c](i, 0) / root_n;
      (*J)(row, 4) = chol_[c](i, 1) / root_n;
      (*J)(row, 6) = chol_[c](i, 2) / root_n;
    }
  }
}

void StrokeDataset::AccelResiduals(double s, const FrictionDirectionParams& f, double* r, double* J) const {
  const std::size_t n = samples.size();
  const double wa = 1.0 / (range_accel_m_s2 * std::sqrt(static_cast<double>(std::max<std::size_t>(n, 1))));
  std::vector<double> stribeck, d_stribeck;
  StribeckTerm(f.stribeck_velocity_m_s, stribeck, J != nullptr ? &d_stribeck : nullptr);
  const double excess = f.static_n - f.coulomb_n;
  for (std::size_t k = 0; k < n; ++k) {
    const IdentSample& q = samples[k];
    const double friction = q.direction * (f.coulomb_n + excess * stribeck[k]) + f.viscous_n_s_m * q.velocity_m_s;
    const double mass = q.mass_fixed_kg + s * q.mass_scaled_kg;
    const double e = (q.force_fixed_n + s * q.force_scaled_n + friction) / mass;
    r[k] = wa * e;
    if (J == nullptr) continue;
    double* row = J + 5 * k;
    row[0] = wa * (q.force_scaled_n - e * q.mass_scaled_kg) / mass;
    row[1] = wa * q.direction * excess * d_stribeck[k] / mass;
    row[2] = wa * q.velocity_m_s / mass;
    row[3] = wa * q.direction * stribeck[k] / mass;
    row[4] = wa * q.direction * (1.0 - stribeck[k]) / mass;
  }
}

void StrokeDataset::Predict(const StrokeParams& p, std::vector<double>& accel, std::vector<double>& p1_rate,
                            std::vector<double>& p2_rate) const {
  const std::size_t n = samples.size();
  std::vector<double> stribeck;
  StribeckTerm(p.stribeck_velocity_m_s, stribeck, nullptr);
  accel.resize(n);
  p1_rate.resize(n);
  p2_rate.resize(n);
  const double excess = p.static_n - p.coulomb_n;
  for (std::size_t k = 0; k < n; ++k) {
    const IdentSample& q = samples[k];
    const double f = q.direction * (p.coulomb_n + excess * stribeck[k]) + p.viscous_n_s_m * q.velocity_m_s;
    accel[k] = q.accel_m_s2 - (accel_offset_[k] + inv_mass_[k] * f);  // what the model implies
    p1_rate[k] = p.inflow * q.p1_in + p.outflow * q.p1_out + p.volume * q.p1_vol;
    p2_rate[k] = p.inflow * q.p2_in + p.outflow * q.p2_out + p.volume * q.p2_vol;
  }
}

}  // namespace hexa
