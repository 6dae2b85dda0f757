// Rig file (protobuf text format, schema proto/rig.proto) -> validated core parameters.
//
// The loader is an edge of the system (docs/style.md rule 5): bad user input gives a message
// naming the file, the line, the field path, the value and the limit, e.g.
//   hexataar_r.textproto:41:3: error: cylinder.annulus_area_m2: annulus area must be
//   smaller than the cap area: value 0.00035, limit < 0.00031416 (cylinder.cap_area_m2)
// The status version never throws; LoadSystemConfigOrThrow wraps it for start-up code.
// Nothing here is meant for the 1 ms cycle: load once, then hand the structs to the core.
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexa/core/board_calibration.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/controller_model.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/physical_limits.hpp"
#include "hexa/core/rig.hpp"

namespace hexa::config {

// ---- Rig overlays (proto/rig_overlay.proto, docs/config.md "Rig overlays") ----------------
// Per-leg corrections of what the controllers and the supervisor believe; an absent value
// leaves the rig file's (or an earlier overlay's).
struct FrictionDirectionOverride {
  std::optional<double> stribeck_velocity_m_s, viscous_n_s_m, static_n, coulomb_n;
};
struct PolytropicOverride {
  std::optional<double> inflow, outflow, volume;  // gamma_i, gamma_o, gamma_k
};
struct LegOverride {
  FrictionDirectionOverride friction_extend, friction_retract;
  PolytropicOverride polytropic_extend, polytropic_retract;
  std::optional<double> discharge_coefficient;
  std::optional<double> effective_mass_kg;  // leg_controller.bssmc
  std::optional<double> gravity_load_n;     // leg_controller.bssmc
  std::optional<Eigen::Vector3d> p_BA_B_m;  // kinematic calibration
  std::optional<Eigen::Vector3d> p_PB_P_m;
  std::optional<double> potentiometer_offset_m;
  std::optional<double> potentiometer_gain;
  bool empty() const;
  // Fields written in `later` replace this one's.
  void MergeFrom(const LegOverride& later);
};
// The platform's mass and inertia with its payload (whole platform, not per leg).
struct PlatformOverride {
  std::optional<double> mass_kg;
  std::optional<Eigen::Vector3d> inertia_diag_kg_m2;
  bool empty() const { return !mass_kg && !inertia_diag_kg_m2; }
  void MergeFrom(const PlatformOverride& later);
};
struct OverlayProvenance {
  std::string source_recording, method, date, tool, note;
};
// One overlay file.
struct RigOverlay {
  std::string rig_name;  // must equal the rig file's
  OverlayProvenance provenance;
  LegArray<LegOverride> leg{};  // index = leg id - 1
  PlatformOverride platform;
  std::string source_path;      // file it was loaded from ("" if built in code)
};

// Everything one rig file describes (+ the overlays applied to it).
struct SystemConfig {
  std::string rig_name;
  hexa::RigParams rig;
  hexa::LegControllerParams leg_controller;
  hexa::SupervisorParams supervisor;
  std::map<std::string, hexa::DisturbanceProfile> profiles;  // by name
  std::string default_profile;  // the profile used when none is requested; in `profiles`
  std::string source_path;      // file it was loaded from (empty if built in code)
  // Rig overlays applied, in order, and their merged per-leg corrections. The controllers
  // and the supervisor see rig + leg_override (MakeControllerModel); the plant never does.
  std::vector<RigOverlay> overlays;
  LegArray<LegOverride> leg_override{};
  PlatformOverride platform_override;
  // The remote I/O board's calibration (the file's optional `board` block; absent: a rig the
  // simulator drives only).
  std::optional<hexa::BoardCalibration> board;
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
  bool physical_limit = false;  // a limit derived from physics (DerivePhysicalLimits)
  // "<file>:<line>:<column>: error: <field>: <message>: value <value>, limit <limit>"
  std::string ToString() const;
};

struct ConfigResult {
  bool ok = false;
  // Filled when ok, and when the file parsed and translated but broke value rules
  // (`translated`): --explain shows the physical limits of such a config.
  SystemConfig config;
  bool translated = false;
  std::string error;                 // every issue, one per line ("" when ok)
  std::vector<ConfigIssue> issues;   // the same, structured
};

// Reads, parses and validates a rig file. Never throws.
ConfigResult LoadSystemConfig(const std::string& path);
// Same, then applies each overlay file in order (later ones win, field by field) and
// validates the result with the rig file's rules; messages name the overlay file and line.
ConfigResult LoadSystemConfig(const std::string& path, const std::vector<std::string>& overlay_paths);
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

// The limits derived from physics for this config (plant and controller, physical_limits.hpp),
// each with value, limit and reason: what `hexa_check_config --explain` prints. Meaningful for
// a config whose structs are valid (ValidateSystemConfig reports them only then).
std::vector<hexa::PhysicalLimit> DerivePhysicalLimits(const SystemConfig& config);

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

// One line for logs: rig name, legs, home leg length, stroke, supply, profiles (+ overlays).
std::string Summary(const SystemConfig& config);

// ---- Rig overlays ---------------------------------------------------------------------------
struct OverlayResult {
  bool ok = false;
  RigOverlay overlay;
  std::string error;
  std::vector<ConfigIssue> issues;
};
// Parses an overlay on its own: syntax, required rig_name and provenance, leg ids 1..6 at most
// once, complete 3-vectors, finite values. Never throws.
OverlayResult ParseRigOverlay(const std::string& text, const std::string& display_name);
OverlayResult LoadRigOverlay(const std::string& path);
// Applies a parsed overlay to `config` (the rig name must match) and validates the per-leg
// result with the rig file's rules (ValidateControllerModel). `text` is the overlay's text
// when known, so that issues carry its lines; "" leaves them at 0. Never throws.
ConfigResult ApplyRigOverlay(const SystemConfig& config, const RigOverlay& overlay,
                             const std::string& text = "");
// The merged per-leg view checked with the rig file's value rules; field paths are those of
// an overlay file ("leg[leg_id=2].friction.extend.static_n"). Never throws.
std::vector<ConfigIssue> ValidateControllerModel(const SystemConfig& config);
// The overlay in its text format (ParseRigOverlay reads it back to an equal overlay).
std::string ToTextFormat(const RigOverlay& overlay);

// What the controllers and the supervisor run with: rig file + overlays (per-leg models,
// calibrated joints, the platform's mass and inertia).
hexa::ControllerModel MakeControllerModel(const SystemConfig& config);
// Leg `leg_id` (1..6)'s controller configuration (its own model, gains, calibration).
hexa::LegControllerConfig MakeLegControllerConfig(const SystemConfig& config, int leg_id,
                                                  hexa::LegControllerKind kind);
// The rig as the supervisor sees it (calibrated joint positions, the overlays' platform mass
// and inertia; the rest of the rig file).
hexa::RigParams MakeSupervisorRig(const SystemConfig& config);

}  // namespace hexa::config
