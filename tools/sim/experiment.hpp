// hexa_sim --experiment identify: the identification experiment (docs/identification.md) in
// the in-process lockstep simulation (the DDS session's protocol and numbers, no processes),
// recorded to an MCAP file with the channels the recorder writes for a DDS session
// (hexa_LegSensors, hexa_ValveCommand) plus hexa_SessionInfo and, for evaluation only,
// hexa_PlantTruth. For batch studies and tests; hexa_session --experiment identify runs the
// same experiment through the system.
#pragma once

#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/lockstep_simulation.hpp"

namespace hexa::sim {

struct ExperimentOptions {
  std::vector<int> legs{1, 2, 3, 4, 5, 6};
  double per_leg_s = 30.0;
  std::string profile = "realistic";
  std::string record_path;
  std::string rig_path;
  std::string command_line;  // stored in hexa_SessionInfo
};

// Runs and records the experiment; prints progress. Returns 0 on success, 1 on a plant
// failure (message on stderr). Throws on I/O errors.
int RunIdentifyExperiment(const config::SystemConfig& config, LockstepConfig lockstep,
                          const ExperimentOptions& options);

// hexa_sim --experiment free-fall: the Appendix B free-fall bench (FreeFallBenchParams, released
// at 0.5 s, recorded for 1.5 s), recorded like the identification experiment.
int RunFreeFallExperiment(const config::SystemConfig& config, LockstepConfig lockstep,
                          const ExperimentOptions& options, double load_kg);

}  // namespace hexa::sim
