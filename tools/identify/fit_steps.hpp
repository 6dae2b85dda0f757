// hexa_identify's steps (main.cpp runs them in order): the legs' loads from the platform's
// inverse dynamics, the fits of one leg and stroke direction, the free-fall evaluation.
#pragma once

#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/controller_model.hpp"
#include "hexa/core/offline_differentiator.hpp"
#include "hexa/core/pneumatic_identification.hpp"
#include "recording_input.hpp"
#include "report.hpp"

namespace hexa::identify {

constexpr double kTickS = 0.001;  // the recordings' control period

// The axial force each leg must exert for its recorded motion (platform inverse dynamics with
// the rig file's geometry and masses), as the fixed and the payload-scaled parts of the force
// and of the mass the leg moves; `accel` is each leg's D[D[l]] with `diff`.
LegArray<LoadSeries> ComputeLegLoads(const IdentificationRecording& rec, const ControllerModel& model,
                                     const config::SystemConfig& cfg, const IdentificationConfig& ic,
                                     const OfflineGaussianDifferentiator& diff,
                                     const LegArray<std::vector<double>>& accel);

// Least squares and / or the GA (report.ga_params, report.ga_space) on one leg and stroke
// direction (dir 0 extend, 1 retract), started from the rig file's values; prints progress.
// `d` is bound to report.payload_scale first.
StrokeReport FitStroke(StrokeDataset& d, int leg, int dir, const config::SystemConfig& cfg, const Report& report,
                       bool run_lsq, bool run_ga, double flat);

// Appendix B's free-fall fit (eq 67, 72) of each of `legs` in the free-fall recording `path`,
// appended to report.free_fall. Throws IdentificationInputError on a recording that does not fit.
void EvaluateFreeFall(const std::string& path, const config::SystemConfig& cfg, const std::vector<int>& legs,
                      Report& report);

}  // namespace hexa::identify
