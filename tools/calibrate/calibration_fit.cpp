#include "calibration_fit.hpp"

#include <cmath>

#include <ceres/ceres.h>

namespace hexa::calib {
namespace {

// One reading of one leg at one measured pose: r = reading - model(parameters), with the
// analytic gradient of core/calibration (the same model the identifiability check uses).
class ReadingResidual final : public ceres::SizedCostFunction<1, kCalibrationParamsPerLeg> {
 public:
  ReadingResidual(const Pose& pose, double reading_m, double mid_m)
      : pose_(pose), reading_m_(reading_m), mid_m_(mid_m) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const LegCalibration leg = LegCalibration::FromVector(
        Eigen::Map<const LegCalibrationVector>(parameters[0]));
    LegCalibrationVector gradient;
    residuals[0] = reading_m_ - PredictedReadingM(leg, pose_, mid_m_, &gradient);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      for (int k = 0; k < kCalibrationParamsPerLeg; ++k) jacobians[0][k] = -gradient[k];
    }
    return std::isfinite(residuals[0]);
  }

 private:
  Pose pose_;
  double reading_m_;
  double mid_m_;
};

double RmsResidual(const std::vector<CalibrationSample>& samples, const LegCalibration& leg,
                   std::size_t i, double mid_m) {
  double sum = 0.0;
  for (const auto& s : samples) {
    const double r = s.reading_m[i] - PredictedReadingM(leg, s.pose, mid_m);
    sum += r * r;
  }
  return samples.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(samples.size()));
}

}  // namespace

FitResult FitKinematicCalibration(const std::vector<CalibrationSample>& samples,
                                  double mid_stroke_length_m, const KinematicCalibration& initial,
                                  const FitOptions& options) {
  FitResult result;
  result.calibration = initial;
  std::vector<Pose> poses;
  for (const auto& s : samples) poses.push_back(s.pose);
  result.identifiability =
      AnalyseIdentifiability(initial, mid_stroke_length_m, poses, options.limits);
  if (!result.identifiability.identifiable) {
    result.message = "refused: the pose set is not identifiable: " +
                     result.identifiability.message;
    return result;
  }
  result.ok = true;
  double worst_rms = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegCalibrationVector theta = initial[i].AsVector();
    ceres::Problem problem;
    for (const auto& s : samples) {
      problem.AddResidualBlock(new ReadingResidual(s.pose, s.reading_m[i], mid_stroke_length_m),
                               nullptr, theta.data());
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = options.max_iterations;
    solver.function_tolerance = 1e-16;
    solver.gradient_tolerance = 1e-20;
    solver.parameter_tolerance = 1e-14;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    LegFitSummary& leg = result.legs[i];
    leg.initial_rms_m = RmsResidual(samples, initial[i], i, mid_stroke_length_m);
    ceres::Solve(solver, &problem, &summary);
    leg.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
    leg.iterations = static_cast<int>(summary.iterations.size());
    leg.ceres_report = summary.BriefReport();
    result.calibration[i] = LegCalibration::FromVector(theta);
    leg.final_rms_m = RmsResidual(samples, result.calibration[i], i, mid_stroke_length_m);
    worst_rms = std::max(worst_rms, leg.final_rms_m);
    if (!leg.converged && result.ok) {
      result.ok = false;
      result.message = "leg " + std::to_string(i + 1) + ": the fit did not converge: " +
                       leg.ceres_report;
    }
  }
  // Uncertainty at the solution, with the residual as the measured noise level.
  CalibrationIdentifiabilityLimits at = options.limits;
  at.reading_noise_m = std::max(worst_rms, 1e-12);
  result.at_solution = AnalyseIdentifiability(result.calibration, mid_stroke_length_m, poses, at);
  if (result.ok) result.message = "fitted";
  return result;
}

}  // namespace hexa::calib
