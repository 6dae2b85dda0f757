// Value rules of the rig file (docs/config.md, "Validation rules"): the core's per-struct
// checks (param_checks.hpp, the same the core's constructors apply), the geometry and
// file-level rules (here), the rules across structs and the physical limits
// (physical_limits.hpp). Each names the field path of the rig file, the offending value and
// the limit it broke; the loader adds the file, line and column.
#include <Eigen/SVD>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/board_calibration.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/physical_limits.hpp"
#include "internal.hpp"

namespace hexa::config {
namespace internal {

std::string FormatDouble(double value) { return FormatParam(value); }
std::string FormatDerived(double value) { return hexa::FormatDerived(value); }

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


// Issues are collected as core ParamIssues (param_checks.hpp) and converted at the end.
using Checker = ParamChecker;

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
  std::vector<ParamIssue> local;
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

// Plausibility of a kinematic calibration: a calibration corrects millimetres; a joint moved
// further, or a potentiometer this far off, is a different rig (edit the rig file).
constexpr double kMaxJointCalibration_m = 0.02;
constexpr double kMaxPotentiometerOffset_m = 0.01;
constexpr double kMinPotentiometerGain = 0.9;
// An overlay's platform mass and each principal moment within this factor of the rig file's:
// a payload estimate, not a different platform.
constexpr double kMinPlatformRatio = 0.5;
constexpr double kMaxPlatformRatio = 2.0;
constexpr double kMaxPotentiometerGain = 1.1;

std::string OverlayLegPath(std::size_t i) { return "leg[leg_id=" + std::to_string(i + 1) + "]"; }

// geometry.leg[id=N].member -> leg[leg_id=N].member (the overlay's own path for the field).
std::string ToOverlayPath(const std::string& rig_path) {
  const std::string prefix = "geometry.leg[id=";
  if (rig_path.rfind(prefix, 0) != 0) return rig_path;
  return "leg[leg_id=" + rig_path.substr(prefix.size());
}

// Core issues -> config issues; those from index `first_physical` on broke a physical limit.
std::vector<ConfigIssue> ToConfigIssues(std::vector<ParamIssue>& issues, std::size_t first_physical) {
  std::vector<ConfigIssue> out;
  for (ParamIssue& i : issues) {
    ConfigIssue issue;
    issue.physical_limit = out.size() >= first_physical;
    issue.field = std::move(i.field);
    issue.message = std::move(i.message);
    issue.value = std::move(i.value);
    issue.limit = std::move(i.limit);
    out.push_back(std::move(issue));
  }
  return out;
}

}  // namespace

std::vector<ConfigIssue> ValidateSystemConfig(const SystemConfig& config) {
  // Stage 1: every struct on its own (the same rules the core's constructors apply), the
  // geometry, the file-level rules; stage 2: rules across structs; stage 3, only for a config
  // that passed both (the derivations divide by what they check): the physical limits.
  std::vector<ParamIssue> issues;
  Checker c(issues);
  if (config.rig_name.empty()) c.Fail("rig_name", "rig name must not be empty", "\"\"", "non-empty");
  const RigParams& rig = config.rig;
  CheckRigParams(c, rig);
  CheckGeometry(c, config);
  CheckLegControllerParams(c, config.leg_controller);
  CheckSupervisorParams(c, config.supervisor);
  if (config.profiles.empty()) {
    c.Fail("disturbance_profile", "at least one disturbance profile is required", "0 profiles", ">= 1");
  }
  std::string names;
  for (const auto& [name, profile] : config.profiles) {
    CheckDisturbanceProfile(c, profile, "disturbance_profile[name=" + name + "]");
    names += (names.empty() ? "" : ", ") + name;
  }
  if (!config.profiles.empty() && config.profiles.count(config.default_profile) == 0) {
    c.Fail("default_profile", "unknown disturbance profile requested",
           "\"" + config.default_profile + "\"", "one of the profiles defined in the file: " + names);
  }
  CheckSystemRules(c, rig, config.leg_controller, config.supervisor, config.profiles);
  const std::size_t structural = issues.size();
  if (structural == 0) {
    CheckPhysicalLimits(c, DerivePhysicalLimits(config));
  }
  std::vector<ConfigIssue> out = ToConfigIssues(issues, structural);
  // Stage 4, for a valid rig only (its ranges are judged against the rig's stroke, pressures
  // and voltages): the I/O board's calibration.
  if (out.empty() && config.board) {
    std::vector<ParamIssue> board_issues;
    Checker board(board_issues);
    CheckBoardCalibration(board, *config.board, rig);
    out = ToConfigIssues(board_issues, board_issues.size());
  }
  return out;
}

std::vector<ConfigIssue> ValidateControllerModel(const SystemConfig& config) {
  std::vector<ParamIssue> issues;
  Checker c(issues);
  const ControllerModel model = MakeControllerModel(config);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegOverride& o = config.leg_override[i];
    if (o.empty()) continue;  // the rig file's values, validated with the rig file
    const std::string leg = OverlayLegPath(i);
    const LegControllerModel& m = model.legs[i];
    // The same per-struct rules as the rig file's (param_checks.hpp), on the calibrated model.
    CheckFrictionParams(c, m.model.friction, leg + ".friction");
    CheckPolytropicSet(c, m.model.polytropic, leg + ".polytropic");
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
  // The platform with its payload: positive, and within kMin/MaxPlatformRatio of the rig file's.
  const PlatformOverride& po = config.platform_override;
  const std::string ratio_limit = FormatDouble(kMinPlatformRatio) + "-" + FormatDouble(kMaxPlatformRatio) +
                                  " x the rig file's ";
  if (po.mass_kg && c.Finite("platform.mass_kg", *po.mass_kg)) {
    const double rig_kg = config.rig.platform.mass_kg;
    if (!(*po.mass_kg >= kMinPlatformRatio * rig_kg && *po.mass_kg <= kMaxPlatformRatio * rig_kg)) {
      c.Fail("platform.mass_kg", "platform mass (with payload) is implausibly far from the rig file's",
             FormatDouble(*po.mass_kg) + " kg",
             "[" + FormatDouble(kMinPlatformRatio * rig_kg) + ", " + FormatDouble(kMaxPlatformRatio * rig_kg) +
                 "] kg (" + ratio_limit + "platform.mass_kg " + FormatDouble(rig_kg) + " kg)");
    }
  }
  if (po.inertia_diag_kg_m2 && po.inertia_diag_kg_m2->allFinite()) {
    for (int k = 0; k < 3; ++k) {
      const std::string axis = std::string(1, "xyz"[k]);
      const double v = (*po.inertia_diag_kg_m2)[k];
      const double rig_v = config.rig.platform.inertia_diag_kg_m2[k];
      if (!(v >= kMinPlatformRatio * rig_v && v <= kMaxPlatformRatio * rig_v)) {
        c.Fail("platform.inertia_diag_kg_m2." + axis,
               "platform moment of inertia (with payload) is implausibly far from the rig file's",
               FormatDouble(v) + " kg m^2",
               "[" + FormatDouble(kMinPlatformRatio * rig_v) + ", " + FormatDouble(kMaxPlatformRatio * rig_v) +
                   "] kg m^2 (" + ratio_limit + "platform.inertia_diag_kg_m2." + axis + ")");
      }
    }
  }
  // The calibrated geometry must still be a proper 6-6 platform with home inside the stroke.
  SystemConfig calibrated = config;
  calibrated.rig.geometry = model.geometry;
  std::vector<ParamIssue> geometry_issues;
  Checker g(geometry_issues);
  CheckGeometry(g, calibrated);
  for (ParamIssue& issue : geometry_issues) {
    issue.field = ToOverlayPath(issue.field);
    issue.message += " (with the overlay's calibrated joints)";
    issues.push_back(std::move(issue));
  }
  return ToConfigIssues(issues, issues.size());
}

std::vector<PhysicalLimit> DerivePhysicalLimits(const SystemConfig& config) {
  std::vector<PhysicalLimit> limits = DerivePlantLimits(config.rig, config.profiles);
  for (PhysicalLimit& l : DeriveControllerLimits(config.rig, config.leg_controller)) {
    limits.push_back(std::move(l));
  }
  return limits;
}

}  // namespace hexa::config
