// Rig overlay loader: protobuf text format (proto/rig_overlay.proto) -> hexa::config::RigOverlay,
// merged onto a loaded rig file and validated with the rig file's rules (docs/config.md,
// "Rig overlays").
//
// Stages, each stopping at the first failing one:
//   1. parse (syntax, unknown fields): the parser's line/column, "did you mean";
//   2. structure: rig_name and provenance (method, date) written, each leg block with a
//      leg_id in 1..6 at most once, 3-vectors complete, every number finite, a platform block
//      not empty;
//   3. apply: the rig name must be the rig file's; the merged per-leg model and platform are
//      checked with the rig file's value rules (validate.cpp, ValidateControllerModel).
#include <google/protobuf/descriptor.h>
#include <google/protobuf/text_format.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "hexa/config/rig_config.hpp"
#include "bounded_file.hpp"
#include "internal.hpp"
#include "rig_overlay.pb.h"
#include "hexa/config/text_format.hpp"

namespace hexa::config {

namespace gp = google::protobuf;
using internal::FormatDouble;
using text_format::Locate;
using text_format::Location;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

// ---- LegOverride ------------------------------------------------------------------------------

namespace {

template <typename T>
void Take(std::optional<T>& into, const std::optional<T>& later) {
  if (later) into = later;
}

bool Any(const FrictionDirectionOverride& f) {
  return f.stribeck_velocity_m_s || f.viscous_n_s_m || f.static_n || f.coulomb_n;
}
bool Any(const PolytropicOverride& p) { return p.inflow || p.outflow || p.volume; }

void Merge(FrictionDirectionOverride& f, const FrictionDirectionOverride& later) {
  Take(f.stribeck_velocity_m_s, later.stribeck_velocity_m_s);
  Take(f.viscous_n_s_m, later.viscous_n_s_m);
  Take(f.static_n, later.static_n);
  Take(f.coulomb_n, later.coulomb_n);
}
void Merge(PolytropicOverride& p, const PolytropicOverride& later) {
  Take(p.inflow, later.inflow);
  Take(p.outflow, later.outflow);
  Take(p.volume, later.volume);
}

}  // namespace

bool LegOverride::empty() const {
  return !(Any(friction_extend) || Any(friction_retract) || Any(polytropic_extend) ||
           Any(polytropic_retract) || discharge_coefficient || effective_mass_kg ||
           gravity_load_n || p_BA_B_m || p_PB_P_m || potentiometer_offset_m || potentiometer_gain);
}

void LegOverride::MergeFrom(const LegOverride& later) {
  Merge(friction_extend, later.friction_extend);
  Merge(friction_retract, later.friction_retract);
  Merge(polytropic_extend, later.polytropic_extend);
  Merge(polytropic_retract, later.polytropic_retract);
  Take(discharge_coefficient, later.discharge_coefficient);
  Take(effective_mass_kg, later.effective_mass_kg);
  Take(gravity_load_n, later.gravity_load_n);
  Take(p_BA_B_m, later.p_BA_B_m);
  Take(p_PB_P_m, later.p_PB_P_m);
  Take(potentiometer_offset_m, later.potentiometer_offset_m);
  Take(potentiometer_gain, later.potentiometer_gain);
}

void PlatformOverride::MergeFrom(const PlatformOverride& later) {
  Take(mass_kg, later.mass_kg);
  Take(inertia_diag_kg_m2, later.inertia_diag_kg_m2);
}

// ---- The controllers' model -----------------------------------------------------------------

namespace {

template <typename T>
void Apply(T& value, const std::optional<T>& override_value) {
  if (override_value) value = *override_value;
}
void Apply(FrictionDirectionParams& p, const FrictionDirectionOverride& o) {
  Apply(p.stribeck_velocity_m_s, o.stribeck_velocity_m_s);
  Apply(p.viscous_n_s_m, o.viscous_n_s_m);
  Apply(p.static_n, o.static_n);
  Apply(p.coulomb_n, o.coulomb_n);
}
void Apply(PolytropicParams& p, const PolytropicOverride& o) {
  Apply(p.inflow, o.inflow);
  Apply(p.outflow, o.outflow);
  Apply(p.volume, o.volume);
}

}  // namespace

ControllerModel MakeControllerModel(const SystemConfig& config) {
  ControllerModel m = ControllerModel::FromRig(config.rig, config.leg_controller);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegOverride& o = config.leg_override[i];
    LegControllerModel& leg = m.legs[i];
    Apply(leg.model.friction.extend, o.friction_extend);
    Apply(leg.model.friction.retract, o.friction_retract);
    Apply(leg.model.polytropic.extend, o.polytropic_extend);
    Apply(leg.model.polytropic.retract, o.polytropic_retract);
    Apply(leg.model.valve.discharge_coefficient, o.discharge_coefficient);
    Apply(leg.params.bssmc.effective_mass_kg, o.effective_mass_kg);
    Apply(leg.params.bssmc.gravity_load_n, o.gravity_load_n);
    Apply(m.geometry.p_BA_B[i], o.p_BA_B_m);
    Apply(m.geometry.p_PB_P[i], o.p_PB_P_m);
    Apply(leg.potentiometer.offset_m, o.potentiometer_offset_m);
    Apply(leg.potentiometer.gain, o.potentiometer_gain);
  }
  Apply(m.platform.mass_kg, config.platform_override.mass_kg);
  Apply(m.platform.inertia_diag_kg_m2, config.platform_override.inertia_diag_kg_m2);
  return m;
}

LegControllerConfig MakeLegControllerConfig(const SystemConfig& config, int leg_id,
                                            LegControllerKind kind) {
  if (leg_id < 1 || leg_id > static_cast<int>(kNumLegs)) {
    throw std::invalid_argument("MakeLegControllerConfig: leg_id = " + std::to_string(leg_id) +
                                " outside [1, 6]");
  }
  const ControllerModel model = MakeControllerModel(config);
  const auto index = static_cast<std::size_t>(leg_id - 1);
  LegControllerConfig c = LegControllerConfig::FromModel(model, index, kind);
  AssignCouplingRow(model.SupervisorRig(config.rig), index, c);  // as LockstepSimulation does
  return c;
}

RigParams MakeSupervisorRig(const SystemConfig& config) {
  return MakeControllerModel(config).SupervisorRig(config.rig);
}

// ---- Parsing --------------------------------------------------------------------------------

namespace {

std::string LegPath(int leg_id) { return "leg[leg_id=" + std::to_string(leg_id) + "]"; }

OverlayResult FailOverlay(std::vector<ConfigIssue> issues) {
  OverlayResult r;
  for (const ConfigIssue& i : issues) r.error += (r.error.empty() ? "" : "\n") + i.ToString();
  r.issues = std::move(issues);
  return r;
}

// Every floating-point value finite (reflection; positions from the parse tree).
void CheckFinite(const gp::Message& msg, const ParseInfoTree* tree, const std::string& path,
                 const std::string& file, std::vector<ConfigIssue>& issues) {
  const gp::Descriptor* d = msg.GetDescriptor();
  const gp::Reflection* r = msg.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* fd = d->field(i);
    const std::string field_path = path.empty() ? fd->name() : path + "." + fd->name();
    if (fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE) {
      if (fd->is_repeated()) {
        for (int k = 0; k < r->FieldSize(msg, fd); ++k) {
          const gp::Message& element = r->GetRepeatedMessage(msg, fd, k);
          CheckFinite(element, tree ? tree->GetTreeForNested(fd, k) : nullptr,
                      field_path + text_format::ElementSelector(element, k), file, issues);
        }
      } else if (r->HasField(msg, fd)) {
        CheckFinite(r->GetMessage(msg, fd), tree ? tree->GetTreeForNested(fd, -1) : nullptr,
                    field_path, file, issues);
      }
      continue;
    }
    if (fd->cpp_type() != gp::FieldDescriptor::CPPTYPE_DOUBLE || fd->is_repeated() ||
        !r->HasField(msg, fd)) {
      continue;
    }
    const double v = r->GetDouble(msg, fd);
    if (!std::isfinite(v)) {
      const Location loc = tree ? text_format::FromRange(tree->GetLocationRange(fd, -1)) : Location{};
      issues.push_back({file, loc.line, loc.column, field_path, "value must be a finite number",
                        FormatDouble(v), "finite"});
    }
  }
}

std::optional<double> Opt(bool has, double value) {
  return has ? std::optional<double>(value) : std::nullopt;
}

FrictionDirectionOverride FromPb(const pb::FrictionDirectionConfig& f) {
  FrictionDirectionOverride o;
  o.stribeck_velocity_m_s = Opt(f.has_stribeck_velocity_m_s(), f.stribeck_velocity_m_s());
  o.viscous_n_s_m = Opt(f.has_viscous_n_s_m(), f.viscous_n_s_m());
  o.static_n = Opt(f.has_static_n(), f.static_n());
  o.coulomb_n = Opt(f.has_coulomb_n(), f.coulomb_n());
  return o;
}
PolytropicOverride FromPb(const pb::PolytropicConfig& g) {
  PolytropicOverride o;
  o.inflow = Opt(g.has_inflow(), g.inflow());
  o.outflow = Opt(g.has_outflow(), g.outflow());
  o.volume = Opt(g.has_volume(), g.volume());
  return o;
}

void ToPb(const FrictionDirectionOverride& o, pb::FrictionDirectionConfig* f) {
  if (o.stribeck_velocity_m_s) f->set_stribeck_velocity_m_s(*o.stribeck_velocity_m_s);
  if (o.viscous_n_s_m) f->set_viscous_n_s_m(*o.viscous_n_s_m);
  if (o.static_n) f->set_static_n(*o.static_n);
  if (o.coulomb_n) f->set_coulomb_n(*o.coulomb_n);
}
void ToPb(const PolytropicOverride& o, pb::PolytropicConfig* g) {
  if (o.inflow) g->set_inflow(*o.inflow);
  if (o.outflow) g->set_outflow(*o.outflow);
  if (o.volume) g->set_volume(*o.volume);
}
void ToPb(const Eigen::Vector3d& v, pb::Vector3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

// Stage 2 for one leg block; fills `out` when it is well formed.
void ReadLeg(const pb::LegOverlay& leg, int k, const ParseInfoTree* leg_tree, const Location& block,
             const std::string& file, std::map<int, int>& first_line_of_id,
             std::vector<ConfigIssue>& issues, RigOverlay& out) {
  const std::string index_path = "leg[" + std::to_string(k) + "]";
  if (!leg.has_leg_id()) {
    issues.push_back({file, block.line, block.column, index_path + ".leg_id",
                      "leg block without leg_id (lines " + std::to_string(block.line) + "-" +
                          std::to_string(block.end_line) + ")",
                      "(absent)", "1..6"});
    return;
  }
  const gp::FieldDescriptor* id_fd = pb::LegOverlay::descriptor()->FindFieldByName("leg_id");
  const Location id_loc =
      leg_tree ? text_format::FromRange(leg_tree->GetLocationRange(id_fd, -1)) : block;
  const int id = leg.leg_id();
  if (id < 1 || id > static_cast<int>(kNumLegs)) {
    issues.push_back({file, id_loc.line, id_loc.column, index_path + ".leg_id",
                      "leg id out of range", std::to_string(id), "[1, 6]"});
    return;
  }
  if (const auto it = first_line_of_id.find(id); it != first_line_of_id.end()) {
    issues.push_back({file, id_loc.line, id_loc.column, index_path + ".leg_id",
                      "leg " + std::to_string(id) + " has two blocks in one overlay (first at line " +
                          std::to_string(it->second) + ")",
                      std::to_string(id), "each leg_id at most once per file"});
    return;
  }
  first_line_of_id[id] = id_loc.line;
  const std::string path = LegPath(id);
  LegOverride o;
  if (leg.has_friction()) {
    if (leg.friction().has_extend()) o.friction_extend = FromPb(leg.friction().extend());
    if (leg.friction().has_retract()) o.friction_retract = FromPb(leg.friction().retract());
  }
  if (leg.has_polytropic()) {
    if (leg.polytropic().has_extend()) o.polytropic_extend = FromPb(leg.polytropic().extend());
    if (leg.polytropic().has_retract()) o.polytropic_retract = FromPb(leg.polytropic().retract());
  }
  o.discharge_coefficient = Opt(leg.has_discharge_coefficient(), leg.discharge_coefficient());
  o.effective_mass_kg = Opt(leg.has_effective_mass_kg(), leg.effective_mass_kg());
  o.gravity_load_n = Opt(leg.has_gravity_load_n(), leg.gravity_load_n());
  o.potentiometer_offset_m = Opt(leg.has_potentiometer_offset_m(), leg.potentiometer_offset_m());
  o.potentiometer_gain = Opt(leg.has_potentiometer_gain(), leg.potentiometer_gain());
  struct VectorField {
    bool has;
    const pb::Vector3* v;
    const char* name;
    std::optional<Eigen::Vector3d>* into;
  };
  for (const VectorField& f : {VectorField{leg.has_p_ba_b_m(), &leg.p_ba_b_m(), "p_BA_B_m", &o.p_BA_B_m},
                               VectorField{leg.has_p_pb_p_m(), &leg.p_pb_p_m(), "p_PB_P_m", &o.p_PB_P_m}}) {
    if (!f.has) continue;
    if (!(f.v->has_x() && f.v->has_y() && f.v->has_z())) {
      const gp::FieldDescriptor* fd = pb::LegOverlay::descriptor()->FindFieldByName(f.name);
      const Location loc =
          leg_tree ? text_format::FromRange(leg_tree->GetLocationRange(fd, -1)) : block;
      issues.push_back({file, loc.line, loc.column, path + "." + f.name,
                        "a joint position needs all three coordinates",
                        std::string(f.v->has_x() ? "x" : "") + (f.v->has_y() ? "y" : "") +
                            (f.v->has_z() ? "z" : "") + " written",
                        "x, y and z"});
      continue;
    }
    *f.into = Eigen::Vector3d(f.v->x(), f.v->y(), f.v->z());
  }
  if (o.empty()) {
    issues.push_back({file, block.line, block.column, path,
                      "leg block changes nothing (no value written besides leg_id)", "", "at least one value"});
    return;
  }
  out.leg[static_cast<std::size_t>(id - 1)] = o;
}

// Stage 2 for the platform block.
void ReadPlatform(const pb::PlatformOverlay& p, const Location& block, const ParseInfoTree* tree,
                  const std::string& file, std::vector<ConfigIssue>& issues, PlatformOverride& out) {
  out.mass_kg = Opt(p.has_mass_kg(), p.mass_kg());
  if (p.has_inertia_diag_kg_m2()) {
    const pb::Vector3& v = p.inertia_diag_kg_m2();
    if (!(v.has_x() && v.has_y() && v.has_z())) {
      const gp::FieldDescriptor* fd = pb::PlatformOverlay::descriptor()->FindFieldByName("inertia_diag_kg_m2");
      const Location loc = tree ? text_format::FromRange(tree->GetLocationRange(fd, -1)) : block;
      issues.push_back({file, loc.line, loc.column, "platform.inertia_diag_kg_m2",
                        "the platform's inertia needs all three principal moments",
                        std::string(v.has_x() ? "x" : "") + (v.has_y() ? "y" : "") +
                            (v.has_z() ? "z" : "") + " written",
                        "x, y and z"});
      return;
    }
    out.inertia_diag_kg_m2 = Eigen::Vector3d(v.x(), v.y(), v.z());
  }
  if (out.empty()) {
    issues.push_back({file, block.line, block.column, "platform",
                      "platform block changes nothing (no value written)", "",
                      "mass_kg and / or inertia_diag_kg_m2"});
  }
}

}  // namespace

OverlayResult ParseRigOverlay(const std::string& text, const std::string& display_name) {
  try {
    pb::RigOverlay file;
    ParseInfoTree tree;
    std::vector<ConfigIssue> issues;
    if (!text_format::ParseTextFormat(text, display_name, file, tree, issues)) {
      return FailOverlay(std::move(issues));
    }
    const int eof_line = text_format::CountLines(text);
    CheckFinite(file, &tree, "", display_name, issues);
    if (!file.has_rig_name() || file.rig_name().empty()) {
      issues.push_back({display_name, eof_line, 1, "rig_name",
                        "required field 'rig_name' is missing (the rig file's rig_name)", "(absent)",
                        "the rig_name of the rig file it applies to"});
    }
    const Location prov_loc = text_format::FromRange(
        tree.GetLocationRange(pb::RigOverlay::descriptor()->FindFieldByName("provenance"), -1));
    if (!file.has_provenance()) {
      issues.push_back({display_name, eof_line, 1, "provenance",
                        "required block 'provenance' is missing (where the values came from)",
                        "(absent)", "provenance { method: .. date: .. }"});
    } else {
      for (const auto& [has, name] : {std::pair{file.provenance().has_method() &&
                                                    !file.provenance().method().empty(),
                                                "method"},
                                      std::pair{file.provenance().has_date() &&
                                                    !file.provenance().date().empty(),
                                                "date"}}) {
        if (!has) {
          issues.push_back({display_name, prov_loc.line, prov_loc.column,
                            std::string("provenance.") + name,
                            std::string("required field '") + name + "' is missing from block 'provenance'",
                            "(absent)", "non-empty"});
        }
      }
    }
    RigOverlay overlay;
    overlay.rig_name = file.rig_name();
    overlay.provenance.source_recording = file.provenance().source_recording();
    overlay.provenance.method = file.provenance().method();
    overlay.provenance.date = file.provenance().date();
    overlay.provenance.tool = file.provenance().tool();
    overlay.provenance.note = file.provenance().note();
    overlay.source_path = display_name;
    const gp::FieldDescriptor* leg_fd = pb::RigOverlay::descriptor()->FindFieldByName("leg");
    std::map<int, int> first_line_of_id;
    for (int k = 0; k < file.leg_size(); ++k) {
      const Location block = text_format::FromRange(tree.GetLocationRange(leg_fd, k));
      ReadLeg(file.leg(k), k, tree.GetTreeForNested(leg_fd, k), block, display_name,
              first_line_of_id, issues, overlay);
    }
    if (file.has_platform()) {
      const gp::FieldDescriptor* fd = pb::RigOverlay::descriptor()->FindFieldByName("platform");
      ReadPlatform(file.platform(), text_format::FromRange(tree.GetLocationRange(fd, -1)),
                   tree.GetTreeForNested(fd, -1), display_name, issues, overlay.platform);
    }
    if (!issues.empty()) return FailOverlay(std::move(issues));
    OverlayResult result;
    result.ok = true;
    result.overlay = std::move(overlay);
    return result;
  } catch (const std::exception& e) {
    return FailOverlay({{display_name, 0, 0, "", std::string("internal error while loading: ") + e.what(), "", ""}});
  }
}

OverlayResult LoadRigOverlay(const std::string& path) {
  std::string text, error;
  if (!internal::ReadBoundedFile(path, "rig overlay", internal::kMaxRigFileBytes, text, error))
    return FailOverlay({{path, 0, 0, "", error, "", ""}});
  return ParseRigOverlay(text, path);
}

ConfigResult ApplyRigOverlay(const SystemConfig& base, const RigOverlay& overlay,
                             const std::string& text) {
  const std::string file = overlay.source_path.empty() ? "<overlay>" : overlay.source_path;
  ConfigResult result;
  std::vector<ConfigIssue> issues;
  // Lines of the overlay's fields, when its text is known.
  pb::RigOverlay parsed;
  ParseInfoTree tree;
  bool have_tree = false;
  if (!text.empty()) {
    std::vector<ConfigIssue> ignored;  // the overlay was parsed (and its errors told) before
    have_tree = text_format::ParseTextFormat(text, file, parsed, tree, ignored);
  }
  auto locate = [&](ConfigIssue& issue) {
    issue.file = file;
    if (have_tree) {
      const Location loc = Locate(parsed, tree, issue.field);
      issue.line = loc.line > 0 ? loc.line : 1;
      issue.column = loc.line > 0 ? loc.column : 1;
    }
  };
  if (overlay.rig_name != base.rig_name) {
    ConfigIssue issue{file, 0, 0, "rig_name",
                      "overlay is for a different rig than the rig file " +
                          (base.source_path.empty() ? std::string("in use") : "'" + base.source_path + "'"),
                      "\"" + overlay.rig_name + "\"", "\"" + base.rig_name + "\" (rig_name of the rig file)"};
    locate(issue);
    issues.push_back(issue);
    result.issues = issues;
    result.error = issue.ToString();
    return result;
  }
  SystemConfig merged = base;
  for (std::size_t i = 0; i < kNumLegs; ++i) merged.leg_override[i].MergeFrom(overlay.leg[i]);
  merged.platform_override.MergeFrom(overlay.platform);
  merged.overlays.push_back(overlay);
  issues = ValidateControllerModel(merged);
  for (ConfigIssue& issue : issues) locate(issue);
  if (!issues.empty()) {
    for (const ConfigIssue& i : issues) result.error += (result.error.empty() ? "" : "\n") + i.ToString();
    result.issues = std::move(issues);
    return result;
  }
  result.ok = true;
  result.translated = true;
  result.config = std::move(merged);
  return result;
}

ConfigResult LoadSystemConfig(const std::string& path, const std::vector<std::string>& overlay_paths) {
  ConfigResult result = LoadSystemConfig(path);
  for (const std::string& overlay_path : overlay_paths) {
    if (!result.ok) return result;
    std::string text, error;
    if (!internal::ReadBoundedFile(overlay_path, "rig overlay", internal::kMaxRigFileBytes, text,
                                   error)) {
      ConfigResult failed;
      failed.issues = {{overlay_path, 0, 0, "", error, "", ""}};
      failed.error = failed.issues[0].ToString();
      return failed;
    }
    OverlayResult parsed = ParseRigOverlay(text, overlay_path);
    if (!parsed.ok) {
      ConfigResult failed;
      failed.error = parsed.error;
      failed.issues = std::move(parsed.issues);
      return failed;
    }
    result = ApplyRigOverlay(result.config, parsed.overlay, text);
  }
  return result;
}

std::string ToTextFormat(const RigOverlay& o) {
  pb::RigOverlay f;
  f.set_rig_name(o.rig_name);
  pb::OverlayProvenance* p = f.mutable_provenance();
  p->set_method(o.provenance.method);
  p->set_date(o.provenance.date);
  if (!o.provenance.source_recording.empty()) p->set_source_recording(o.provenance.source_recording);
  if (!o.provenance.tool.empty()) p->set_tool(o.provenance.tool);
  if (!o.provenance.note.empty()) p->set_note(o.provenance.note);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegOverride& l = o.leg[i];
    if (l.empty()) continue;
    pb::LegOverlay* leg = f.add_leg();
    leg->set_leg_id(static_cast<int>(i + 1));
    if (Any(l.friction_extend)) ToPb(l.friction_extend, leg->mutable_friction()->mutable_extend());
    if (Any(l.friction_retract)) ToPb(l.friction_retract, leg->mutable_friction()->mutable_retract());
    if (Any(l.polytropic_extend)) ToPb(l.polytropic_extend, leg->mutable_polytropic()->mutable_extend());
    if (Any(l.polytropic_retract)) ToPb(l.polytropic_retract, leg->mutable_polytropic()->mutable_retract());
    if (l.discharge_coefficient) leg->set_discharge_coefficient(*l.discharge_coefficient);
    if (l.effective_mass_kg) leg->set_effective_mass_kg(*l.effective_mass_kg);
    if (l.gravity_load_n) leg->set_gravity_load_n(*l.gravity_load_n);
    if (l.p_BA_B_m) ToPb(*l.p_BA_B_m, leg->mutable_p_ba_b_m());
    if (l.p_PB_P_m) ToPb(*l.p_PB_P_m, leg->mutable_p_pb_p_m());
    if (l.potentiometer_offset_m) leg->set_potentiometer_offset_m(*l.potentiometer_offset_m);
    if (l.potentiometer_gain) leg->set_potentiometer_gain(*l.potentiometer_gain);
  }
  if (o.platform.mass_kg) f.mutable_platform()->set_mass_kg(*o.platform.mass_kg);
  if (o.platform.inertia_diag_kg_m2) ToPb(*o.platform.inertia_diag_kg_m2, f.mutable_platform()->mutable_inertia_diag_kg_m2());
  std::string text;
  gp::TextFormat::Printer printer;
  printer.PrintToString(f, &text);
  return text;
}

}  // namespace hexa::config
