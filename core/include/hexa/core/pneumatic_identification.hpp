// Identification of the pneumatic model of one leg (paper Sec. 3.1, eq 3, 7, 8, 13, Table 8):
// from a recording of the leg driven open loop (potentiometer, chamber and supply pressures,
// valve voltage), the equation errors of eq 8 - acceleration, dP1/dt, dP2/dt - for the
// parameters of one stroke direction, theta = (v_s, B, F_s, F_c, gamma_o, gamma_i, gamma_k),
// and their normalised RMS (eq 13), minimised by the GA of Table 7 (genetic_algorithm.hpp)
// and by least squares (the Ceres solver, in tools/identify; this header gives residuals and
// analytic Jacobians). docs/identification.md derives every step.
//
//   measured (left of eq 8)                  model (right of eq 8)
//   x''  = D[D[x]]                           (f_req - F_p + F_f(v; theta)) / M_eff + x''
//   P1'  = D[P1]                             S[eq 7 chamber 1](gamma)
//   P2'  = D[P2]                             S[eq 7 chamber 2](gamma)
//
// D is the Gaussian differentiator of eq 40/41 (offline, centred), S its matching smoothing
// (offline_differentiator.hpp): D[y] = S[y'] exactly, so the pressure residuals vanish for
// noise-free data at the true gamma. The flows, volumes and pressure rates are the plant's
// and the controller's functions (pneumatics.hpp: eq 4, 5, 7, 42, 43, 64, 65), the spool
// lag is the rig file's first-order lag. f_req is the force the leg must exert for the
// measured motion (platform inverse dynamics, platform_inverse_dynamics.hpp), affine in the
// payload scale s: f_req = f_fixed + s f_scaled, M_eff = m_fixed + s m_scaled.
//
// Pure: no clock, no I/O, no threads; setup allocates, the objective does not.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/genetic_algorithm.hpp"
#include "hexa/core/offline_differentiator.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

enum class Stroke { kExtend = 0, kRetract = 1 };  // Table 8: up / down stroke
const char* ToString(Stroke stroke);              // "extend" / "retract"

// Table 8 parameters of one stroke direction, magnitudes, in the table's order.
struct StrokeParams {
  static constexpr int kCount = 7;
  double stribeck_velocity_m_s = 0.1;  // v_s
  double viscous_n_s_m = 0.0;          // B
  double static_n = 0.0;               // F_s
  double coulomb_n = 0.0;              // F_c
  double outflow = 1.0;                // gamma_o
  double inflow = 1.0;                 // gamma_i
  double volume = 1.0;                 // gamma_k

  using Vector = Eigen::Matrix<double, kCount, 1>;
  Vector ToVector() const;
  static StrokeParams FromVector(const Vector& v);
  static StrokeParams From(const FrictionDirectionParams& f, const PolytropicParams& g);
  FrictionDirectionParams Friction() const;
  PolytropicParams Polytropic() const;
  static const char* Name(int i);  // "v_s", "B", "F_s", "F_c", "gamma_o", "gamma_i", "gamma_k"
  static const char* Unit(int i);  // "m/s", "N s/m", "N", "N", "-", "-", "-"
};

// Eq 3 with sgn(v): the friction force (magnitude parameters, opposing v).
double StaticFrictionN(const StrokeParams& p, double velocity_m_s);

// ---- Data ---------------------------------------------------------------------------------

// One leg over a recording, one value per plant tick (uniform period).
struct LegSeries {
  std::vector<double> length_m;            // potentiometer
  std::vector<double> cap_pressure_pa;     // P1
  std::vector<double> rod_pressure_pa;     // P2
  std::vector<double> supply_pressure_pa;  // Ps
  std::vector<double> valve_v;             // command answering this tick (applied until the next)
  std::vector<std::uint8_t> excited;       // 1 where the valve was driven open loop
  std::size_t size() const { return length_m.size(); }
};

// The force the leg must exert along itself for the measured motion and the inertia it sees,
// per tick: f_req = force_fixed_n + s force_scaled_n, M_eff = mass_fixed_kg + s mass_scaled_kg
// with s the payload scale (1 = the rig file's platform). NaN where unknown.
struct LoadSeries {
  std::vector<double> force_fixed_n, force_scaled_n, mass_fixed_kg, mass_scaled_kg;
};

struct IdentificationConfig {
  OfflineDifferentiatorParams differentiator;  // eq 40/41, offline and centred
  // The velocity inside eq 7's volume terms, evaluated sample by sample before S smooths
  // them: a narrow eq 40 window, so that S[f(v)] matches S[f(x')] (the wide D[x] would be
  // smoothed twice there).
  OfflineDifferentiatorParams regressor_differentiator{7, 1.5};
  // Standard deviation (samples) of a Gaussian smoothing of the measured chamber and supply
  // pressures before they enter the flow and volume regressors (0 = none): eq 4 is steep
  // near equal pressures, and noise passed through it biases the regressors.
  double pressure_smoothing_samples = 0.0;
  // Standard deviation of the pressure sensors' noise (the rig file's sensors block; 0 = no
  // compensation). The same noisy samples enter D[P] and the eq 7 regressors, so their
  // errors correlate and bias the fit (errors in variables); that covariance, computed
  // from the kernels and the regressors' sensitivity to each pressure sample, is taken out
  // of the pressure channels' normal equations (docs/identification.md, "Model and objective").
  double pressure_noise_sigma_pa = 0.0;
  // The pressure channels of a sample whose window holds a tick where an open flow path's
  // pressure difference (supply to a filling chamber, an exhausting chamber to the
  // atmosphere) is below this are left out (its acceleration channel stays): eq 4 is
  // steepest there (its linear band spans 0.5 %), and the sensors' noise passed through it
  // makes the flow regressors noisy and biased (0 = keep all).
  double min_flow_pressure_difference_pa = 0.0;
  // Samples whose windows come closer than this to an end stop are left out (the end-stop
  // force is not part of eq 8).
  double end_stop_margin_m = 0.01;
  double period_s = 0.001;
  // Samples slower than this are left out: the direction (and with it the Table 8 set) is
  // ambiguous there, and the plant's LuGre friction departs from eq 3 while the bristles
  // deflect (docs/identification.md measures the effect).
  double min_speed_m_s = 0.02;
  // Eq 13's ranges: the spread between these quantiles of each measured derivative.
  double range_quantile = 0.005;
  // Every sample must have this many valid samples of the same direction on each side,
  // in addition to the differentiators' windows (0: the windows only).
  int direction_margin_samples = 0;
  void Validate() const;  // throws std::invalid_argument
};

// One sample of the equation-error problem. The acceleration channel, times M_eff:
//   e_a M_eff = force_fixed + s force_scaled + sgn F_c + sgn (F_s - F_c) S[S[E(v; v_s)]] + B v
// with E(v; v_s) = exp(-(v/v_s)^2) smoothed exactly as x'' is (StrokeDataset keeps the
// velocity series for it), so that eq 3 is matched term by term.
struct IdentSample {
  std::uint32_t tick = 0;
  double direction = 1.0;          // +1 extend, -1 retract (sgn of eq 3)
  double velocity_m_s = 0.0;       // S[S[x']] (= S[D[x]]): the viscous term's regressor
  double accel_m_s2 = 0.0;         // D[D[x]] (measured x'')
  double force_fixed_n = 0.0;      // f_fixed - S[S[F_p]]
  double force_scaled_n = 0.0;
  double mass_fixed_kg = 0.0;
  double mass_scaled_kg = 0.0;
  // Eq 7 per chamber: measured D[P], and the smoothed regressors of gamma_i, gamma_o, gamma_k
  // (model = gamma_i in + gamma_o out + gamma_k vol).
  double p1_rate_pa_s = 0.0, p1_in = 0.0, p1_out = 0.0, p1_vol = 0.0;
  double p2_rate_pa_s = 0.0, p2_in = 0.0, p2_out = 0.0, p2_vol = 0.0;
  // Expected product of the noise in D[P] and in each regressor (in, out, vol), per chamber.
  double p1_cov_in = 0.0, p1_cov_out = 0.0, p1_cov_vol = 0.0;
  double p2_cov_in = 0.0, p2_cov_out = 0.0, p2_cov_vol = 0.0;
  bool pressure_ok = true;  // the pressure channels count (min_flow_pressure_difference_pa)
};

// What the fits of one leg and direction work on.
class StrokeDataset {
 public:
  Stroke stroke = Stroke::kExtend;
  std::vector<IdentSample> samples;
  // Eq 13 normalisers (ranges of the measured x'', dP1/dt, dP2/dt over the leg's samples).
  double range_accel_m_s2 = 1.0;
  double range_p1_rate_pa_s = 1.0;
  double range_p2_rate_pa_s = 1.0;

  // The velocity series (ticks [first_tick, first_tick + size)) and the double-smoothing
  // kernel (S applied twice, centred: 2 half + 1 taps) for the Stribeck term.
  void SetStribeckSource(std::uint32_t first_tick, std::vector<double> velocity_m_s,
                         std::vector<double> kernel);

  // Fixes the payload scale s (precomputes e_a's offset and 1 / M_eff, and the pressure
  // channels' normal equations). Call before the objective / residuals.
  void Bind(double payload_scale);
  double payload_scale() const { return payload_scale_; }

  // S[S[E(v; v_s)]] at every sample, and its derivative wrt v_s (optional).
  void StribeckTerm(double stribeck_velocity_m_s, std::vector<double>& value,
                    std::vector<double>* d_value_d_vs) const;

  // Eq 13: Z = sqrt(1/n sum_k [(e_a/R_a)^2 + (e_1/R_1)^2 + (e_2/R_2)^2]). Exact.
  double Nrmse(const StrokeParams& p) const;
  // What the GA and least squares minimise: Z^2 with the pressure channels' noise
  // covariance taken out of the normal equations (equal to Z^2 without pressure noise).
  // FitObjective^2 and |Residuals|^2 differ by a constant only.
  double FitObjective(const StrokeParams& p) const;
  // For a search that evaluates Z many times (the GA): the Stribeck term tabulated over
  // `points` log-spaced v_s in [lo, hi] (PrepareSearch), linearly interpolated in log v_s;
  // thread-safe and allocation-free. v_s outside the table is clamped to it.
  void PrepareSearch(double stribeck_lo_m_s, double stribeck_hi_m_s, int points = 128);
  double NrmseForSearch(const StrokeParams& p) const;
  // Residuals r of FitObjective: n acceleration residuals (e_a / (R_a sqrt(n))) and 3 per
  // pressure channel (the Cholesky factor of its compensated normal equations times
  // (gamma - its minimiser)): |r|^2 = FitObjective^2 - constant. Optionally their Jacobian
  // ((n + 6) x 7, Table 8 order). Resizes r and J.
  void Residuals(const StrokeParams& p, Eigen::VectorXd& r, Eigen::MatrixXd* J) const;
  // Acceleration channel only, with the payload scale free (for its estimation): residuals
  // (n) and Jacobian (n x 5: s, v_s, B, F_s, F_c), each / (R_a sqrt(n)).
  void AccelResiduals(double payload_scale, const FrictionDirectionParams& f, double* r,
                      double* J_row_major) const;
  // n x sum of the squared double-smoothing kernel: independent noise samples.
  double EffectiveSamples() const;
  // Measured and model-predicted x'', dP1/dt, dP2/dt at every sample (plots).
  void Predict(const StrokeParams& p, std::vector<double>& accel_m_s2,
               std::vector<double>& p1_rate_pa_s, std::vector<double>& p2_rate_pa_s) const;

 private:
  double AccelSumSquares(const StrokeParams& p, const double* stribeck) const;
  double PressureSumSquares(const StrokeParams& p) const;

  double payload_scale_ = 1.0;
  std::vector<double> accel_offset_;  // (force_fixed + s force_scaled) / M_eff
  std::vector<double> inv_mass_;      // 1 / M_eff
  std::uint32_t first_tick_ = 0;
  std::vector<double> tick_velocity_;  // v per tick (narrow eq 40 derivative)
  std::vector<double> kernel_;         // S o S
  std::vector<double> grid_log_vs_;    // PrepareSearch table
  std::vector<double> grid_;           // [point][sample]
  // Pressure channels: |y - X gamma|^2 = yy - 2 gamma . Xy + gamma' XX gamma,
  // gamma = (gamma_i, gamma_o, gamma_k).
  std::array<Eigen::Matrix3d, 2> xx_{};
  std::array<Eigen::Vector3d, 2> xy_{};   // plain
  std::array<Eigen::Vector3d, 2> xyc_{};  // noise-compensated
  std::array<double, 2> yy_{};
  std::array<Eigen::Matrix3d, 2> chol_{};  // upper factor U of xx_ / R^2 (U^T U)
  std::array<Eigen::Vector3d, 2> gamma_star_{};  // minimiser of the compensated channel
};

// Why a leg's recording cannot be used (clear errors for the tool).
struct DatasetReport {
  bool ok = false;
  std::string error;             // what is missing, when !ok
  std::size_t excited_ticks = 0;
  std::array<std::size_t, 2> samples{};  // per Stroke
  std::array<double, 2> max_speed_m_s{};
};

// Builds both directions' datasets for one leg. `velocity_m_s` / `accel_m_s2` are D[x] and
// D[D[x]] of this leg's potentiometer (the load was computed from them). Requirements it
// checks (error names what is missing): equal lengths, excitation present, at least
// `min_samples` samples per direction.
DatasetReport BuildStrokeDatasets(const NominalLegModel& model, const LegSeries& leg,
                                  const std::vector<double>& velocity_m_s,
                                  const std::vector<double>& accel_m_s2, const LoadSeries& load,
                                  const IdentificationConfig& config, std::size_t min_samples,
                                  std::array<StrokeDataset, 2>& out);

// Standard deviation of white measurement noise on a sampled signal, from the third
// differences (variance 20 sigma^2 for white noise; a smooth signal adds ~h^3 times its
// third derivative): median(|d3|) / (0.6745 sqrt(20)), over the samples where `use` is
// non-zero (all if empty).
double EstimateWhiteNoiseSigma(const std::vector<double>& x, const std::vector<std::uint8_t>& use = {});

// ---- Search space of the GA (genes in [0, 1]) ------------------------------------------------

// Gene j maps linearly to [lower_j, upper_j] of the GA variable j, in the order
// (v_s, B, F_s - F_c, F_c, gamma_o, gamma_i, gamma_k): F_s is searched as F_c plus a
// non-negative excess so that every genome satisfies F_s >= F_c (the rig file's rule).
struct StrokeSearchSpace {
  StrokeParams::Vector lower, upper;
  static StrokeSearchSpace Default();  // docs/identification.md gives the ranges
  // The friction variables (v_s, B, F_s - F_c, F_c) in [nominal / factor, nominal x factor]
  // of the rig file's values, the gammas in [1, 2] as Default(): the GA's genes then resolve
  // the range the parameters can plausibly take, and Table 7's mutation step (sigma = 0.1 of
  // the gene range) shrinks with it (docs/identification.md, "The two fits").
  // factor > 1; a nominal value <= 0 keeps Default()'s range for that variable.
  static StrokeSearchSpace AroundNominal(const StrokeParams& nominal, double factor);
  // Genes 1-3 are the friction force magnitudes of eq 3 at three reference speeds instead of
  // B, F_s - F_c and F_c (each in [nominal / factor, nominal x factor] of the rig file's values'
  // force at that speed; v_s and the gammas as AroundNominal): the data fix the friction curve
  // over the recorded speeds much better than the three coefficients, which trade off against
  // each other (docs/measurements/identification.md, "Why the template GA stalls, and the gene
  // map that fixes it"). Decoding solves eq 3 at the three speeds for F_c, F_s - F_c and B (given v_s); they are
  // not projected onto >= 0 (a projection makes a flat plateau the GA stalls on).
  static StrokeSearchSpace ForceAtSpeeds(const StrokeParams& nominal, double factor,
                                         const std::array<double, 3>& speeds_m_s);
  bool force_at_speeds = false;
  std::array<double, 3> reference_speeds_m_s{};
  StrokeParams Decode(const Genome& genes) const;
  Genome Encode(const StrokeParams& p) const;  // clamped to [0, 1]
};

// ---- Curvature of the objective at an optimum -------------------------------------------------

// Gauss-Newton Hessian of Z^2 in relative parameter units (delta_i = d theta_i / theta_i):
// for each parameter, the relative increase of its channels' share of Z^2 (the acceleration
// channel for v_s, B, F_s, F_c; the pressure channels for the gammas) when it moves by 10 %
// alone, and when it moves by 10 % with the others re-fitted (profile; small when
// parameters trade off).
// A parameter whose profile increase is below `flat_threshold` is reported as not
// identifiable from the data (flat objective) rather than given a value. The default
// threshold (flat_threshold <= 0) is 1 / n_eff, n_eff = samples x sum of the squared
// double-smoothing kernel (the number of independent noise samples the residuals hold):
// below it a 10 % change hides in the objective's noise. The same numbers give the
// parameter's expected standard error from noise, 10 % x sqrt(1 / (n_eff x increase)).
struct CurvatureReport {
  StrokeParams::Vector hessian_diagonal_rel;   // d2 Z^2 / d delta_i^2
  StrokeParams::Vector increase_alone_10pct;   // Z^2(+10 %) / Z^2 - 1, others fixed
  StrokeParams::Vector increase_profile_10pct; // same, others re-fitted (quadratic model)
  StrokeParams::Vector standard_error_pct;     // expected 1 sigma from noise, %
  std::array<bool, StrokeParams::kCount> identifiable{};
  double objective = 0.0;                      // FitObjective at the point
  double effective_samples = 0.0;              // n_eff
  double flat_threshold = 0.0;                 // used
};
CurvatureReport AnalyseCurvature(const StrokeDataset& data, const StrokeParams& at,
                                 double flat_threshold = 0.0);

}  // namespace hexa
