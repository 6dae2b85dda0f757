// Least-squares fit of the kinematic calibration with Ceres: per leg, the base and
// platform joint positions and the potentiometer offset and gain that best explain the
// potentiometer readings at poses measured by an external instrument (the model of
// core/calibration.hpp). Not in core/: Ceres is not Eigen.
#pragma once

#include <string>
#include <vector>

#include "hexa/core/calibration.hpp"

namespace hexa::calib {

struct FitOptions {
  CalibrationIdentifiabilityLimits limits;  // refuse an unidentifiable pose set
  int max_iterations = 100;
};

struct LegFitSummary {
  bool converged = false;
  int iterations = 0;
  double initial_rms_m = 0.0;  // reading residual at the initial guess
  double final_rms_m = 0.0;    // after the fit
  std::string ceres_report;    // Ceres' one-line summary
};

struct FitResult {
  bool ok = false;                 // false: refused (message says why) or failed
  std::string message;
  IdentifiabilityReport identifiability;  // at the initial guess, with the pose set used
  IdentifiabilityReport at_solution;      // at the solution, noise = the fitted residual
  KinematicCalibration calibration{};
  LegArray<LegFitSummary> legs{};
};

// Fits from `initial` (usually the nominal geometry and ideal potentiometers). Refuses (ok
// false, nothing fitted) when the pose set is not identifiable within options.limits.
FitResult FitKinematicCalibration(const std::vector<CalibrationSample>& samples,
                                  double mid_stroke_length_m, const KinematicCalibration& initial,
                                  const FitOptions& options);

}  // namespace hexa::calib
