// Value rules of the parameter structs (see param_checks.hpp, docs/config.md).
#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace hexa {

std::string FormatParam(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // The fewest %g digits that read back to the same double: "0.00031416", "1e-05".
  char buffer[64];
  // Start at the number of integer digits so that 10 prints as "10", not "1e+01".
  const double magnitude = std::abs(value);
  const int integer_digits =
      magnitude >= 1.0 && magnitude < 1e17 ? static_cast<int>(std::log10(magnitude)) + 1 : 1;
  for (int precision = integer_digits; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

std::string FormatDerived(double value) {
  if (!std::isfinite(value)) return FormatParam(value);
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

void ParamChecker::Fail(const std::string& field, const std::string& message,
                        const std::string& value, const std::string& limit) {
  out_.push_back(ParamIssue{field, message, value, limit});
}

bool ParamChecker::Finite(const std::string& field, double v) {
  if (std::isfinite(v)) return true;
  Fail(field, "value must be a finite number", FormatParam(v), "finite");
  return false;
}

void ParamChecker::Positive(const std::string& field, double v, const std::string& what) {
  if (Finite(field, v) && !(v > 0.0)) Fail(field, what + " must be positive", FormatParam(v), "> 0");
}

void ParamChecker::NonNegative(const std::string& field, double v, const std::string& what) {
  if (Finite(field, v) && !(v >= 0.0)) {
    Fail(field, what + " must not be negative", FormatParam(v), ">= 0");
  }
}

void ParamChecker::InClosed(const std::string& field, double v, double lo, double hi,
                            const std::string& what) {
  if (Finite(field, v) && !(v >= lo && v <= hi)) {
    Fail(field, what + " is out of range", FormatParam(v),
         std::string("[") + FormatParam(lo) + std::string(", ") + FormatParam(hi) + "]");
  }
}

void ParamChecker::IntInClosed(const std::string& field, int v, int lo, int hi,
                               const std::string& what) {
  if (!(v >= lo && v <= hi)) {
    Fail(field, what + " is out of range", std::to_string(v),
         std::string("[") + std::to_string(lo) + std::string(", ") + std::to_string(hi) + "]");
  }
}

void ParamChecker::TickMultiple(const std::string& field, double v, const std::string& what) {
  if (!Finite(field, v)) return;
  const double ticks = v / kPlantTick_s;
  if (!(ticks >= 1.0 - 1e-9) || std::abs(ticks - std::round(ticks)) > 1e-6) {
    Fail(field, what + " must be a whole multiple of the 1 ms plant tick", FormatParam(v),
         "n * 0.001, n >= 1");
  }
}

void CheckAirParams(ParamChecker& c, const AirParams& a, const std::string& path) {
  const std::string p = path + ".";
  if (c.Finite(p + "heat_ratio", a.heat_ratio) && !(a.heat_ratio > 1.0 && a.heat_ratio <= 5.0 / 3.0)) {
    c.Fail(p + "heat_ratio", "heat capacity ratio of a gas lies in (1, 5/3]",
           FormatParam(a.heat_ratio), "(1, 1.6667]");
  }
  c.Positive(p + "temperature_k", a.temperature_k, "absolute temperature");
  c.Positive(p + "gas_constant_j_kg_k", a.gas_constant_j_kg_k, "gas constant");
  c.Positive(p + "atmosphere_pressure_pa", a.atmosphere_pressure_pa, "atmosphere pressure");
  if (c.Finite(p + "supply_pressure_pa", a.supply_pressure_pa) &&
      !(a.supply_pressure_pa > a.atmosphere_pressure_pa)) {
    c.Fail(p + "supply_pressure_pa", "absolute supply pressure must exceed the atmosphere",
           FormatParam(a.supply_pressure_pa),
           std::string("> ") + p + std::string("atmosphere_pressure_pa (") + FormatParam(a.atmosphere_pressure_pa) + ")");
  }
}

void CheckCylinderParams(ParamChecker& c, const CylinderParams& y, const std::string& path) {
  const std::string p = path + ".";
  c.Positive(p + "cap_area_m2", y.cap_area_m2, "area");
  c.Positive(p + "annulus_area_m2", y.annulus_area_m2, "area");
  c.Positive(p + "rod_area_m2", y.rod_area_m2, "area");
  if (y.cap_area_m2 > 0.0 && y.annulus_area_m2 > 0.0 && std::isfinite(y.cap_area_m2) &&
      std::isfinite(y.annulus_area_m2)) {
    if (!(y.annulus_area_m2 < y.cap_area_m2)) {
      c.Fail(p + "annulus_area_m2", "annulus area must be smaller than the cap area",
             FormatParam(y.annulus_area_m2),
             std::string("< ") + p + std::string("cap_area_m2 (") + FormatParam(y.cap_area_m2) + ")");
    } else if (y.rod_area_m2 > 0.0 && std::isfinite(y.rod_area_m2)) {
      // A2 = A1 - Ar for a single-rod cylinder; 1 % covers rounding of the three areas.
      const double expected = y.cap_area_m2 - y.annulus_area_m2;
      if (!(std::abs(y.rod_area_m2 - expected) <= 0.01 * y.cap_area_m2)) {
        c.Fail(p + "rod_area_m2", "rod area must equal cap area - annulus area",
               FormatParam(y.rod_area_m2),
               FormatParam(expected) + std::string(" +- 1 % of ") + p + "cap_area_m2");
      }
    }
  }
  c.Positive(p + "stroke_m", y.stroke_m, "stroke");
  c.Positive(p + "dead_volume_m3", y.dead_volume_m3, "dead volume");
  c.Positive(p + "moving_mass_kg", y.moving_mass_kg, "mass");
  if (c.Finite(p + "mid_stroke_length_m", y.mid_stroke_length_m) && std::isfinite(y.stroke_m) &&
      !(y.mid_stroke_length_m > 0.5 * y.stroke_m)) {
    c.Fail(p + "mid_stroke_length_m",
           "leg length at mid-stroke must exceed half the stroke (the retracted leg is longer "
           "than zero)",
           FormatParam(y.mid_stroke_length_m),
           std::string("> ") + p + std::string("stroke_m / 2 (") + FormatParam(0.5 * y.stroke_m) + ")");
  }
  c.Positive(p + "end_stop_stiffness_n_m", y.end_stop_stiffness_n_m, "end-stop stiffness");
  c.NonNegative(p + "end_stop_damping_n_s_m", y.end_stop_damping_n_s_m, "end-stop damping");
}

void CheckValveParams(ParamChecker& c, const ValveParams& v, const std::string& path) {
  const std::string p = path + ".";
  const bool finite_v = c.Finite(p + "min_voltage_v", v.min_voltage_v) &
                        c.Finite(p + "max_voltage_v", v.max_voltage_v) &
                        c.Finite(p + "null_voltage_v", v.null_voltage_v);
  if (finite_v) {
    if (!(v.max_voltage_v > v.min_voltage_v)) {
      c.Fail(p + "max_voltage_v", "maximum voltage must exceed the minimum voltage",
             FormatParam(v.max_voltage_v),
             std::string("> ") + p + std::string("min_voltage_v (") + FormatParam(v.min_voltage_v) + ")");
    } else if (!(v.null_voltage_v > v.min_voltage_v && v.null_voltage_v < v.max_voltage_v)) {
      c.Fail(p + "null_voltage_v",
             "null (closed) voltage must lie strictly between the minimum and maximum voltage",
             FormatParam(v.null_voltage_v),
             std::string("(") + FormatParam(v.min_voltage_v) + std::string(", ") + FormatParam(v.max_voltage_v) + std::string(") = (") +
                 p + std::string("min_voltage_v, ") + p + "max_voltage_v)");
    }
  }
  if (c.Finite(p + "spool_gain_m_v", v.spool_gain_m_v) && !(v.spool_gain_m_v != 0.0)) {
    c.Fail(p + "spool_gain_m_v", "spool gain a of eq 42 must not be zero",
           FormatParam(v.spool_gain_m_v), "!= 0");
  }
  c.Finite(p + "spool_offset_m", v.spool_offset_m);
  c.Positive(p + "max_spool_m", v.max_spool_m, "full spool opening");
  const bool spool_ok = std::isfinite(v.spool_gain_m_v) && v.spool_gain_m_v != 0.0 &&
                        std::isfinite(v.spool_offset_m) && std::isfinite(v.max_spool_m) &&
                        v.max_spool_m > 0.0;
  if (finite_v && spool_ok && v.max_voltage_v > v.min_voltage_v &&
      v.null_voltage_v > v.min_voltage_v && v.null_voltage_v < v.max_voltage_v) {
    // Eq 42 must close the valve at the null voltage and open it no further than fully.
    const double x_null_m = v.spool_gain_m_v * v.null_voltage_v + v.spool_offset_m;
    if (!(std::abs(x_null_m) <= 0.01 * v.max_spool_m)) {
      c.Fail(p + "spool_offset_m",
             "spool must be closed at the null voltage: X_spool = a * null_voltage_v + b (eq 42)",
             std::string("X_spool(null) = ") + FormatParam(x_null_m) + " m",
             std::string("|X_spool(null)| <= 1 % of ") + p + std::string("max_spool_m (") + FormatParam(0.01 * v.max_spool_m) +
                 " m)");
    }
    const double x_lo_m = v.spool_gain_m_v * v.min_voltage_v + v.spool_offset_m;
    const double x_hi_m = v.spool_gain_m_v * v.max_voltage_v + v.spool_offset_m;
    const double x_max_m = std::max(std::abs(x_lo_m), std::abs(x_hi_m));
    if (!(x_max_m <= 1.01 * v.max_spool_m)) {
      c.Fail(p + "spool_gain_m_v", "the voltage range drives the spool past its full opening (eq 42)",
             std::string("max |X_spool| = ") + FormatParam(x_max_m) + " m",
             std::string("<= ") + p + std::string("max_spool_m (") + FormatParam(v.max_spool_m) + " m) + 1 %");
    }
  }
  c.Positive(p + "max_orifice_area_m2", v.max_orifice_area_m2, "area");
  if (c.Finite(p + "discharge_coefficient", v.discharge_coefficient) &&
      !(v.discharge_coefficient > 0.0 && v.discharge_coefficient <= 1.0)) {
    c.Fail(p + "discharge_coefficient", "discharge coefficient is out of range",
           FormatParam(v.discharge_coefficient), "(0, 1]");
  }
  // The spool lag dX/dt = (X_target - X) / tau divides by it; its lower bound against the
  // plant's integrator step is a physical limit (physical_limits.hpp).
  c.Positive(p + "spool_time_constant_s", v.spool_time_constant_s, "time constant");
}

namespace {
void CheckFrictionDirection(ParamChecker& c, const FrictionDirectionParams& f,
                            const std::string& path) {
  c.Positive(path + ".stribeck_velocity_m_s", f.stribeck_velocity_m_s, "Stribeck velocity (magnitude)");
  c.NonNegative(path + ".viscous_n_s_m", f.viscous_n_s_m, "viscous coefficient (magnitude)");
  c.NonNegative(path + ".static_n", f.static_n, "static friction (magnitude)");
  if (c.Finite(path + ".coulomb_n", f.coulomb_n) && !(f.coulomb_n > 0.0)) {
    c.Fail(path + ".coulomb_n",
           "Coulomb friction (magnitude) must be positive: the LuGre bristle equation divides by "
           "the friction level, which falls to the Coulomb value at speed (eq 3)",
           FormatParam(f.coulomb_n), "> 0");
  }
  if (std::isfinite(f.static_n) && std::isfinite(f.coulomb_n) && f.coulomb_n >= 0.0 &&
      !(f.static_n >= f.coulomb_n)) {
    c.Fail(path + ".static_n", "static (breakaway) friction must be at least the Coulomb friction (eq 3)",
           FormatParam(f.static_n), std::string(">= ") + path + std::string(".coulomb_n (") + FormatParam(f.coulomb_n) + ")");
  }
}

void CheckPolytropic(ParamChecker& c, const PolytropicParams& p, const std::string& path) {
  // 1 = isothermal; Table 8 identified up to 1.651 (above k = 1.4); 2 catches typos.
  c.InClosed(path + ".inflow", p.inflow, 1.0, 2.0, "polytropic coefficient");
  c.InClosed(path + ".outflow", p.outflow, 1.0, 2.0, "polytropic coefficient");
  c.InClosed(path + ".volume", p.volume, 1.0, 2.0, "polytropic coefficient");
}
}  // namespace

void CheckFrictionParams(ParamChecker& c, const FrictionParams& f, const std::string& path) {
  CheckFrictionDirection(c, f.extend, path + ".extend");
  CheckFrictionDirection(c, f.retract, path + ".retract");
  c.Positive(path + ".bristle_stiffness_n_m", f.bristle_stiffness_n_m, "bristle stiffness");
  c.NonNegative(path + ".bristle_damping_n_s_m", f.bristle_damping_n_s_m, "bristle damping");
}

void CheckPolytropicSet(ParamChecker& c, const PolytropicSet& p, const std::string& path) {
  CheckPolytropic(c, p.extend, path + ".extend");
  CheckPolytropic(c, p.retract, path + ".retract");
}

void CheckPlatformParams(ParamChecker& c, const PlatformParams& p, const std::string& path) {
  c.Positive(path + ".mass_kg", p.mass_kg, "mass");
  c.Positive(path + ".inertia_diag_kg_m2.x", p.inertia_diag_kg_m2.x(), "moment of inertia");
  c.Positive(path + ".inertia_diag_kg_m2.y", p.inertia_diag_kg_m2.y(), "moment of inertia");
  c.Positive(path + ".inertia_diag_kg_m2.z", p.inertia_diag_kg_m2.z(), "moment of inertia");
  c.Positive(path + ".gravity_m_s2", p.gravity_m_s2, "gravity");
}

void CheckSensorNoiseParams(ParamChecker& c, const SensorNoiseParams& s, const std::string& path) {
  const std::string p = path + ".";
  c.NonNegative(p + "length_sigma_m", s.length_sigma_m, "noise standard deviation");
  c.IntInClosed(p + "length_bits", s.length_bits, 1, 24, "quantisation resolution");
  c.NonNegative(p + "pressure_sigma_pa", s.pressure_sigma_pa, "noise standard deviation");
  c.NonNegative(p + "imu_orientation_sigma_rad", s.imu_orientation_sigma_rad, "noise standard deviation");
  c.NonNegative(p + "imu_bias_walk_rad_sqrt_s", s.imu_bias_walk_rad_sqrt_s, "bias random walk");
  c.TickMultiple(p + "imu_period_s", s.imu_period_s, "IMU period");
}

void CheckDisturbanceProfile(ParamChecker& c, const DisturbanceProfile& p, const std::string& path) {
  c.Positive(path + ".friction_scale", p.friction_scale, "scale");
  c.Positive(path + ".polytropic_scale", p.polytropic_scale, "scale");
  c.Positive(path + ".payload_scale", p.payload_scale, "scale");
  // Its upper bound (the supply must stay above the atmosphere) is a system rule.
  c.NonNegative(path + ".supply_ripple_amplitude_pa", p.supply_ripple_amplitude_pa, "supply ripple");
  c.NonNegative(path + ".supply_ripple_frequency_hz", p.supply_ripple_frequency_hz, "frequency");
  c.NonNegative(path + ".joint_position_error_max_m", p.joint_position_error_max_m, "error bound");
  c.NonNegative(path + ".potentiometer_offset_max_m", p.potentiometer_offset_max_m, "error bound");
  if (c.Finite(path + ".potentiometer_gain_error_max", p.potentiometer_gain_error_max) &&
      !(p.potentiometer_gain_error_max >= 0.0 && p.potentiometer_gain_error_max < 1.0)) {
    c.Fail(path + ".potentiometer_gain_error_max", "relative gain error is out of range",
           FormatParam(p.potentiometer_gain_error_max), "[0, 1)");
  }
}

void CheckDifferentiatorParams(ParamChecker& c, const DifferentiatorParams& d,
                               const std::string& path) {
  // Eq 40-41 need at least two samples to form a derivative; the controller keeps at most
  // 32 in its fixed buffer (control_params.hpp).
  c.IntInClosed(path + ".window", d.window, 2, 32, "differentiator window");
  c.Positive(path + ".sigma", d.sigma, "Gaussian standard deviation (samples)");
  if (d.window >= 2) {
    c.InClosed(path + ".centre_lag_samples", d.centre_lag_samples, 0.0,
               static_cast<double>(d.window - 1), "Gaussian centre (inside the window)");
  }
}

void CheckBsSmcParams(ParamChecker& c, const BsSmcParams& b, const std::string& path) {
  const std::string p = path + ".";
  c.Positive(p + "lambda_1_s", b.lambda_1_s, "sliding surface slope");
  c.NonNegative(p + "switching_gain_n", b.switching_gain_n, "switching gain");
  c.Positive(p + "boundary_layer_xi_s_m", b.boundary_layer_xi_s_m, "boundary layer xi");
  c.Positive(p + "backstepping_beta_1_s", b.backstepping_beta_1_s, "backstepping gain");
  c.Positive(p + "effective_mass_kg", b.effective_mass_kg, "mass");
  c.Finite(p + "gravity_load_n", b.gravity_load_n);
  c.NonNegative(p + "viscous_estimate_scale", b.viscous_estimate_scale, "scale");
  c.NonNegative(p + "friction_estimate_scale", b.friction_estimate_scale, "scale");
  c.Positive(p + "friction_smoothing_velocity_m_s", b.friction_smoothing_velocity_m_s,
             "smoothing velocity");
  c.NonNegative(p + "reaching_proportional_n_s_m", b.reaching_proportional_n_s_m, "reaching-law gain");
  c.InClosed(p + "null_band_area_fraction", b.null_band_area_fraction, 0.0, 1.0,
             "area fraction (of the full opening)");
  c.InClosed(p + "spool_filter_time_constant_s", b.spool_filter_time_constant_s, 0.0, 1.0,
             "time constant");
  c.NonNegative(p + "integral_gain_n_m", b.integral_gain_n_m, "gain");
  c.NonNegative(p + "integral_limit_n", b.integral_limit_n, "force limit");
  c.NonNegative(p + "integral_active_below_m_s", b.integral_active_below_m_s, "speed");
  c.Positive(p + "integral_leak_time_constant_s", b.integral_leak_time_constant_s, "time constant");
  c.NonNegative(p + "integral_deadband_m", b.integral_deadband_m, "deadband");
  c.InClosed(p + "feedback_rate_fraction", b.feedback_rate_fraction, 0.0, 1.0,
             "fraction of the feedback part's rate in phi_dot");
  c.InClosed(p + "feedback_rate_time_constant_s", b.feedback_rate_time_constant_s, 0.0, 1.0,
             "time constant");
  c.NonNegative(p + "feedback_rate_full_speed_m_s", b.feedback_rate_full_speed_m_s, "speed");
  c.Positive(p + "observer_mass_kg", b.observer_mass_kg, "observer mass");
  c.Positive(p + "observer_length_sigma_m", b.observer_length_sigma_m, "position noise");
  c.NonNegative(p + "observer_force_sigma_n", b.observer_force_sigma_n, "force noise");
  c.Positive(p + "observer_disturbance_rate_m_s3", b.observer_disturbance_rate_m_s3,
             "disturbance random walk");
  c.NonNegative(p + "dither_amplitude_n", b.dither_amplitude_n, "dither amplitude");
  // At least 4 samples per cycle of the 1 ms control period.
  c.Positive(p + "dither_frequency_hz", b.dither_frequency_hz, "dither frequency");
  c.InClosed(p + "dither_frequency_hz", b.dither_frequency_hz, 0.0, 250.0,
             "dither frequency (at least 4 samples per cycle of the 1 ms control period)");
  c.Positive(p + "dither_gate_speed_m_s", b.dither_gate_speed_m_s, "dither gate speed");
  c.NonNegative(p + "friction_adaptation_rate_1_n_m", b.friction_adaptation_rate_1_n_m,
                "friction adaptation rate");
  c.Positive(p + "friction_adaptation_speed_m_s", b.friction_adaptation_speed_m_s,
             "friction adaptation speed");
  c.InClosed(p + "friction_adaptation_min_scale", b.friction_adaptation_min_scale, 0.0, 1.0,
             "lower bound of the adapted friction scale (the nominal 1 must lie inside)");
  c.InClosed(p + "friction_adaptation_max_scale", b.friction_adaptation_max_scale, 1.0, 5.0,
             "upper bound of the adapted friction scale (the nominal 1 must lie inside)");
}

void CheckPiParams(ParamChecker& c, const PiParams& p, const std::string& path) {
  c.NonNegative(path + ".proportional_v_m", p.proportional_v_m, "gain");
  c.NonNegative(path + ".integral_v_m_s", p.integral_v_m_s, "gain");
  c.NonNegative(path + ".integrator_limit_v", p.integrator_limit_v, "limit");
  c.NonNegative(path + ".velocity_feedforward_v_s_m", p.velocity_feedforward_v_s_m, "gain");
  c.NonNegative(path + ".rate_damping_v_s_m", p.rate_damping_v_s_m, "gain");
  c.NonNegative(path + ".force_feedforward_v_n", p.force_feedforward_v_n, "gain");
}

void CheckPotentiometerCalibrationParams(ParamChecker& c, const PotentiometerCalibrationParams& p,
                                         const std::string& path) {
  c.Finite(path + ".offset_m", p.offset_m);
  c.Positive(path + ".gain", p.gain, "potentiometer gain");
}

void CheckLegControllerParams(ParamChecker& c, const LegControllerParams& p,
                              const std::string& path) {
  CheckDifferentiatorParams(c, p.differentiator, path + ".differentiator");
  CheckBsSmcParams(c, p.bssmc, path + ".bssmc");
  CheckPiParams(c, p.pi, path + ".pi");
  c.InClosed(path + ".coupled.gain", p.coupled.gain, 0.0, 1.0, "coupling gain");
  c.InClosed(path + ".coupled.cutoff_hz", p.coupled.cutoff_hz, 0.0, 500.0,
             "coupling low-pass cut-off (0 = none; at most the 1 kHz tick's Nyquist frequency)");
  // Its lower bound (the setpoint period) is a system rule.
  c.Positive(path + ".setpoint_timeout_s", p.setpoint_timeout_s, "setpoint timeout");
}

void CheckOuterLoopParams(ParamChecker& c, const OuterLoopParams& o, const std::string& path) {
  c.InClosed(path + ".gain", o.gain, 0.0, 1.0, "outer-loop gain (fraction per step)");
  c.NonNegative(path + ".max_correction_m", o.max_correction_m, "correction bound");
  c.InClosed(path + ".translation_gain_scale", o.translation_gain_scale, 0.0, 1.0,
             "translation share of the outer-loop gain");
  c.NonNegative(path + ".gate_leg_speed_m_s", o.gate_leg_speed_m_s, "speed gate (0 = off)");
}

// Longest blend or stop: with the 1800 s a CSV may span, every accepted trajectory stays under
// the feasibility check's 2000 s (feasibility.hpp).
inline constexpr double kMaxBlendOrStop_s = 60.0;

namespace {

// The soft limits of the supervisor's setpoints (docs/operate.md "Soft limits"). The box must
// contain the home pose (where the platform starts), and lie inside the workspace check
// (a setpoint held at the box must not hold the platform as "outside the workspace").
void CheckSoftLimitParams(ParamChecker& c, const SoftLimitParams& s, const std::string& path,
                          double workspace_radius_m, double workspace_max_rotation_rad) {
  const std::string p = path + ".";
  c.InClosed(p + "max_base_joint_angle_rad", s.max_base_joint_angle_rad, 1e-3, 1.5,
             "base joint deflection limit");
  c.InClosed(p + "max_platform_joint_angle_rad", s.max_platform_joint_angle_rad, 1e-3, 1.5,
             "platform joint deflection limit");
  static constexpr const char* kXyz[3] = {"x", "y", "z"};
  static constexpr const char* kRpy[3] = {"roll", "pitch", "yaw"};
  const auto bound = [&](const std::string& field, double v, bool is_min, double reach,
                         const char* reach_field) {
    if (!c.Finite(field, v)) return;
    if (is_min ? !(v < 0.0) : !(v > 0.0)) {
      c.Fail(field, "the pose box must contain the home pose", FormatParam(v), is_min ? "< 0" : "> 0");
    } else if (std::isfinite(reach) && reach > 0.0 && !(std::abs(v) <= reach)) {
      c.Fail(field,
             std::string("the pose box must lie inside the workspace check (") + reach_field + ")",
             FormatParam(v), "[-" + FormatParam(reach) + ", " + FormatParam(reach) + "]");
    }
  };
  const double max_angle_rad = std::min(workspace_max_rotation_rad, 1.5);  // rpy singular at 90 deg
  for (int k = 0; k < 3; ++k) {
    bound(p + "position_min_from_home_m." + kXyz[k], s.position_min_from_home_m[k], true,
          workspace_radius_m, "supervisor.workspace_radius_m");
    bound(p + "position_max_from_home_m." + kXyz[k], s.position_max_from_home_m[k], false,
          workspace_radius_m, "supervisor.workspace_radius_m");
    bound(p + "rotation_min_rad." + kRpy[k], s.rotation_min_rad[k], true, max_angle_rad,
          "supervisor.workspace_max_rotation_rad, at most 1.5 rad");
    bound(p + "rotation_max_rad." + kRpy[k], s.rotation_max_rad[k], false, max_angle_rad,
          "supervisor.workspace_max_rotation_rad, at most 1.5 rad");
  }
  c.Positive(p + "max_linear_speed_m_s", s.max_linear_speed_m_s, "linear speed limit");
  c.Positive(p + "max_angular_speed_rad_s", s.max_angular_speed_rad_s, "angular speed limit");
}

}  // namespace

void CheckSupervisorParams(ParamChecker& c, const SupervisorParams& s, const std::string& path) {
  const std::string p = path + ".";
  c.TickMultiple(p + "period_s", s.period_s, "supervisor period");
  for (const auto& [field, v] : {std::pair{"blend_duration_s", s.blend_duration_s},
                                 std::pair{"stop_duration_s", s.stop_duration_s}}) {
    if (c.Finite(p + field, v) && !(v > 0.0 && v <= kMaxBlendOrStop_s)) {
      c.Fail(p + field,
             std::string("duration must be positive (a zero blend or stop steps the setpoints) and at most ") +
                 FormatParam(kMaxBlendOrStop_s) +
                 " s (every trajectory must stay within the 2000 s the feasibility check samples)",
             FormatParam(v), std::string("(0, ") + FormatParam(kMaxBlendOrStop_s) + "]");
    }
  }
  // Its upper bound (half the stroke) is a system rule.
  c.NonNegative(p + "stroke_margin_m", s.stroke_margin_m, "stroke margin");
  c.Positive(p + "max_leg_speed_m_s", s.max_leg_speed_m_s, "speed limit");
  c.Positive(p + "max_leg_acceleration_m_s2", s.max_leg_acceleration_m_s2, "acceleration limit");
  c.IntInClosed(p + "max_consecutive_deadline_misses", s.max_consecutive_deadline_misses, 1, 1000,
                "deadline-miss tolerance");
  c.Positive(p + "workspace_radius_m", s.workspace_radius_m, "radius");
  if (c.Finite(p + "workspace_max_rotation_rad", s.workspace_max_rotation_rad) &&
      !(s.workspace_max_rotation_rad > 0.0 && s.workspace_max_rotation_rad <= 3.14159265358979323846)) {
    c.Fail(p + "workspace_max_rotation_rad",
           "rotation bound is out of range (0 would hold at every tick)",
           FormatParam(s.workspace_max_rotation_rad), "(0, 3.1415926535897931]");
  }
  c.Positive(p + "estimator_outlier_threshold_m", s.estimator_outlier_threshold_m, "outlier threshold");
  c.Positive(p + "length_consistency_limit_m", s.length_consistency_limit_m,
             "length-consistency limit (docs/faults.md)");
  c.IntInClosed(p + "length_consistency_ticks", s.length_consistency_ticks, 1, 200,
                "length-consistency persistence (supervisor ticks)");
  c.InClosed(p + "setpoint_lead_s", s.setpoint_lead_s, 0.0, 0.05, "setpoint lead (0 = off)");
  CheckOuterLoopParams(c, s.outer_loop, p + "outer_loop");
  CheckSoftLimitParams(c, s.soft_limits, p + "soft_limits", s.workspace_radius_m,
                       s.workspace_max_rotation_rad);
}

void CheckPlantFaultParams(ParamChecker& c, const PlantFaultParams& f, const std::string& path) {
  c.Finite(path + ".pot_drift_m_s", f.pot_drift_m_s);
  c.Positive(path + ".supply_loss_time_constant_s", f.supply_loss_time_constant_s, "time constant");
  for (std::size_t k = 0; k < f.faults.size(); ++k) {
    const PlantFault& x = f.faults[k];
    const std::string at = path + ".faults[" + std::to_string(k) + "]";
    c.NonNegative(at + ".at_time_s", x.at_time_s, "fault time");
    if (PlantFaultHasLeg(x.kind)) {
      c.IntInClosed(at + ".leg", x.leg, 1, static_cast<int>(kNumLegs), std::string(ToString(x.kind)) + " leg");
    } else {
      c.IntInClosed(at + ".leg", x.leg, 0, 0, std::string(ToString(x.kind)) + " (not a leg fault) leg");
    }
  }
}

void CheckRigParams(ParamChecker& c, const RigParams& rig) {
  CheckAirParams(c, rig.air);
  CheckCylinderParams(c, rig.cylinder);
  CheckValveParams(c, rig.valve);
  CheckFrictionParams(c, rig.friction);
  CheckPolytropicSet(c, rig.polytropic);
  CheckPlatformParams(c, rig.platform);
  CheckSensorNoiseParams(c, rig.sensors);
}

void ThrowIfIssues(const std::vector<ParamIssue>& issues, const std::string& context) {
  if (issues.empty()) return;
  std::string text = context + ": ";
  for (std::size_t i = 0; i < issues.size(); ++i) {
    const ParamIssue& issue = issues[i];
    if (i > 0) text += "; ";
    text += issue.field + ": " + issue.message + " (value " + issue.value + ", limit " +
            issue.limit + ")";
  }
  throw std::invalid_argument(text);
}

}  // namespace hexa
