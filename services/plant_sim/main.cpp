// hexa_plant_sim: the simulated HexaTaar rig and clock master (docs/architecture.md).
#include <fstream>
#include <string>

#include <google/protobuf/text_format.h>

#include "hexa/recording/plant_truth.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/runtime.hpp"
#include "plant_node.hpp"

namespace {

using hexa::plant_sim::PlantNodeOptions;

// The rig's profile must exist: its name and the defined ones in the message.
bool CheckProfile(const PlantNodeOptions& o, const hexa::config::SystemConfig& config,
                  spdlog::logger& log) {
  if (config.profiles.count(o.profile) != 0) return true;
  std::string names;
  for (const auto& [name, p] : config.profiles) names += " " + name;
  log.error("--profile '{}' is not defined in {} (defined:{})", o.profile, o.common.rig_path, names);
  return false;
}

// --truth-out: the simulated rig's true parameters (evaluation only); -1 on success.
int WriteTruth(const PlantNodeOptions& o, const hexa::plant_sim::PlantNode& node,
               const hexa::config::SystemConfig& config, spdlog::logger& log) {
  if (node.simulation() == nullptr) {
    log.error("--truth-out: the device is a remote board: this process simulates nothing");
    return hexa::exit_code::kUsage;
  }
  std::string text;
  google::protobuf::TextFormat::PrintToString(
      hexa::recorder::MakePlantTruth(*node.simulation(), config.rig_name, o.profile), &text);
  std::ofstream out(o.truth_out_path);
  out << text;
  if (!out) {
    log.error("cannot write --truth-out {}", o.truth_out_path);
    return hexa::exit_code::kRunError;
  }
  log.info("true plant parameters written to {} (evaluation only)", o.truth_out_path);
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  PlantNodeOptions options;
  if (const int rc = hexa::plant_sim::ParseOptions(argc, argv, options); rc >= 0) return rc;
  // The plant simulates the rig file and its profile; overlays configure the controllers and
  // the supervisor (docs/config.md, "Rig overlays").
  hexa::node::CommonOptions common = options.common;
  common.rig_overlays.clear();
  return hexa::services::RunControlService(
      {"plant", hexa::plant_sim::kRealtimePriority}, common,
      [&](const hexa::config::SystemConfig& config, std::shared_ptr<spdlog::logger> log) {
        for (const auto& overlay : options.common.rig_overlays)
          log->info("rig overlay {} not applied to the plant: it simulates the rig file and "
                    "profile '{}' (overlays configure the controllers and the supervisor)",
                    overlay, options.profile);
        if (!CheckProfile(options, config, *log)) return hexa::exit_code::kRunError;
        hexa::plant_sim::PlantNode node(options, config, log);
        if (!options.truth_out_path.empty())
          if (const int rc = WriteTruth(options, node, config, *log); rc >= 0) return rc;
        return node.Run();
      });
}
