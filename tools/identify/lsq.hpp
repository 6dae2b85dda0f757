// Gradient-based least squares on the identification objective (eq 13 residuals), with the
// Ceres solver (Debian libceres-dev): the Gauss-Newton / Levenberg-Marquardt counterpart of
// the paper's GA, started from the rig file's nominal parameters (docs/identification.md).
#pragma once

#include <array>
#include <string>

#include "hexa/core/pneumatic_identification.hpp"

namespace hexa::identify {

struct LsqResult {
  StrokeParams params;
  double objective = 0.0;   // Z of eq 13 at the solution
  double initial_objective = 0.0;
  int iterations = 0;
  bool converged = false;
  std::string summary;      // Ceres' one-line report
  double wall_s = 0.0;
};

// Minimises Z^2 of one leg and direction (the dataset's payload scale fixed), from `start`.
LsqResult FitStrokeLeastSquares(const StrokeDataset& data, const StrokeParams& start);

// Payload scale of one leg: the acceleration channel of both directions, with s and both
// directions' friction (v_s, B, F_s, F_c) free, from s = 1 and the nominal friction.
struct PayloadResult {
  double payload_scale = 1.0;
  std::array<FrictionDirectionParams, 2> friction{};
  double objective = 0.0;
  bool converged = false;
};
PayloadResult FitPayloadScale(const StrokeDataset& extend, const StrokeDataset& retract,
                              const FrictionDirectionParams& extend_start,
                              const FrictionDirectionParams& retract_start);

}  // namespace hexa::identify
