// Motion-cueing parameter file -> validated hexa::WashoutConfig (see washout_file.hpp).
#include "hexa/config/washout_file.hpp"

#include <fstream>
#include <sstream>

#include "motion_cueing.pb.h"
#include "text_format.hpp"

namespace hexa::config {
namespace {

namespace gp = google::protobuf;
using internal::CollectingErrors;
using internal::FromRange;
using internal::Location;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

// Every (non-repeated) field of every block must be written: nothing takes a silent default.
void CheckPresence(const gp::Message& msg, const ParseInfoTree* tree, const std::string& path,
                   const Location& block, const std::string& file, int eof_line,
                   std::vector<ConfigIssue>& issues) {
  const gp::Descriptor* d = msg.GetDescriptor();
  const gp::Reflection* r = msg.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* fd = d->field(i);
    const std::string field_path = path.empty() ? fd->name() : path + "." + fd->name();
    const bool is_message = fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE;
    if (!r->HasField(msg, fd)) {
      ConfigIssue issue;
      issue.file = file;
      issue.field = field_path;
      issue.value = "(absent)";
      issue.limit = "every field must be written";
      issue.line = path.empty() ? eof_line : block.line;
      issue.column = path.empty() ? 1 : block.column;
      issue.message = std::string("required ") + (is_message ? "block" : "field") + " '" +
                      fd->name() + "' is missing from " +
                      (path.empty() ? std::string("the file") : "block '" + path + "'");
      issues.push_back(std::move(issue));
      continue;
    }
    if (is_message) {
      const Location loc = tree ? FromRange(tree->GetLocationRange(fd, -1)) : Location{};
      CheckPresence(r->GetMessage(msg, fd), tree ? tree->GetTreeForNested(fd, -1) : nullptr,
                    field_path, loc, file, eof_line, issues);
    }
  }
}

WashoutTranslationParams FromPb(const pb::WashoutTranslationChannel& c) {
  return {c.scale(), c.input_limit_m_s2(), c.frequency_rad_s(), c.damping(),
          c.break_frequency_rad_s(), c.displacement_limit_m()};
}

WashoutRotationParams FromPb(const pb::WashoutRotationChannel& c) {
  return {c.scale(), c.input_limit_rad_s(), c.frequency_rad_s(), c.damping(), c.angle_limit_rad()};
}

WashoutConfig Translate(const pb::WashoutFile& f) {
  WashoutConfig w;
  w.period_s = f.period_s();
  w.gravity_m_s2 = f.gravity_m_s2();
  w.translation = {FromPb(f.translation().surge()), FromPb(f.translation().sway()),
                   FromPb(f.translation().heave())};
  w.rotation = {FromPb(f.rotation().roll()), FromPb(f.rotation().pitch()),
                FromPb(f.rotation().yaw())};
  const pb::WashoutTilt& t = f.tilt();
  w.tilt = {t.scale(), t.frequency_rad_s(), t.damping(), t.rate_limit_rad_s(), t.angle_limit_rad()};
  return w;
}

WashoutFileResult Fail(std::vector<ConfigIssue> issues) {
  WashoutFileResult result;
  for (const ConfigIssue& issue : issues) {
    result.error += (result.error.empty() ? "" : "\n") + issue.ToString();
  }
  result.issues = std::move(issues);
  return result;
}

}  // namespace

WashoutFileResult ParseWashoutFile(const std::string& text, const std::string& display_name) {
  pb::WashoutFile file;
  ParseInfoTree tree;
  CollectingErrors errors;
  gp::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(&tree);
  if (!parser.ParseFromString(text, &file)) {
    std::vector<ConfigIssue> issues;
    for (const auto& e : errors.errors) {
      issues.push_back(internal::ParserIssue(e, display_name, pb::WashoutFile::descriptor()));
    }
    if (issues.empty()) issues.push_back({display_name, 1, 1, "", "text format parse failed", "", ""});
    return Fail(std::move(issues));
  }
  std::vector<ConfigIssue> issues;
  CheckPresence(file, &tree, "", Location{1, 1, internal::CountLines(text)}, display_name,
                internal::CountLines(text), issues);
  if (!issues.empty()) return Fail(std::move(issues));
  WashoutFileResult result;
  result.config = Translate(file);
  std::vector<ParamIssue> rules;
  ParamChecker checker(rules);
  CheckWashoutConfig(checker, result.config, "");
  for (const ParamIssue& rule : rules) {
    const Location loc = internal::Locate(file, tree, rule.field);
    issues.push_back({display_name, loc.line > 0 ? loc.line : 1, loc.line > 0 ? loc.column : 1,
                      rule.field, rule.message, rule.value, rule.limit});
  }
  if (!issues.empty()) return Fail(std::move(issues));
  result.ok = true;
  return result;
}

WashoutFileResult LoadWashoutFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Fail({{path, 0, 0, "", "cannot open washout file", "", ""}});
  std::ostringstream text;
  text << in.rdbuf();
  return ParseWashoutFile(text.str(), path);
}

}  // namespace hexa::config
