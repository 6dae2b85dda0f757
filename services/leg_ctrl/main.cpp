// hexa_leg_ctrl: the position controller of one leg (BS-SMC, Sec. 3.2, or the PI baseline).
#include "hexa/services/runtime.hpp"
#include "leg_node.hpp"

int main(int argc, char** argv) {
  hexa::leg_ctrl::LegNodeOptions options;
  if (const int rc = hexa::leg_ctrl::ParseOptions(argc, argv, options); rc >= 0) return rc;
  return hexa::services::RunControlService(
      {hexa::leg_ctrl::NodeName(options), hexa::leg_ctrl::kRealtimePriority}, options.common,
      [&](const hexa::config::SystemConfig& config, std::shared_ptr<spdlog::logger> log) {
        return hexa::leg_ctrl::LegNode(options, config, std::move(log)).Run();
      });
}
