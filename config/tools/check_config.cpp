// hexa_check_config: loads a rig file, prints "OK <summary>" and exits 0, or prints every
// problem (file:line:column: error: field: message (value, limit)) to stderr and exits 1.
// --explain also prints the limits derived from physics, with the rig's values and reasons.
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"

namespace {

void PrintUsage(std::ostream& out) {
  out << "usage: hexa_check_config [--profile NAME] [--rig-overlay OVERLAY]... [--print] [--explain]\n"
         "                         [FILE]\n"
         "\n"
         "Loads and validates a HexaTaar rig file (protobuf text format, schema\n"
         "proto/rig.proto, see docs/config.md).\n"
         "  FILE            rig file; default " << hexa::config::DefaultRigFile() << "\n"
         "  --profile NAME  also check that disturbance profile NAME is defined\n"
         "  --rig-overlay OVERLAY\n"
         "                  apply a rig overlay (proto/rig_overlay.proto) on top of FILE and\n"
         "                  validate the result; repeatable, applied in order\n"
         "  --print         print the loaded configuration in text format (rig file part)\n"
         "  --explain       print the limits derived from physics (supply pressure, masses,\n"
         "                  time constants against the 1 ms tick, gains against the valves),\n"
         "                  each with this rig's value, the limit and the reason\n"
         "  -h, --help      this help\n"
         "Exit status: 0 valid, 1 invalid (messages on stderr), 2 usage error.\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  std::string profile;
  bool print = false;
  std::vector<std::string> overlays;
  bool explain = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      PrintUsage(std::cout);
      return 0;
    } else if (arg == "--profile" && i + 1 < argc) {
      profile = argv[++i];
    } else if (arg == "--rig-overlay" && i + 1 < argc) {
      overlays.push_back(argv[++i]);
    } else if (arg == "--print") {
      print = true;
    } else if (arg == "--explain") {
      explain = true;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "hexa_check_config: unknown option " << arg << "\n";
      PrintUsage(std::cerr);
      return 2;
    } else if (path.empty()) {
      path = arg;
    } else {
      std::cerr << "hexa_check_config: more than one file given\n";
      return 2;
    }
  }
  if (path.empty()) path = hexa::config::DefaultRigFile();

  const hexa::config::ConfigResult result = hexa::config::LoadSystemConfig(path, overlays);
  // The limits need every struct valid (they divide by areas, masses, time constants): shown
  // for a valid file and for one that breaks physical limits only.
  bool structs_valid = result.translated;
  for (const auto& issue : result.issues) structs_valid = structs_valid && issue.physical_limit;
  if (explain && structs_valid) {
    std::cout << "Physical limits of " << path << " (docs/rig_checks.md, \"Physical limits\"):\n"
              << hexa::ExplainLimits(hexa::config::DerivePhysicalLimits(result.config));
  } else if (explain) {
    std::cout << "Physical limits of " << path << ": not derived, the file has errors below\n";
  }
  if (!result.ok) {
    std::cerr << result.error << "\n";
    return 1;
  }
  if (!profile.empty()) {
    const hexa::config::ProfileResult selected = hexa::config::SelectProfile(result.config, profile);
    if (!selected.ok) {
      std::cerr << selected.error << "\n";
      return 1;
    }
  }
  if (print) std::cout << hexa::config::ToTextFormat(result.config);
  std::cout << "OK " << path << ": " << hexa::config::Summary(result.config) << "\n";
  return 0;
}
