// Rig file loader: protobuf text format -> hexa::config::SystemConfig.
//
// Stages, each stopping at its first failing stage so that messages stay about the cause:
//   1. parse (syntax, unknown fields, repeated singular fields): the parser's line/column;
//   2. presence and finiteness of every field (reflection over the schema), with the line
//      of the field (non-finite) or of its enclosing block (missing);
//   3. structure: six legs with ids 1..6, unique profile names;
//   4. translation into the core structs (rig_proto.cpp) and value rules (validate.cpp);
//      each rule names a field path that is mapped back to its line through the parser's
//      ParseInfoTree.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "hexa/config/rig_config.hpp"
#include "bounded_file.hpp"
#include "internal.hpp"
#include "rig.pb.h"
#include "rig_proto.hpp"
#include "hexa/config/text_format.hpp"

namespace hexa::config {

namespace gp = google::protobuf;
using text_format::CountLines;
using text_format::ElementSelector;
using internal::FormatDouble;
using text_format::FromRange;
using text_format::Locate;
using text_format::Location;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

std::string ConfigIssue::ToString() const {
  std::ostringstream out;
  out << file << ":" << line << ":" << column << ": error: ";
  if (!field.empty()) out << field << ": ";
  out << message;
  if (!value.empty() || !limit.empty()) {
    out << " (";
    if (!value.empty()) out << "value " << value;
    if (!value.empty() && !limit.empty()) out << ", ";
    if (!limit.empty()) out << "limit " << limit;
    out << ")";
  }
  return out.str();
}

std::string DefaultRigFile() { return HEXA_DEFAULT_RIG_FILE; }

namespace {

// Blocks a rig file may leave out (their defaults apply): the board wiring, the coupled leg
// feedback (off).
const std::vector<std::string> kOptionalBlocks = {"board", "leg_controller.coupled_legs"};

// Six `leg` elements with ids 1..6 once each in the top-level block `block` (geometry, board).
void CheckSixLegIds(const pb::RigFile& f, const ParseInfoTree& tree, const std::string& file, const std::string& block,
                    const std::string& what, std::vector<ConfigIssue>& issues) {
  const gp::FieldDescriptor* block_fd = pb::RigFile::descriptor()->FindFieldByName(block);
  const gp::Message& msg = f.GetReflection()->GetMessage(f, block_fd);
  const gp::FieldDescriptor* leg_fd = msg.GetDescriptor()->FindFieldByName("leg");
  const gp::Reflection* r = msg.GetReflection();
  const Location block_loc = FromRange(tree.GetLocationRange(block_fd, -1));
  const ParseInfoTree* block_tree = tree.GetTreeForNested(block_fd, -1);
  const int legs = r->FieldSize(msg, leg_fd);
  if (legs != static_cast<int>(kNumLegs)) {
    issues.push_back({file, block_loc.line, block_loc.column, block + ".leg", what, std::to_string(legs) + " legs",
                      "exactly 6"});
  }
  std::map<int, int> first_line_of_id;
  for (int k = 0; k < legs; ++k) {
    const gp::Message& leg = r->GetRepeatedMessage(msg, leg_fd, k);
    const gp::FieldDescriptor* id_fd = leg.GetDescriptor()->FindFieldByName("id");
    const int id = leg.GetReflection()->GetInt32(leg, id_fd);
    const ParseInfoTree* leg_tree = block_tree ? block_tree->GetTreeForNested(leg_fd, k) : nullptr;
    const Location loc = leg_tree ? FromRange(leg_tree->GetLocationRange(id_fd, -1)) : block_loc;
    const std::string path = block + ".leg[" + std::to_string(k) + "].id";
    if (id < 1 || id > static_cast<int>(kNumLegs)) {
      issues.push_back({file, loc.line, loc.column, path, "leg id out of range", std::to_string(id), "[1, 6]"});
    } else if (const auto it = first_line_of_id.find(id); it != first_line_of_id.end()) {
      issues.push_back({file, loc.line, loc.column, path,
                        "leg " + std::to_string(id) + " is defined twice (first at line " +
                            std::to_string(it->second) + ")",
                        std::to_string(id), "each id 1..6 exactly once"});
    } else {
      first_line_of_id[id] = loc.line;
    }
  }
}

// Stage 3: six legs with ids 1..6 once each (geometry, board); profile names non-empty and
// unique.
void CheckStructure(const pb::RigFile& f, const ParseInfoTree& tree, const std::string& file, int eof_line,
                    std::vector<ConfigIssue>& issues) {
  CheckSixLegIds(f, tree, file, "geometry", "a 6-6 platform needs exactly six legs", issues);
  if (f.has_board()) CheckSixLegIds(f, tree, file, "board", "the board serves exactly six legs", issues);

  const gp::FieldDescriptor* profile_fd = pb::RigFile::descriptor()->FindFieldByName("disturbance_profile");
  const gp::FieldDescriptor* name_fd = pb::DisturbanceProfileConfig::descriptor()->FindFieldByName("name");
  if (f.disturbance_profile_size() == 0) {
    issues.push_back({file, eof_line, 1, "disturbance_profile", "at least one disturbance profile is required",
                      "0 profiles", ">= 1"});
  }
  std::map<std::string, int> first_line_of_name;
  for (int k = 0; k < f.disturbance_profile_size(); ++k) {
    const std::string& name = f.disturbance_profile(k).name();
    const ParseInfoTree* profile_tree = tree.GetTreeForNested(profile_fd, k);
    const Location loc = profile_tree ? FromRange(profile_tree->GetLocationRange(name_fd, -1))
                                      : FromRange(tree.GetLocationRange(profile_fd, k));
    const std::string path = "disturbance_profile[" + std::to_string(k) + "].name";
    if (name.empty()) {
      issues.push_back({file, loc.line, loc.column, path, "profile name must not be empty", "\"\"", "non-empty"});
    } else if (const auto it = first_line_of_name.find(name); it != first_line_of_name.end()) {
      issues.push_back({file, loc.line, loc.column, path,
                        "disturbance profile '" + name + "' is defined twice (first at line " +
                            std::to_string(it->second) + ")",
                        "\"" + name + "\"", "unique profile names"});
    } else {
      first_line_of_name[name] = loc.line;
    }
  }
}

std::string JoinIssues(const std::vector<ConfigIssue>& issues) {
  std::string out;
  for (const ConfigIssue& issue : issues) out += (out.empty() ? "" : "\n") + issue.ToString();
  return out;
}

ConfigResult Fail(std::vector<ConfigIssue> issues) {
  ConfigResult result;
  result.ok = false;
  result.error = JoinIssues(issues);
  result.issues = std::move(issues);
  return result;
}

}  // namespace

ConfigResult ParseSystemConfig(const std::string& text, const std::string& display_name) {
  try {
    pb::RigFile file;
    ParseInfoTree tree;
    std::vector<ConfigIssue> issues;
    if (!text_format::ParseTextFormat(text, display_name, file, tree, issues)) return Fail(std::move(issues));
    const int eof_line = CountLines(text);

    text_format::CheckEveryFieldWritten(file, tree, display_name, eof_line, kOptionalBlocks, issues);
    if (!issues.empty()) return Fail(std::move(issues));

    CheckStructure(file, tree, display_name, eof_line, issues);
    if (!issues.empty()) return Fail(std::move(issues));

    SystemConfig config = internal::FromRigFile(file);
    config.source_path = display_name;
    issues = ValidateSystemConfig(config);
    for (ConfigIssue& issue : issues) {
      issue.file = display_name;
      const Location loc = Locate(file, tree, issue.field);
      issue.line = loc.line > 0 ? loc.line : 1;
      issue.column = loc.line > 0 ? loc.column : 1;
    }
    if (!issues.empty()) {
      ConfigResult failed = Fail(std::move(issues));
      failed.config = std::move(config);
      failed.translated = true;
      return failed;
    }

    ConfigResult result;
    result.ok = true;
    result.translated = true;
    result.config = std::move(config);
    return result;
  } catch (const std::exception& e) {  // e.g. std::bad_alloc; the status API never throws
    return Fail({{display_name, 0, 0, "", std::string("internal error while loading: ") + e.what(), "", ""}});
  }
}

ConfigResult LoadSystemConfig(const std::string& path) {
  std::string text, error;
  if (!internal::ReadBoundedFile(path, "rig file", internal::kMaxRigFileBytes, text, error))
    return Fail({{path, 0, 0, "", error, "", ""}});
  return ParseSystemConfig(text, path);
}

SystemConfig LoadSystemConfigOrThrow(const std::string& path) {
  ConfigResult result = LoadSystemConfig(path);
  if (!result.ok) throw ConfigError(result.error);
  return std::move(result.config);
}

ProfileResult SelectProfile(const SystemConfig& config, const std::string& name) {
  ProfileResult result;
  result.name = name.empty() ? config.default_profile : name;
  const auto it = config.profiles.find(result.name);
  if (it != config.profiles.end()) {
    result.ok = true;
    result.profile = it->second;
    return result;
  }
  std::string names;
  for (const auto& [known, profile] : config.profiles) names += (names.empty() ? "" : ", ") + known;
  ConfigIssue issue;
  issue.file = config.source_path.empty() ? "<config>" : config.source_path;
  issue.field = "disturbance_profile";
  issue.message = "unknown disturbance profile requested";
  issue.value = "\"" + result.name + "\"";
  issue.limit = "one of the profiles defined in the file: " + names;
  result.error = issue.ToString();
  return result;
}

std::string ToTextFormat(const SystemConfig& c) {
  std::string text;
  gp::TextFormat::Printer printer;
  printer.PrintToString(internal::ToRigFile(c), &text);
  return text;
}

std::string Summary(const SystemConfig& c) {
  const internal::HomeGeometry home = internal::ComputeHomeGeometry(c.rig.geometry);
  const auto [lo, hi] = std::minmax_element(home.length_m.begin(), home.length_m.end());
  std::ostringstream out;
  out.precision(6);
  out << c.rig_name << ": " << kNumLegs << " legs, home leg length " << *lo;
  if (*hi - *lo > 1e-7) out << ".." << *hi;
  out << " m (mid-stroke " << c.rig.cylinder.mid_stroke_length_m << " m, stroke " << c.rig.cylinder.stroke_m
      << " m), home Jacobian condition " << home.jacobian_condition << ", supply " << c.rig.air.supply_pressure_pa
      << " Pa, platform " << c.rig.platform.mass_kg << " kg, profiles {";
  bool first = true;
  for (const auto& [name, profile] : c.profiles) {
    out << (first ? "" : ", ") << name;
    first = false;
  }
  out << "}, default " << c.default_profile;
  if (c.board) {
    out << ", I/O board " << c.board->adc_bits << "-bit ADC / " << c.board->dac_bits << "-bit DAC, watchdog "
        << c.board->watchdog_timeout_s << " s";
  }
  for (const RigOverlay& o : c.overlays) {
    int legs = 0;
    for (const LegOverride& l : o.leg) legs += l.empty() ? 0 : 1;
    out << "; overlay " << o.source_path << " (" << legs << " legs, ";
    if (o.platform.mass_kg) out << "platform " << *o.platform.mass_kg << " kg, ";
    out << o.provenance.method << ", " << o.provenance.date << ")";
  }
  return out.str();
}

}  // namespace hexa::config
