// Motion-cueing parameter file -> validated hexa::WashoutConfig (see washout_file.hpp).
#include "hexa/config/washout_file.hpp"

#include <fstream>
#include <sstream>

#include "motion_cueing.pb.h"
#include "hexa/config/text_format.hpp"

namespace hexa::config {
namespace {

namespace gp = google::protobuf;
using text_format::FromRange;
using text_format::Location;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

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
  std::vector<ConfigIssue> issues;
  if (!text_format::ParseTextFormat(text, display_name, file, tree, issues)) return Fail(std::move(issues));
  text_format::CheckEveryFieldWritten(file, tree, display_name, text_format::CountLines(text), {}, issues);
  if (!issues.empty()) return Fail(std::move(issues));
  WashoutFileResult result;
  result.config = Translate(file);
  std::vector<ParamIssue> rules;
  ParamChecker checker(rules);
  CheckWashoutConfig(checker, result.config, "");
  for (const ParamIssue& rule : rules) {
    const Location loc = text_format::Locate(file, tree, rule.field);
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
