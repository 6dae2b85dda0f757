// hexa_bridge: serves a running session's DDS topics, and the 3-D scene, to Foxglove over the
// Foxglove WebSocket protocol (docs/foxglove.md; bridge_node.hpp).
#include "bridge_node.hpp"
#include "hexa/services/exit_code.hpp"

int main(int argc, char** argv) {
  hexa::bridge::BridgeOptions options;
  if (const int rc = hexa::bridge::ParseOptions(argc, argv, options); rc >= 0) return rc;
  return hexa::services::RunService(
      "bridge", options.log_file, "info", options.dds_config,
      [&](std::shared_ptr<spdlog::logger> log) {
        // Before any thread exists (Cyclone's, the WebSocket I/O thread): they inherit both.
        hexa::services::ApplyBackgroundScheduling(options.cpus, options.nice, *log);
        if (!hexa::bridge::InstallSessionKey(options, *log)) return hexa::exit_code::kUsage;
        return hexa::bridge::BridgeNode(options, std::move(log)).Run();
      });
}
