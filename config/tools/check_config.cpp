// hexa_check_config: loads a rig file, prints "OK <summary>" and exits 0, or prints every
// problem (file:line:column: error: field: message (value, limit)) to stderr and exits 1.
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"

namespace {

void PrintUsage(std::ostream& out) {
  out << "usage: hexa_check_config [--profile NAME] [--rig-overlay OVERLAY]... [--print] [FILE]\n"
         "\n"
         "Loads and validates a HexaTaar rig file (protobuf text format, schema\n"
         "proto/rig.proto, see docs/config.md).\n"
         "  FILE            rig file; default " << hexa::config::DefaultRigFile() << "\n"
         "  --profile NAME  also check that disturbance profile NAME is defined\n"
         "  --rig-overlay OVERLAY\n"
         "                  apply a rig overlay (proto/rig_overlay.proto) on top of FILE and\n"
         "                  validate the result; repeatable, applied in order\n"
         "  --print         print the loaded configuration in text format (rig file part)\n"
         "  -h, --help      this help\n"
         "Exit status: 0 valid, 1 invalid (messages on stderr), 2 usage error.\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  std::string profile;
  bool print = false;
  std::vector<std::string> overlays;
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
