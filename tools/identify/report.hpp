// hexa_identify's results: per leg and direction the nominal, GA and least-squares
// parameters with their objective, wall time and curvature; the overlay built from them; the
// Table 8 style markdown, a JSON file for the docs generator, and CSV data for the plots.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/free_fall.hpp"
#include "hexa/core/genetic_algorithm.hpp"
#include "hexa/core/pneumatic_identification.hpp"
#include "identification.pb.h"

namespace hexa::identify {

struct StrokeReport {
  int leg = 1;
  Stroke stroke = Stroke::kExtend;
  std::size_t samples = 0;
  StrokeParams nominal;
  double nominal_objective = 0.0;
  std::optional<StrokeParams> lsq, ga;
  double lsq_objective = 0.0, ga_objective = 0.0;          // Z of eq 13
  double lsq_fit_objective = 0.0, ga_fit_objective = 0.0;  // what the fits minimise
  double lsq_wall_s = 0.0, ga_wall_s = 0.0;
  int lsq_iterations = 0, ga_iterations = 0;
  bool lsq_converged = false;
  std::uint64_t ga_evaluations = 0;
  std::vector<double> ga_history;
  CurvatureReport lsq_curvature, ga_curvature;
};

// Appendix B free fall of one leg (eq 67, 72), from a free-fall recording.
struct FreeFallLeg {
  int leg = 1;
  FreeFallFit fit;
  std::size_t samples = 0;
  double fall_m = 0.0;
  double duration_s = 0.0;
};

struct Report {
  std::string recording, rig_file, method, overlay_path, overlay_error;
  bool overlay_refused = false;
  IdentificationConfig config;
  GaParams ga_params;
  int threads = 2;
  double flat_threshold = 1e-3;
  // How the GA's genes map to the parameters (--ga-space: around-nominal, wide) and the
  // factor of around-nominal (--ga-range-factor).
  std::string ga_space = "wide";
  double ga_range_factor = 2.0;
  double pressure_noise_pa = 0.0;  // compensated in the pressure channels
  double payload_scale = 1.0;
  bool payload_estimated = false;
  std::map<int, double> payload_per_leg;
  std::optional<rec::PlantTruth> truth;
  std::vector<StrokeReport> strokes;
  std::string free_fall_recording;  // empty: no free-fall experiment given
  double free_fall_mass_kg = 0.0;
  std::vector<FreeFallLeg> free_fall;
};

// The true Table 8 parameters of a leg and direction from the evaluation channel.
std::optional<StrokeParams> TrueStroke(const rec::PlantTruth& truth, int leg, Stroke stroke);

// The static force along each leg at the home pose (platform at rest) for a payload scale:
// the BS-SMC's gravity load (leg_controller.bssmc.gravity_load_n) with the rig file's
// geometry and masses, the platform's scaled.
LegArray<double> HomeGravityLoadN(const config::SystemConfig& cfg, double payload_scale);
// Overlay with the identifiable parameters of the GA (from_ga) or least-squares fit, and
// the gravity load of the estimated payload when `with_gravity_load`.
config::RigOverlay MakeOverlay(const Report& report, const config::SystemConfig& cfg, bool from_ga,
                               bool with_gravity_load);
// Overlay with the plant's true friction and polytropic coefficients and the gravity load of
// its true payload (closed-loop reference).
config::RigOverlay MakeTruthOverlay(const rec::PlantTruth& truth, const config::SystemConfig& cfg,
                                    bool with_gravity_load);

// Checks `overlay` as a service loading it next to the rig file would (its text parsed back,
// then applied to `cfg` with the rig file's value rules) and writes it to `path`, after the
// comment line `header`, only when it passes. Returns "" when written; otherwise the
// validator's messages (field, value, limit), and `path` does not exist afterwards: values
// outside the rig file's limits are refused, never written. Never throws.
std::string WriteValidatedOverlay(const config::RigOverlay& overlay, const config::SystemConfig& cfg,
                                  const std::string& path, const std::string& header);

// identification.md, identification.json, predictions_leg<L>_<dir>.csv, ga_history.csv.
void WriteReport(const Report& report, const std::map<int, std::array<StrokeDataset, 2>>& data,
                 const std::string& out_dir);

}  // namespace hexa::identify
