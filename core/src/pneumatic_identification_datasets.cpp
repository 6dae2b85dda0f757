// Building the identification datasets from a recorded leg series, and the white-noise
// estimate (pneumatic_identification.hpp).
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

}  // namespace

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

}  // namespace hexa
