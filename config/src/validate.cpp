// Value rules of the rig file (docs/config.md, "Validation rules"). Each rule names the
// field path of the rig file, the offending value and the limit it broke; the loader adds
// the file, line and column. Comparisons are written as !(value OK) so that NaN fails too.
#include <Eigen/SVD>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/kinematics.hpp"
#include "internal.hpp"

namespace hexa::config {
namespace internal {

std::string FormatDouble(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // The fewest %g digits that read back to the same double: "0.00031416", "1e-05".
  char buffer[64];
  // Start at the number of integer digits so that 10 prints as "10", not "1e+01".
  const double magnitude = std::abs(value);
  const int integer_digits = magnitude >= 1.0 && magnitude < 1e17 ? static_cast<int>(std::log10(magnitude)) + 1 : 1;
  for (int precision = integer_digits; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

std::string FormatDerived(double value) {
  if (!std::isfinite(value)) return FormatDouble(value);
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

HomeGeometry ComputeHomeGeometry(const GeometryParams& geometry) {
  HomeGeometry home;
  Pose pose;
  pose.p_BP_B_m = geometry.home_position_m;
  InverseKinematics(geometry, pose, home.length_m);

  // Eq 48 mixes units (m/m for translation, m/rad for rotation); dividing the rotation
  // columns by a characteristic length (the RMS platform joint radius) makes the
  // condition number independent of the unit choice.
  double sum_sq = 0.0;
  for (const auto& b : geometry.p_PB_P) sum_sq += b.squaredNorm();
  home.characteristic_length_m = std::sqrt(sum_sq / static_cast<double>(kNumLegs));
  const double scale_m = home.characteristic_length_m > 1e-9 ? home.characteristic_length_m : 1.0;

  Matrix6d J;
  LegJacobian(geometry, pose, J);
  J.rightCols<3>() /= scale_m;
  const Eigen::JacobiSVD<Matrix6d> svd(J);
  const Vector6d s = svd.singularValues();  // descending
  const bool zero_leg =
      std::any_of(home.length_m.begin(), home.length_m.end(), [](double l) { return !(l > 1e-9); });
  if (zero_leg || !s.allFinite() || !(s(5) > 1e-12 * s(0))) {
    home.jacobian_condition = std::numeric_limits<double>::infinity();
  } else {
    home.jacobian_condition = s(0) / s(5);
  }
  return home;
}

}  // namespace internal

namespace {

using internal::FormatDouble;
using internal::FormatDerived;

// Joints closer than this are the same joint (a real spherical joint is ~20 mm across).
constexpr double kMinJointSeparation_m = 1e-3;
// RMS distance of the six joints from their best-fit line below which base or platform
// joints are treated as collinear.
constexpr double kMinJointSpread_m = 1e-3;
// Upper bound of the scaled home Jacobian's condition number. HexaTaar-R has 2.83; 100
// means a 1 % leg-length error may become a 100 % pose error in the worst direction.
constexpr double kMaxJacobianCondition = 100.0;


class Checker {
 public:
  explicit Checker(std::vector<ConfigIssue>& out) : out_(out) {}

  void Fail(const std::string& field, const std::string& message, const std::string& value,
            const std::string& limit) {
    ConfigIssue issue;
    issue.field = field;
    issue.message = message;
    issue.value = value;
    issue.limit = limit;
    out_.push_back(std::move(issue));
  }

  // Returns false (and reports) if the value is not finite; further rules then skip it.
  bool Finite(const std::string& field, double v) {
    if (std::isfinite(v)) return true;
    Fail(field, "value must be a finite number", FormatDouble(v), "finite");
    return false;
  }
  void Positive(const std::string& field, double v, const std::string& what) {
    if (Finite(field, v) && !(v > 0.0)) Fail(field, what + " must be positive", FormatDouble(v), "> 0");
  }
  void NonNegative(const std::string& field, double v, const std::string& what) {
    if (Finite(field, v) && !(v >= 0.0)) {
      Fail(field, what + " must not be negative", FormatDouble(v), ">= 0");
    }
  }
  // lo <= v <= hi
  void InClosed(const std::string& field, double v, double lo, double hi, const std::string& what) {
    if (Finite(field, v) && !(v >= lo && v <= hi)) {
      Fail(field, what + " is out of range", FormatDouble(v),
           "[" + FormatDouble(lo) + ", " + FormatDouble(hi) + "]");
    }
  }
  void IntInClosed(const std::string& field, int v, int lo, int hi, const std::string& what) {
    if (!(v >= lo && v <= hi)) {
      Fail(field, what + " is out of range", std::to_string(v),
           "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
  }
  // A period that the 1 ms plant tick can realise.
  void TickMultiple(const std::string& field, double v, const std::string& what) {
    if (!Finite(field, v)) return;
    const double ticks = v / internal::kPlantTick_s;
    if (!(ticks >= 1.0 - 1e-9) || std::abs(ticks - std::round(ticks)) > 1e-6) {
      Fail(field, what + " must be a whole multiple of the 1 ms plant tick", FormatDouble(v),
           "n * 0.001, n >= 1");
    }
  }

 private:
  std::vector<ConfigIssue>& out_;
};

std::string LegPath(std::size_t i) { return "geometry.leg[id=" + std::to_string(i + 1) + "]"; }

bool AllFinite(const GeometryParams& g) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!g.p_BA_B[i].allFinite() || !g.p_PB_P[i].allFinite()) return false;
  }
  return g.home_position_m.allFinite();
}

// RMS distance of the points from their best-fit line.
double SpreadAboutLine(const LegArray<Eigen::Vector3d>& points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(kNumLegs);
  Eigen::Matrix<double, kNumLegs, 3> centred;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    centred.row(static_cast<Eigen::Index>(i)) = (points[i] - mean).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, kNumLegs, 3>> svd(centred);
  const Eigen::Vector3d s = svd.singularValues();
  return std::sqrt((s(1) * s(1) + s(2) * s(2)) / static_cast<double>(kNumLegs));
}

void CheckJointSet(Checker& c, const LegArray<Eigen::Vector3d>& joints, const std::string& member,
                   const std::string& which) {
  bool distinct = true;
  for (std::size_t j = 1; j < kNumLegs; ++j) {
    for (std::size_t i = 0; i < j; ++i) {
      const double d = (joints[j] - joints[i]).norm();
      if (!(d >= kMinJointSeparation_m)) {
        distinct = false;
        c.Fail(LegPath(j) + "." + member,
               which + " joint of leg " + std::to_string(j + 1) + " coincides with that of leg " +
                   std::to_string(i + 1) + " (distance " + FormatDouble(d) + " m)",
               FormatDouble(d), ">= " + FormatDouble(kMinJointSeparation_m) + " m apart");
      }
    }
  }
  if (!distinct) return;
  const double spread = SpreadAboutLine(joints);
  if (!(spread >= kMinJointSpread_m)) {
    c.Fail("geometry", which + " joints are collinear: RMS distance from their best-fit line",
           FormatDouble(spread), ">= " + FormatDouble(kMinJointSpread_m) + " m");
  }
}

void CheckGeometry(Checker& c, const SystemConfig& config) {
  const GeometryParams& g = config.rig.geometry;
  if (!AllFinite(g)) {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      for (int k = 0; k < 3; ++k) {
        static constexpr const char* kAxis[] = {"x", "y", "z"};
        c.Finite(LegPath(i) + ".p_BA_B_m." + kAxis[k], g.p_BA_B[i](k));
        c.Finite(LegPath(i) + ".p_PB_P_m." + kAxis[k], g.p_PB_P[i](k));
      }
    }
    for (int k = 0; k < 3; ++k) {
      static constexpr const char* kAxis[] = {"x", "y", "z"};
      c.Finite(std::string("geometry.home_position_m.") + kAxis[k], g.home_position_m(k));
    }
    return;
  }
  std::vector<ConfigIssue> local;
  Checker joints(local);
  CheckJointSet(joints, g.p_BA_B, "p_BA_B_m", "base");
  CheckJointSet(joints, g.p_PB_P, "p_PB_P_m", "platform");
  const bool joints_ok = local.empty();
  for (auto& issue : local) c.Fail(issue.field, issue.message, issue.value, issue.limit);
  if (!joints_ok) return;

  const internal::HomeGeometry home = internal::ComputeHomeGeometry(g);

  // Home pose inside the usable stroke (end stops minus the supervisor's margin).
  const CylinderParams& cyl = config.rig.cylinder;
  const double margin_m = config.supervisor.stroke_margin_m;
  if (std::isfinite(cyl.mid_stroke_length_m) && std::isfinite(cyl.stroke_m) && cyl.stroke_m > 0.0 &&
      std::isfinite(margin_m) && margin_m >= 0.0 && margin_m < 0.5 * cyl.stroke_m) {
    const double lo_m = cyl.mid_stroke_length_m - 0.5 * cyl.stroke_m + margin_m;
    const double hi_m = cyl.mid_stroke_length_m + 0.5 * cyl.stroke_m - margin_m;
    // One message for the pose, naming the leg furthest outside and every leg outside.
    std::string legs_outside;
    std::size_t worst = kNumLegs;
    double worst_excess_m = 0.0;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double l = home.length_m[i];
      const double excess_m = std::max(lo_m - l, l - hi_m);
      if (!(excess_m <= 0.0)) {
        legs_outside += (legs_outside.empty() ? "" : ",") + std::to_string(i + 1);
        if (worst == kNumLegs || excess_m > worst_excess_m) {
          worst = i;
          worst_excess_m = excess_m;
        }
      }
    }
    if (worst < kNumLegs) {
      c.Fail("geometry.home_position_m",
             "home pose puts leg(s) " + legs_outside + " outside the usable stroke " +
                 "(cylinder.mid_stroke_length_m +- cylinder.stroke_m / 2, less supervisor.stroke_margin_m); "
                 "leg " + std::to_string(worst + 1) + " is " + FormatDerived(home.length_m[worst]) + " m long",
             FormatDerived(home.length_m[worst]) + " m",
             "[" + FormatDerived(lo_m) + ", " + FormatDerived(hi_m) + "] m");
    }
  }

  // A proper 6-6 platform: the leg Jacobian at home (eq 48) must be well conditioned.
  if (!std::isfinite(home.jacobian_condition)) {
    c.Fail("geometry",
           "not a proper 6-6 platform: the leg Jacobian (eq 48) at the home pose is singular",
           "condition number inf", "<= " + FormatDouble(kMaxJacobianCondition));
  } else if (!(home.jacobian_condition <= kMaxJacobianCondition)) {
    c.Fail("geometry",
           "not a proper 6-6 platform: the leg Jacobian (eq 48) at the home pose is badly "
           "conditioned (rotation columns scaled by the platform radius " +
               FormatDerived(home.characteristic_length_m) + " m)",
           "condition number " + FormatDerived(home.jacobian_condition),
           "<= " + FormatDouble(kMaxJacobianCondition));
  }
}

void CheckAir(Checker& c, const AirParams& a) {
  if (c.Finite("air.heat_ratio", a.heat_ratio) && !(a.heat_ratio > 1.0 && a.heat_ratio <= 5.0 / 3.0)) {
    c.Fail("air.heat_ratio", "heat capacity ratio of a gas lies in (1, 5/3]",
           FormatDouble(a.heat_ratio), "(1, 1.6667]");
  }
  c.Positive("air.temperature_k", a.temperature_k, "absolute temperature");
  c.Positive("air.gas_constant_j_kg_k", a.gas_constant_j_kg_k, "gas constant");
  c.Positive("air.atmosphere_pressure_pa", a.atmosphere_pressure_pa, "atmosphere pressure");
  if (c.Finite("air.supply_pressure_pa", a.supply_pressure_pa) &&
      !(a.supply_pressure_pa > a.atmosphere_pressure_pa)) {
    c.Fail("air.supply_pressure_pa", "absolute supply pressure must exceed the atmosphere",
           FormatDouble(a.supply_pressure_pa),
           "> air.atmosphere_pressure_pa (" + FormatDouble(a.atmosphere_pressure_pa) + ")");
  }
}

void CheckCylinder(Checker& c, const CylinderParams& y) {
  c.Positive("cylinder.cap_area_m2", y.cap_area_m2, "area");
  c.Positive("cylinder.annulus_area_m2", y.annulus_area_m2, "area");
  c.Positive("cylinder.rod_area_m2", y.rod_area_m2, "area");
  if (y.cap_area_m2 > 0.0 && y.annulus_area_m2 > 0.0 && std::isfinite(y.cap_area_m2) &&
      std::isfinite(y.annulus_area_m2)) {
    if (!(y.annulus_area_m2 < y.cap_area_m2)) {
      c.Fail("cylinder.annulus_area_m2", "annulus area must be smaller than the cap area",
             FormatDouble(y.annulus_area_m2),
             "< cylinder.cap_area_m2 (" + FormatDouble(y.cap_area_m2) + ")");
    } else if (y.rod_area_m2 > 0.0 && std::isfinite(y.rod_area_m2)) {
      // A2 = A1 - Ar for a single-rod cylinder; 1 % covers rounding of the three areas.
      const double expected = y.cap_area_m2 - y.annulus_area_m2;
      if (!(std::abs(y.rod_area_m2 - expected) <= 0.01 * y.cap_area_m2)) {
        c.Fail("cylinder.rod_area_m2", "rod area must equal cap area - annulus area",
               FormatDouble(y.rod_area_m2),
               FormatDouble(expected) + " +- 1 % of cylinder.cap_area_m2");
      }
    }
  }
  c.Positive("cylinder.stroke_m", y.stroke_m, "stroke");
  c.Positive("cylinder.dead_volume_m3", y.dead_volume_m3, "dead volume");
  c.Positive("cylinder.moving_mass_kg", y.moving_mass_kg, "mass");
  if (c.Finite("cylinder.mid_stroke_length_m", y.mid_stroke_length_m) && std::isfinite(y.stroke_m) &&
      !(y.mid_stroke_length_m > 0.5 * y.stroke_m)) {
    c.Fail("cylinder.mid_stroke_length_m",
           "leg length at mid-stroke must exceed half the stroke (the retracted leg is longer "
           "than zero)",
           FormatDouble(y.mid_stroke_length_m), "> cylinder.stroke_m / 2 (" + FormatDouble(0.5 * y.stroke_m) + ")");
  }
  c.Positive("cylinder.end_stop_stiffness_n_m", y.end_stop_stiffness_n_m, "end-stop stiffness");
  c.NonNegative("cylinder.end_stop_damping_n_s_m", y.end_stop_damping_n_s_m, "end-stop damping");
}

void CheckValve(Checker& c, const ValveParams& v) {
  const bool finite_v = c.Finite("valve.min_voltage_v", v.min_voltage_v) &
                        c.Finite("valve.max_voltage_v", v.max_voltage_v) &
                        c.Finite("valve.null_voltage_v", v.null_voltage_v);
  if (finite_v) {
    if (!(v.max_voltage_v > v.min_voltage_v)) {
      c.Fail("valve.max_voltage_v", "maximum voltage must exceed the minimum voltage",
             FormatDouble(v.max_voltage_v), "> valve.min_voltage_v (" + FormatDouble(v.min_voltage_v) + ")");
    } else if (!(v.null_voltage_v > v.min_voltage_v && v.null_voltage_v < v.max_voltage_v)) {
      c.Fail("valve.null_voltage_v",
             "null (closed) voltage must lie strictly between the minimum and maximum voltage",
             FormatDouble(v.null_voltage_v),
             "(" + FormatDouble(v.min_voltage_v) + ", " + FormatDouble(v.max_voltage_v) +
                 ") = (valve.min_voltage_v, valve.max_voltage_v)");
    }
  }
  if (c.Finite("valve.spool_gain_m_v", v.spool_gain_m_v) && !(v.spool_gain_m_v != 0.0)) {
    c.Fail("valve.spool_gain_m_v", "spool gain a of eq 42 must not be zero",
           FormatDouble(v.spool_gain_m_v), "!= 0");
  }
  c.Finite("valve.spool_offset_m", v.spool_offset_m);
  c.Positive("valve.max_spool_m", v.max_spool_m, "full spool opening");
  const bool spool_ok = std::isfinite(v.spool_gain_m_v) && v.spool_gain_m_v != 0.0 &&
                        std::isfinite(v.spool_offset_m) && std::isfinite(v.max_spool_m) &&
                        v.max_spool_m > 0.0;
  if (finite_v && spool_ok && v.max_voltage_v > v.min_voltage_v &&
      v.null_voltage_v > v.min_voltage_v && v.null_voltage_v < v.max_voltage_v) {
    // Eq 42 must close the valve at the null voltage and open it no further than fully.
    const double x_null_m = v.spool_gain_m_v * v.null_voltage_v + v.spool_offset_m;
    if (!(std::abs(x_null_m) <= 0.01 * v.max_spool_m)) {
      c.Fail("valve.spool_offset_m",
             "spool must be closed at the null voltage: X_spool = a * null_voltage_v + b (eq 42)",
             "X_spool(null) = " + FormatDouble(x_null_m) + " m",
             "|X_spool(null)| <= 1 % of valve.max_spool_m (" + FormatDouble(0.01 * v.max_spool_m) + " m)");
    }
    const double x_lo_m = v.spool_gain_m_v * v.min_voltage_v + v.spool_offset_m;
    const double x_hi_m = v.spool_gain_m_v * v.max_voltage_v + v.spool_offset_m;
    const double x_max_m = std::max(std::abs(x_lo_m), std::abs(x_hi_m));
    if (!(x_max_m <= 1.01 * v.max_spool_m)) {
      c.Fail("valve.spool_gain_m_v",
             "the voltage range drives the spool past its full opening (eq 42)",
             "max |X_spool| = " + FormatDouble(x_max_m) + " m",
             "<= valve.max_spool_m (" + FormatDouble(v.max_spool_m) + " m) + 1 %");
    }
  }
  c.Positive("valve.max_orifice_area_m2", v.max_orifice_area_m2, "area");
  if (c.Finite("valve.discharge_coefficient", v.discharge_coefficient) &&
      !(v.discharge_coefficient > 0.0 && v.discharge_coefficient <= 1.0)) {
    c.Fail("valve.discharge_coefficient", "discharge coefficient is out of range",
           FormatDouble(v.discharge_coefficient), "(0, 1]");
  }
  c.NonNegative("valve.spool_time_constant_s", v.spool_time_constant_s, "time constant");
}

void CheckFrictionDirection(Checker& c, const FrictionDirectionParams& f, const std::string& path) {
  c.Positive(path + ".stribeck_velocity_m_s", f.stribeck_velocity_m_s, "Stribeck velocity (magnitude)");
  c.NonNegative(path + ".viscous_n_s_m", f.viscous_n_s_m, "viscous coefficient (magnitude)");
  c.NonNegative(path + ".static_n", f.static_n, "static friction (magnitude)");
  c.NonNegative(path + ".coulomb_n", f.coulomb_n, "Coulomb friction (magnitude)");
  if (std::isfinite(f.static_n) && std::isfinite(f.coulomb_n) && f.coulomb_n >= 0.0 &&
      !(f.static_n >= f.coulomb_n)) {
    c.Fail(path + ".static_n", "static (breakaway) friction must be at least the Coulomb friction (eq 3)",
           FormatDouble(f.static_n), ">= " + path + ".coulomb_n (" + FormatDouble(f.coulomb_n) + ")");
  }
}

void CheckPolytropic(Checker& c, const PolytropicParams& p, const std::string& path) {
  // 1 = isothermal; Table 8 identified up to 1.651 (above k = 1.4); 2 catches typos.
  c.InClosed(path + ".inflow", p.inflow, 1.0, 2.0, "polytropic coefficient");
  c.InClosed(path + ".outflow", p.outflow, 1.0, 2.0, "polytropic coefficient");
  c.InClosed(path + ".volume", p.volume, 1.0, 2.0, "polytropic coefficient");
}

void CheckPlatformAndSensors(Checker& c, const RigParams& rig) {
  c.Positive("platform.mass_kg", rig.platform.mass_kg, "mass");
  c.Positive("platform.inertia_diag_kg_m2.x", rig.platform.inertia_diag_kg_m2.x(), "moment of inertia");
  c.Positive("platform.inertia_diag_kg_m2.y", rig.platform.inertia_diag_kg_m2.y(), "moment of inertia");
  c.Positive("platform.inertia_diag_kg_m2.z", rig.platform.inertia_diag_kg_m2.z(), "moment of inertia");
  c.Positive("platform.gravity_m_s2", rig.platform.gravity_m_s2, "gravity");

  const SensorNoiseParams& s = rig.sensors;
  c.NonNegative("sensors.length_sigma_m", s.length_sigma_m, "noise standard deviation");
  c.IntInClosed("sensors.length_bits", s.length_bits, 1, 24, "quantisation resolution");
  c.NonNegative("sensors.pressure_sigma_pa", s.pressure_sigma_pa, "noise standard deviation");
  c.NonNegative("sensors.imu_orientation_sigma_rad", s.imu_orientation_sigma_rad, "noise standard deviation");
  c.NonNegative("sensors.imu_bias_walk_rad_sqrt_s", s.imu_bias_walk_rad_sqrt_s, "bias random walk");
  c.TickMultiple("sensors.imu_period_s", s.imu_period_s, "IMU period");
}

void CheckLegController(Checker& c, const LegControllerParams& p, const SupervisorParams& sup) {
  const DifferentiatorParams& d = p.differentiator;
  // Eq 40-41 need at least two samples to form a derivative; the controller keeps at most
  // 32 in its fixed buffer (control_params.hpp).
  c.IntInClosed("leg_controller.differentiator.window", d.window, 2, 32, "differentiator window");
  c.Positive("leg_controller.differentiator.sigma", d.sigma, "Gaussian standard deviation (samples)");
  if (d.window >= 2) {
    c.InClosed("leg_controller.differentiator.centre_lag_samples", d.centre_lag_samples, 0.0,
               static_cast<double>(d.window - 1), "Gaussian centre (inside the window)");
  }
  const BsSmcParams& b = p.bssmc;
  c.Positive("leg_controller.bssmc.lambda_1_s", b.lambda_1_s, "sliding surface slope");
  c.NonNegative("leg_controller.bssmc.switching_gain_n", b.switching_gain_n, "switching gain");
  c.Positive("leg_controller.bssmc.boundary_layer_xi_s_m", b.boundary_layer_xi_s_m, "boundary layer xi");
  c.Positive("leg_controller.bssmc.backstepping_beta_1_s", b.backstepping_beta_1_s, "backstepping gain");
  c.Positive("leg_controller.bssmc.effective_mass_kg", b.effective_mass_kg, "mass");
  c.Finite("leg_controller.bssmc.gravity_load_n", b.gravity_load_n);
  c.NonNegative("leg_controller.bssmc.viscous_estimate_scale", b.viscous_estimate_scale, "scale");
  c.NonNegative("leg_controller.bssmc.friction_estimate_scale", b.friction_estimate_scale, "scale");
  c.Positive("leg_controller.bssmc.friction_smoothing_velocity_m_s", b.friction_smoothing_velocity_m_s,
             "smoothing velocity");
  c.NonNegative("leg_controller.bssmc.reaching_proportional_n_s_m", b.reaching_proportional_n_s_m,
                "reaching-law gain");
  c.NonNegative("leg_controller.bssmc.null_band_area_fraction", b.null_band_area_fraction, "area fraction");
  c.NonNegative("leg_controller.bssmc.spool_filter_time_constant_s", b.spool_filter_time_constant_s,
                "time constant");
  c.NonNegative("leg_controller.bssmc.integral_gain_n_m", b.integral_gain_n_m, "gain");
  c.NonNegative("leg_controller.bssmc.integral_limit_n", b.integral_limit_n, "force limit");
  c.NonNegative("leg_controller.bssmc.integral_active_below_m_s", b.integral_active_below_m_s,
                "speed");
  c.Positive("leg_controller.bssmc.integral_leak_time_constant_s", b.integral_leak_time_constant_s,
             "time constant");
  c.NonNegative("leg_controller.bssmc.integral_deadband_m", b.integral_deadband_m, "deadband");
  c.NonNegative("leg_controller.pi.proportional_v_m", p.pi.proportional_v_m, "gain");
  c.NonNegative("leg_controller.pi.integral_v_m_s", p.pi.integral_v_m_s, "gain");
  c.NonNegative("leg_controller.pi.integrator_limit_v", p.pi.integrator_limit_v, "limit");
  c.NonNegative("leg_controller.pi.velocity_feedforward_v_s_m", p.pi.velocity_feedforward_v_s_m, "gain");
  c.NonNegative("leg_controller.pi.rate_damping_v_s_m", p.pi.rate_damping_v_s_m, "gain");
  c.NonNegative("leg_controller.pi.force_feedforward_v_n", p.pi.force_feedforward_v_n, "gain");
  if (c.Finite("leg_controller.setpoint_timeout_s", p.setpoint_timeout_s) &&
      std::isfinite(sup.period_s) && !(p.setpoint_timeout_s >= sup.period_s && p.setpoint_timeout_s > 0.0)) {
    // Setpoints arrive once per supervisor period: a shorter timeout holds every cycle.
    c.Fail("leg_controller.setpoint_timeout_s", "setpoint timeout shorter than the setpoint period",
           FormatDouble(p.setpoint_timeout_s), ">= supervisor.period_s (" + FormatDouble(sup.period_s) + ")");
  }
}

void CheckSupervisor(Checker& c, const SupervisorParams& s, const CylinderParams& cyl) {
  c.TickMultiple("supervisor.period_s", s.period_s, "supervisor period");
  c.Positive("supervisor.blend_duration_s", s.blend_duration_s, "duration");
  c.Positive("supervisor.stop_duration_s", s.stop_duration_s, "duration");
  if (c.Finite("supervisor.stroke_margin_m", s.stroke_margin_m) && std::isfinite(cyl.stroke_m) &&
      !(s.stroke_margin_m >= 0.0 && s.stroke_margin_m < 0.5 * cyl.stroke_m)) {
    c.Fail("supervisor.stroke_margin_m", "stroke margin must leave a usable stroke",
           FormatDouble(s.stroke_margin_m), "[0, cylinder.stroke_m / 2) = [0, " + FormatDouble(0.5 * cyl.stroke_m) + ")");
  }
  c.Positive("supervisor.max_leg_speed_m_s", s.max_leg_speed_m_s, "speed limit");
  c.Positive("supervisor.max_leg_acceleration_m_s2", s.max_leg_acceleration_m_s2, "acceleration limit");
  c.IntInClosed("supervisor.max_consecutive_deadline_misses", s.max_consecutive_deadline_misses, 1, 1000,
                "deadline-miss tolerance");
  c.Positive("supervisor.workspace_radius_m", s.workspace_radius_m, "radius");
  c.InClosed("supervisor.workspace_max_rotation_rad", s.workspace_max_rotation_rad, 0.0, 3.14159265358979323846,
             "rotation bound");
  c.Positive("supervisor.estimator_outlier_threshold_m", s.estimator_outlier_threshold_m, "outlier threshold");
  c.InClosed("supervisor.outer_loop.gain", s.outer_loop.gain, 0.0, 1.0, "outer-loop gain (fraction per step)");
  c.NonNegative("supervisor.outer_loop.max_correction_m", s.outer_loop.max_correction_m, "correction bound");
  c.InClosed("supervisor.outer_loop.translation_gain_scale", s.outer_loop.translation_gain_scale, 0.0, 1.0,
             "translation share of the outer-loop gain");
}

void CheckProfile(Checker& c, const DisturbanceProfile& p, const std::string& path, const AirParams& air) {
  c.Positive(path + ".friction_scale", p.friction_scale, "scale");
  c.Positive(path + ".polytropic_scale", p.polytropic_scale, "scale");
  c.Positive(path + ".payload_scale", p.payload_scale, "scale");
  if (c.Finite(path + ".supply_ripple_amplitude_pa", p.supply_ripple_amplitude_pa)) {
    const double headroom_pa = air.supply_pressure_pa - air.atmosphere_pressure_pa;
    if (!(p.supply_ripple_amplitude_pa >= 0.0 && p.supply_ripple_amplitude_pa < headroom_pa)) {
      c.Fail(path + ".supply_ripple_amplitude_pa",
             "supply ripple must be non-negative and keep the supply above the atmosphere",
             FormatDouble(p.supply_ripple_amplitude_pa),
             "[0, supply - atmosphere) = [0, " + FormatDouble(headroom_pa) + ")");
    }
  }
  c.NonNegative(path + ".supply_ripple_frequency_hz", p.supply_ripple_frequency_hz, "frequency");
  c.NonNegative(path + ".joint_position_error_max_m", p.joint_position_error_max_m, "error bound");
  c.NonNegative(path + ".potentiometer_offset_max_m", p.potentiometer_offset_max_m, "error bound");
  if (c.Finite(path + ".potentiometer_gain_error_max", p.potentiometer_gain_error_max) &&
      !(p.potentiometer_gain_error_max >= 0.0 && p.potentiometer_gain_error_max < 1.0)) {
    c.Fail(path + ".potentiometer_gain_error_max", "relative gain error is out of range",
           FormatDouble(p.potentiometer_gain_error_max), "[0, 1)");
  }
}

// Plausibility of a kinematic calibration: a calibration corrects millimetres; a joint moved
// further, or a potentiometer this far off, is a different rig (edit the rig file).
constexpr double kMaxJointCalibration_m = 0.02;
constexpr double kMaxPotentiometerOffset_m = 0.01;
constexpr double kMinPotentiometerGain = 0.9;
constexpr double kMaxPotentiometerGain = 1.1;

std::string OverlayLegPath(std::size_t i) { return "leg[leg_id=" + std::to_string(i + 1) + "]"; }

// geometry.leg[id=N].member -> leg[leg_id=N].member (the overlay's own path for the field).
std::string ToOverlayPath(const std::string& rig_path) {
  const std::string prefix = "geometry.leg[id=";
  if (rig_path.rfind(prefix, 0) != 0) return rig_path;
  return "leg[leg_id=" + rig_path.substr(prefix.size());
}

}  // namespace

std::vector<ConfigIssue> ValidateControllerModel(const SystemConfig& config) {
  std::vector<ConfigIssue> issues;
  Checker c(issues);
  const ControllerModel model = MakeControllerModel(config);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegOverride& o = config.leg_override[i];
    if (o.empty()) continue;  // the rig file's values, validated with the rig file
    const std::string leg = OverlayLegPath(i);
    const LegControllerModel& m = model.legs[i];
    CheckFrictionDirection(c, m.model.friction.extend, leg + ".friction.extend");
    CheckFrictionDirection(c, m.model.friction.retract, leg + ".friction.retract");
    CheckPolytropic(c, m.model.polytropic.extend, leg + ".polytropic.extend");
    CheckPolytropic(c, m.model.polytropic.retract, leg + ".polytropic.retract");
    const double cf = m.model.valve.discharge_coefficient;
    if (c.Finite(leg + ".discharge_coefficient", cf) && !(cf > 0.0 && cf <= 1.0)) {
      c.Fail(leg + ".discharge_coefficient", "discharge coefficient is out of range", FormatDouble(cf),
             "(0, 1]");
    }
    c.Positive(leg + ".effective_mass_kg", m.params.bssmc.effective_mass_kg, "mass");
    const double g = m.params.bssmc.gravity_load_n;
    if (c.Finite(leg + ".gravity_load_n", g) && !(std::abs(g) < 1e4)) {
      c.Fail(leg + ".gravity_load_n", "gravity load is implausible", FormatDouble(g), "|value| < 10000 N");
    }
    const double offset = m.potentiometer.offset_m;
    if (c.Finite(leg + ".potentiometer_offset_m", offset) &&
        !(std::abs(offset) <= kMaxPotentiometerOffset_m)) {
      c.Fail(leg + ".potentiometer_offset_m", "potentiometer offset is implausibly large for a calibration",
             FormatDouble(offset), "|value| <= " + FormatDouble(kMaxPotentiometerOffset_m) + " m");
    }
    c.InClosed(leg + ".potentiometer_gain", m.potentiometer.gain, kMinPotentiometerGain,
               kMaxPotentiometerGain, "potentiometer gain");
    for (const auto& [member, calibrated, nominal] :
         {std::tuple{"p_BA_B_m", model.geometry.p_BA_B[i], config.rig.geometry.p_BA_B[i]},
          std::tuple{"p_PB_P_m", model.geometry.p_PB_P[i], config.rig.geometry.p_PB_P[i]}}) {
      const double moved = (calibrated - nominal).norm();
      if (!calibrated.allFinite()) continue;  // reported by the parser
      if (!(moved <= kMaxJointCalibration_m)) {
        c.Fail(leg + "." + member,
               "calibrated joint is implausibly far from the rig file's (geometry.leg[id=" +
                   std::to_string(i + 1) + "]." + member + ")",
               FormatDouble(moved) + " m", "<= " + FormatDouble(kMaxJointCalibration_m) + " m");
      }
    }
  }
  // The calibrated geometry must still be a proper 6-6 platform with home inside the stroke.
  SystemConfig calibrated = config;
  calibrated.rig.geometry = model.geometry;
  std::vector<ConfigIssue> geometry_issues;
  Checker g(geometry_issues);
  CheckGeometry(g, calibrated);
  for (ConfigIssue& issue : geometry_issues) {
    issue.field = ToOverlayPath(issue.field);
    issue.message += " (with the overlay's calibrated joints)";
    issues.push_back(std::move(issue));
  }
  return issues;
}

std::vector<ConfigIssue> ValidateSystemConfig(const SystemConfig& config) {
  std::vector<ConfigIssue> issues;
  Checker c(issues);
  if (config.rig_name.empty()) c.Fail("rig_name", "rig name must not be empty", "\"\"", "non-empty");
  const RigParams& rig = config.rig;
  CheckAir(c, rig.air);
  CheckCylinder(c, rig.cylinder);
  CheckGeometry(c, config);
  CheckValve(c, rig.valve);
  CheckFrictionDirection(c, rig.friction.extend, "friction.extend");
  CheckFrictionDirection(c, rig.friction.retract, "friction.retract");
  c.Positive("friction.bristle_stiffness_n_m", rig.friction.bristle_stiffness_n_m, "bristle stiffness");
  c.NonNegative("friction.bristle_damping_n_s_m", rig.friction.bristle_damping_n_s_m, "bristle damping");
  CheckPolytropic(c, rig.polytropic.extend, "polytropic.extend");
  CheckPolytropic(c, rig.polytropic.retract, "polytropic.retract");
  CheckPlatformAndSensors(c, rig);
  CheckLegController(c, config.leg_controller, config.supervisor);
  CheckSupervisor(c, config.supervisor, rig.cylinder);
  if (config.profiles.empty()) {
    c.Fail("disturbance_profile", "at least one disturbance profile is required", "0 profiles", ">= 1");
  }
  std::string names;
  for (const auto& [name, profile] : config.profiles) {
    CheckProfile(c, profile, "disturbance_profile[name=" + name + "]", rig.air);
    names += (names.empty() ? "" : ", ") + name;
  }
  if (!config.profiles.empty() && config.profiles.count(config.default_profile) == 0) {
    c.Fail("default_profile", "unknown disturbance profile requested",
           "\"" + config.default_profile + "\"", "one of the profiles defined in the file: " + names);
  }
  return issues;
}

}  // namespace hexa::config
