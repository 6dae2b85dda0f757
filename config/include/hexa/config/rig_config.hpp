// Rig file (protobuf text format, schema proto/rig.proto) -> validated core parameters.
//
// The loader is an edge of the system (STYLE.md rule 5): bad user input gives a message
// naming the file, the line, the field path, the value and the limit, e.g.
//   hexataar_r.textproto:41:3: error: cylinder.annulus_area_m2: annulus area must be
//   smaller than the cap area: value 0.00035, limit < 0.00031416 (cylinder.cap_area_m2)
// The status version never throws; LoadSystemConfigOrThrow wraps it for start-up code.
// Nothing here is meant for the 1 ms cycle: load once, then hand the structs to the core.
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "hexa/core/control_params.hpp"
#include "hexa/core/rig.hpp"

namespace hexa::config {

// Everything one rig file describes.
struct SystemConfig {
  std::string rig_name;
  hexa::RigParams rig;
  hexa::LegControllerParams leg_controller;
  hexa::SupervisorParams supervisor;
  std::map<std::string, hexa::DisturbanceProfile> profiles;  // by name
  std::string default_profile;  // the profile used when none is requested; in `profiles`
  std::string source_path;      // file it was loaded from (empty if built in code)
};

// One problem found in a file. `line`/`column` are 1-based; 0 when not known (a config
// built in code, or a requested profile that is not in the file).
struct ConfigIssue {
  std::string file;
  int line = 0;
  int column = 0;
  std::string field;    // path in the file, e.g. "cylinder.cap_area_m2", "geometry.leg[2]"
  std::string message;  // what is wrong
  std::string value;    // offending value as text ("" for syntax errors)
  std::string limit;    // the rule it broke, e.g. "> 0", "< 0.00031416 (cylinder.cap_area_m2)"
  // "<file>:<line>:<column>: error: <field>: <message>: value <value>, limit <limit>"
  std::string ToString() const;
};

struct ConfigResult {
  bool ok = false;
  SystemConfig config;               // filled only when ok
  std::string error;                 // every issue, one per line ("" when ok)
  std::vector<ConfigIssue> issues;   // the same, structured
};

// Reads, parses and validates a rig file. Never throws.
ConfigResult LoadSystemConfig(const std::string& path);
// Same, from text already in memory; `display_name` is used as the file name in messages.
ConfigResult ParseSystemConfig(const std::string& text, const std::string& display_name);

class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& what) : std::runtime_error(what) {}
};
// Throws ConfigError carrying ConfigResult::error.
SystemConfig LoadSystemConfigOrThrow(const std::string& path);

// Absolute path of the shipped reference rig file (deploy/rigs/hexataar_r.textproto).
std::string DefaultRigFile();

// Checks the values of a config (also one built in code). Field paths are those of the
// rig file; lines are left 0. Used by the loader after translation. Never throws.
std::vector<ConfigIssue> ValidateSystemConfig(const SystemConfig& config);

// Picks a disturbance profile: `name` empty -> config.default_profile. An unknown name is
// an error that lists the profiles the file defines.
struct ProfileResult {
  bool ok = false;
  std::string name;
  hexa::DisturbanceProfile profile;
  std::string error;
};
ProfileResult SelectProfile(const SystemConfig& config, const std::string& name);

// The config in the rig file's text format (loads back to an equal config); handy for
// storing the configuration a session ran with.
std::string ToTextFormat(const SystemConfig& config);

// One line for logs: rig name, legs, home leg length, stroke, supply, profiles.
std::string Summary(const SystemConfig& config);

}  // namespace hexa::config
