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

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Normalised Gaussian smoothing (sigma in samples, +-3 sigma), NaN-propagating; copies when
// sigma is 0.
std::vector<double> GaussianSmooth(const std::vector<double>& x, double sigma) {
  if (!(sigma > 0.0)) return x;
  const int half = static_cast<int>(std::ceil(3.0 * sigma));
  std::vector<double> w(static_cast<std::size_t>(2 * half + 1));
  double sum = 0.0;
  for (int j = -half; j <= half; ++j) sum += w[static_cast<std::size_t>(j + half)] = std::exp(-0.5 * j * j / (sigma * sigma));
  for (double& v : w) v /= sum;
  std::vector<double> out(x.size(), kNaN);
  const auto n = static_cast<long>(x.size());
  for (long k = half; k + half < n; ++k) {
    double s = 0.0;
    for (int j = -half; j <= half; ++j) s += w[static_cast<std::size_t>(j + half)] * x[static_cast<std::size_t>(k + j)];
    out[static_cast<std::size_t>(k)] = s;
  }
  return out;
}

double Spread(const std::vector<double>& v, double q) {
  const double s = Quantile(v, 1.0 - q) - Quantile(v, q);
  return s > 0.0 && std::isfinite(s) ? s : 1.0;
}

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

// ---- Building the datasets --------------------------------------------------------------------

DatasetReport BuildStrokeDatasets(const NominalLegModel& model, const LegSeries& leg,
                                  const std::vector<double>& velocity, const std::vector<double>& accel,
                                  const LoadSeries& load, const IdentificationConfig& config,
                                  std::size_t min_samples, std::array<StrokeDataset, 2>& out) {
  config.Validate();
  DatasetReport report;
  const std::size_t n = leg.size();
  for (const std::vector<double>* v :
       {&leg.cap_pressure_pa, &leg.rod_pressure_pa, &leg.supply_pressure_pa, &leg.valve_v, &velocity,
        &accel, &load.force_fixed_n, &load.force_scaled_n, &load.mass_fixed_kg, &load.mass_scaled_kg}) {
    if (v->size() != n) {
      report.error = "internal: series of different lengths";
      return report;
    }
  }
  if (leg.excited.size() != n) {
    report.error = "internal: excitation flags of a different length";
    return report;
  }
  for (std::uint8_t e : leg.excited) report.excited_ticks += e;
  if (report.excited_ticks == 0) {
    report.error = "no excitation: the leg's valve was never driven open loop (no valve command "
                   "with controller CONTROLLER_NONE)";
    return report;
  }

  const OfflineGaussianDifferentiator diff(config.differentiator, config.period_s);
  const OfflineGaussianDifferentiator narrow(config.regressor_differentiator, config.period_s);
  const AirParams& air = model.air;
  const CylinderParams& cyl = model.cylinder;
  const ValveParams& valve = model.valve;
  const OrificeFlowModel orifice(air, valve.discharge_coefficient, kDefaultLaminarPressureRatio);
  const double rt = air.gas_constant_j_kg_k * air.temperature_k;
  std::vector<double> x_m(n), v_narrow, v_smooth;
  for (std::size_t k = 0; k < n; ++k) x_m[k] = leg.length_m[k] - cyl.mid_stroke_length_m;
  narrow.Derivative(x_m, v_narrow);  // the Stribeck term's argument, sample by sample
  diff.Smooth(velocity, v_smooth);   // S[D[x]] = S[S[x']]: the viscous term, smoothed as x''

  // Spool position at each sample: eq 42 behind the rig file's first-order lag, integrated
  // exactly over each tick from the command of the tick before (the plant's spool state).
  std::vector<double> spool(n, 0.0);
  const double decay = valve.spool_time_constant_s > 0.0
                           ? std::exp(-config.period_s / valve.spool_time_constant_s)
                           : 0.0;
  auto command = [&](std::size_t k) {
    return std::isfinite(leg.valve_v[k]) ? leg.valve_v[k] : valve.null_voltage_v;
  };
  if (n > 0) spool[0] = SpoolTargetM(valve, command(0));
  for (std::size_t k = 1; k < n; ++k) {
    const double target = SpoolTargetM(valve, command(k - 1));
    spool[k] = target + (spool[k - 1] - target) * decay;
  }

  // Regressors of eq 7 (per chamber, per coefficient) at every sample: the shared eq 7
  // function with one coefficient set to 1 and the others 0 (it is affine in each). The
  // volume terms, -P/V dV/dt = -(A P/V) x', are smoothed from the position differences
  // (SmoothTimesDerivative): no velocity estimate enters them.
  std::vector<double> in1(n), out1(n), in2(n), out2(n), g1(n), g2(n), pneumatic(n);
  const std::vector<double> p1s = GaussianSmooth(leg.cap_pressure_pa, config.pressure_smoothing_samples);
  const std::vector<double> p2s = GaussianSmooth(leg.rod_pressure_pa, config.pressure_smoothing_samples);
  const std::vector<double> pss = GaussianSmooth(leg.supply_pressure_pa, config.pressure_smoothing_samples);
  const PolytropicParams unit_in{1.0, 0.0, 0.0}, unit_out{0.0, 1.0, 0.0}, unit_vol{0.0, 0.0, 1.0};
  for (std::size_t k = 0; k < n; ++k) {
    const double x = x_m[k];
    const double p1 = p1s[k];
    const double p2 = p2s[k];
    const double area = OrificeAreaM2(valve, spool[k]);  // eq 6, 43
    const ChamberMassFlows m = ValveMassFlows(orifice, area, spool[k], pss[k],
                                              air.atmosphere_pressure_pa, p1, p2);  // eq 4, 5, Tables 4, 5
    const double v1 = Chamber1VolumeM3(cyl, x), v2 = Chamber2VolumeM3(cyl, x);  // eq 64
    in1[k] = ChamberPressureRatePaS(rt, unit_in, m.chamber1_kg_s, p1, v1, 0.0);
    out1[k] = ChamberPressureRatePaS(rt, unit_out, m.chamber1_kg_s, p1, v1, 0.0);
    in2[k] = ChamberPressureRatePaS(rt, unit_in, m.chamber2_kg_s, p2, v2, 0.0);
    out2[k] = ChamberPressureRatePaS(rt, unit_out, m.chamber2_kg_s, p2, v2, 0.0);
    // Volume term per unit of x' (dV1/dt = A1 x', dV2/dt = -A2 x').
    g1[k] = ChamberPressureRatePaS(rt, unit_vol, 0.0, p1, v1, cyl.cap_area_m2);
    g2[k] = ChamberPressureRatePaS(rt, unit_vol, 0.0, p2, v2, -cyl.annulus_area_m2);
    pneumatic[k] = leg.cap_pressure_pa[k] * cyl.cap_area_m2 - leg.rod_pressure_pa[k] * cyl.annulus_area_m2 -
                   air.atmosphere_pressure_pa * cyl.rod_area_m2;  // eq 1, 50 (linear: no bias)
  }
  std::vector<double> s_in1, s_out1, s_vol1, s_in2, s_out2, s_vol2, s_pneu, ss_pneu, d_p1, d_p2;
  diff.Smooth(in1, s_in1);
  diff.Smooth(out1, s_out1);
  diff.SmoothTimesDerivative(g1, x_m, s_vol1);
  diff.Smooth(in2, s_in2);
  diff.Smooth(out2, s_out2);
  diff.SmoothTimesDerivative(g2, x_m, s_vol2);
  // The acceleration is differentiated twice: its model side is smoothed twice.
  diff.Smooth(pneumatic, s_pneu);
  diff.Smooth(s_pneu, ss_pneu);
  diff.Derivative(leg.cap_pressure_pa, d_p1);
  diff.Derivative(leg.rod_pressure_pa, d_p2);
  // Noise compensation (IdentificationConfig::pressure_noise_sigma_pa): sensitivities of
  // the regressors to each chamber's pressure sample, then per sample the covariance of the
  // noise in D[P] with that in each regressor.
  const double noise_var = config.pressure_noise_sigma_pa * config.pressure_noise_sigma_pa;
  std::vector<double> d_in1, d_out1, d_g1, d_in2, d_out2, d_g2;
  if (noise_var > 0.0) {
    const double dp = 50.0;  // Pa, central differences of eq 4
    for (auto* v : {&d_in1, &d_out1, &d_g1, &d_in2, &d_out2, &d_g2}) v->assign(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
      const double x = x_m[k], p1 = p1s[k], p2 = p2s[k];
      const double area = OrificeAreaM2(valve, spool[k]);
      const double v1 = Chamber1VolumeM3(cyl, x), v2 = Chamber2VolumeM3(cyl, x);
      const auto flows = [&](double a1, double a2) {
        return ValveMassFlows(orifice, area, spool[k], pss[k], air.atmosphere_pressure_pa, a1, a2);
      };
      const ChamberMassFlows u1 = flows(p1 + dp, p2), l1 = flows(p1 - dp, p2);
      const ChamberMassFlows u2 = flows(p1, p2 + dp), l2 = flows(p1, p2 - dp);
      d_in1[k] = (ChamberPressureRatePaS(rt, unit_in, u1.chamber1_kg_s, p1, v1, 0.0) -
                  ChamberPressureRatePaS(rt, unit_in, l1.chamber1_kg_s, p1, v1, 0.0)) / (2.0 * dp);
      d_out1[k] = (ChamberPressureRatePaS(rt, unit_out, u1.chamber1_kg_s, p1, v1, 0.0) -
                   ChamberPressureRatePaS(rt, unit_out, l1.chamber1_kg_s, p1, v1, 0.0)) / (2.0 * dp);
      d_in2[k] = (ChamberPressureRatePaS(rt, unit_in, u2.chamber2_kg_s, p2, v2, 0.0) -
                  ChamberPressureRatePaS(rt, unit_in, l2.chamber2_kg_s, p2, v2, 0.0)) / (2.0 * dp);
      d_out2[k] = (ChamberPressureRatePaS(rt, unit_out, u2.chamber2_kg_s, p2, v2, 0.0) -
                   ChamberPressureRatePaS(rt, unit_out, l2.chamber2_kg_s, p2, v2, 0.0)) / (2.0 * dp);
      d_g1[k] = ChamberPressureRatePaS(rt, unit_vol, 0.0, 1.0, v1, cyl.cap_area_m2);  // g is linear in P
      d_g2[k] = ChamberPressureRatePaS(rt, unit_vol, 0.0, 1.0, v2, -cyl.annulus_area_m2);
    }
  }
  const std::vector<double>& coeff = diff.coefficients();      // D: sample m + h - k has coeff[k]
  const std::vector<double>& sw = diff.sample_weights();       // S: sample m - h - 1 + i has sw[i]
  const std::vector<double>& iw = diff.interval_weights();     // interval j = [m+h-j-1, m+h-j]
  const long hw = diff.half_window();
  auto c_of = [&](long r) { return std::abs(r) <= hw ? coeff[static_cast<std::size_t>(hw - r)] : 0.0; };
  auto noise_cov = [&](std::size_t k, const std::vector<double>& d_in, const std::vector<double>& d_out,
                       const std::vector<double>& d_g, double& cin, double& cout, double& cvol) {
    cin = cout = cvol = 0.0;
    if (noise_var <= 0.0) return;
    for (long r = -hw; r <= hw; ++r) {
      const std::size_t m = static_cast<std::size_t>(static_cast<long>(k) + r);
      const double w = c_of(r) * sw[static_cast<std::size_t>(r + hw + 1)];
      cin += w * d_in[m];
      cout += w * d_out[m];
    }
    for (std::size_t j = 0; j < iw.size(); ++j) {
      const std::size_t b = k + static_cast<std::size_t>(hw) - j, a = b - 1;
      const double omega = 0.5 * iw[j] / config.period_s * (x_m[b] - x_m[a]);
      cvol += omega * (c_of(static_cast<long>(b) - static_cast<long>(k)) * d_g[b] +
                       c_of(static_cast<long>(a) - static_cast<long>(k)) * d_g[a]);
    }
    cin *= noise_var;
    cout *= noise_var;
    cvol *= noise_var;
  };
  const std::vector<double> kernel = diff.DoubleSmoothingKernel();
  const std::size_t kernel_half = kernel.size() / 2;

  // A sample is used when every tick its double window reaches was excited, away from the
  // end stops, and moving in the sample's direction at |v| >= min_speed (prefix counts).
  const std::size_t reach = std::max(kernel_half, static_cast<std::size_t>(2 * diff.half_window())) +
                            static_cast<std::size_t>(config.direction_margin_samples);
  std::vector<std::uint32_t> up(n + 1, 0), down(n + 1, 0);
  const double stop_m = 0.5 * cyl.stroke_m - config.end_stop_margin_m;
  const auto flow_well_posed = [&](std::size_t k) {
    if (!(config.min_flow_pressure_difference_pa > 0.0) || spool[k] == 0.0) return true;
    const double pa = air.atmosphere_pressure_pa, ps = pss[k], p1 = p1s[k], p2 = p2s[k];
    const double d = spool[k] > 0.0 ? std::min(std::abs(ps - p1), std::abs(p2 - pa))   // Table 4
                                    : std::min(std::abs(ps - p2), std::abs(p1 - pa));  // Table 5
    return d >= config.min_flow_pressure_difference_pa;
  };
  std::vector<std::uint32_t> posed(n + 1, 0);
  for (std::size_t k = 0; k < n; ++k) {
    posed[k + 1] = posed[k] + (flow_well_posed(k) ? 1u : 0u);
    const bool ok = leg.excited[k] != 0 && std::isfinite(velocity[k]) && std::isfinite(v_narrow[k]) &&
                    std::abs(x_m[k]) <= stop_m;
    // Both the wide and the narrow derivative: the wide one alone hides a short stop.
    const double slow = std::min(velocity[k], v_narrow[k]), fast = std::max(velocity[k], v_narrow[k]);
    up[k + 1] = up[k] + (ok && slow >= config.min_speed_m_s ? 1u : 0u);
    down[k + 1] = down[k] + (ok && fast <= -config.min_speed_m_s ? 1u : 0u);
  }
  for (StrokeDataset& d : out) d = StrokeDataset{};
  out[0].stroke = Stroke::kExtend;
  out[1].stroke = Stroke::kRetract;
  std::vector<double> range_a, range_1, range_2;
  for (std::size_t k = reach; k + reach < n; ++k) {
    const std::size_t lo = k - reach, hi = k + reach + 1;
    const std::uint32_t width = static_cast<std::uint32_t>(hi - lo);
    int dir = -1;
    if (up[hi] - up[lo] == width) dir = 0;
    else if (down[hi] - down[lo] == width) dir = 1;
    if (dir < 0) continue;
    IdentSample q;
    q.tick = static_cast<std::uint32_t>(k);
    q.direction = dir == 0 ? 1.0 : -1.0;
    q.velocity_m_s = v_smooth[k];
    q.accel_m_s2 = accel[k];
    q.force_fixed_n = load.force_fixed_n[k] - ss_pneu[k];
    q.force_scaled_n = load.force_scaled_n[k];
    q.mass_fixed_kg = load.mass_fixed_kg[k];
    q.mass_scaled_kg = load.mass_scaled_kg[k];
    q.p1_rate_pa_s = d_p1[k];
    q.p1_in = s_in1[k];
    q.p1_out = s_out1[k];
    q.p1_vol = s_vol1[k];
    q.p2_rate_pa_s = d_p2[k];
    q.p2_in = s_in2[k];
    q.p2_out = s_out2[k];
    q.p2_vol = s_vol2[k];
    noise_cov(k, d_in1, d_out1, d_g1, q.p1_cov_in, q.p1_cov_out, q.p1_cov_vol);
    noise_cov(k, d_in2, d_out2, d_g2, q.p2_cov_in, q.p2_cov_out, q.p2_cov_vol);
    {
      const std::size_t lo_p = k - static_cast<std::size_t>(hw) - 1, hi_p = k + static_cast<std::size_t>(hw) + 2;
      q.pressure_ok = posed[hi_p] - posed[lo_p] == hi_p - lo_p;
    }
    const double values[] = {q.velocity_m_s, q.accel_m_s2, q.force_fixed_n, q.force_scaled_n,
                             q.mass_fixed_kg, q.mass_scaled_kg, q.p1_rate_pa_s, q.p1_in, q.p1_out,
                             q.p1_vol, q.p2_rate_pa_s, q.p2_in, q.p2_out, q.p2_vol};
    if (!std::all_of(std::begin(values), std::end(values), [](double v) { return std::isfinite(v); }) ||
        !(q.mass_fixed_kg + q.mass_scaled_kg > 0.0)) {
      continue;
    }
    out[static_cast<std::size_t>(dir)].samples.push_back(q);
    report.max_speed_m_s[static_cast<std::size_t>(dir)] =
        std::max(report.max_speed_m_s[static_cast<std::size_t>(dir)], std::abs(velocity[k]));
    range_a.push_back(q.accel_m_s2);
    range_1.push_back(q.p1_rate_pa_s);
    range_2.push_back(q.p2_rate_pa_s);
  }
  const double ra = Spread(range_a, config.range_quantile);
  const double r1 = Spread(range_1, config.range_quantile);
  const double r2 = Spread(range_2, config.range_quantile);
  for (StrokeDataset& d : out) {
    d.range_accel_m_s2 = ra;
    d.range_p1_rate_pa_s = r1;
    d.range_p2_rate_pa_s = r2;
    d.SetStribeckSource(0, v_narrow, kernel);
    d.Bind(1.0);
  }
  report.samples = {out[0].samples.size(), out[1].samples.size()};
  for (std::size_t dir = 0; dir < 2; ++dir) {
    if (report.samples[dir] < min_samples) {
      std::ostringstream m;
      m << "too few usable samples in the " << ToString(static_cast<Stroke>(dir)) << " stroke: "
        << report.samples[dir] << " (need " << min_samples << "; " << report.excited_ticks
        << " excited ticks, a sample needs " << 2 * reach + 1 << " consecutive excited ticks moving "
        << ToString(static_cast<Stroke>(dir)) << " at >= " << config.min_speed_m_s
        << " m/s, at least " << config.end_stop_margin_m
        << " m from the end stops): the recording is too short or the excitation too weak";
      report.error = m.str();
      return report;
    }
  }
  report.ok = true;
  return report;
}

double EstimateWhiteNoiseSigma(const std::vector<double>& x, const std::vector<std::uint8_t>& use) {
  std::vector<double> d;
  for (std::size_t k = 3; k < x.size(); ++k) {
    if (!use.empty() && !(use[k] && use[k - 3])) continue;
    const double v = x[k] - 3.0 * x[k - 1] + 3.0 * x[k - 2] - x[k - 3];
    if (std::isfinite(v)) d.push_back(std::abs(v));
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2] / (0.6745 * std::sqrt(20.0));
}

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
