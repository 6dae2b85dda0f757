// Protobuf text-format reading shared by every file loader (hexa/config/text_format.hpp).
#include "hexa/config/text_format.hpp"

#include <algorithm>
#include <cmath>
#include <regex>

#include "internal.hpp"

namespace hexa::config::text_format {

namespace gp = google::protobuf;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

namespace {

// Levenshtein distance, for "did you mean" on unknown field names.
std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diag = up;
    }
  }
  return row[b.size()];
}

// Every path in the schema where a message type appears ("cylinder", "friction.extend").
void PathsOfType(const gp::Descriptor* root, const gp::Descriptor* type, const std::string& prefix,
                 std::vector<std::string>& out, int depth = 0) {
  if (depth > 8) return;
  for (int i = 0; i < root->field_count(); ++i) {
    const gp::FieldDescriptor* fd = root->field(i);
    if (fd->cpp_type() != gp::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string path = prefix.empty() ? fd->name() : prefix + "." + fd->name();
    if (fd->message_type() == type) out.push_back(path);
    PathsOfType(fd->message_type(), type, path, out, depth + 1);
  }
}

}  // namespace

Location FromRange(const gp::TextFormat::ParseLocationRange& range) {
  Location loc;
  if (range.start.line >= 0) {
    loc.line = range.start.line + 1;
    loc.column = range.start.column + 1;
    loc.end_line = range.end.line + 1;
  }
  return loc;
}

void CollectingErrors::AddError(int line, gp::io::ColumnNumber column, const std::string& message) {
  errors.push_back({line, column, message});
}

bool ParseTextFormat(const std::string& text, const std::string& display_name, gp::Message& message,
                     gp::TextFormat::ParseInfoTree& tree, std::vector<ConfigIssue>& issues) {
  CollectingErrors errors;
  gp::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(&tree);
  if (parser.ParseFromString(text, &message)) return true;
  for (const auto& e : errors.errors) issues.push_back(ParserIssue(e, display_name, message.GetDescriptor()));
  if (issues.empty()) issues.push_back({display_name, 1, 1, "", "text format parse failed", "", ""});
  return false;
}

// Turns the parser's "Message type "X" has no field named "y"." into an issue with the
// field path (when the type is used in one place only), the known fields and a guess.
ConfigIssue ParserIssue(const CollectingErrors::Error& e, const std::string& file, const gp::Descriptor* root) {
  ConfigIssue issue;
  issue.file = file;
  issue.line = e.line + 1;
  issue.column = e.column + 1;
  issue.message = e.message;
  static const std::regex kUnknown(R"re(Message type "([^"]+)" has no field named "([^"]+)")re");
  std::smatch m;
  if (!std::regex_search(e.message, m, kUnknown)) {
    issue.message = "syntax error: " + e.message;
    return issue;
  }
  const std::string type_name = m[1];
  const std::string field_name = m[2];
  const gp::Descriptor* type = gp::DescriptorPool::generated_pool()->FindMessageTypeByName(type_name);
  issue.value = field_name;
  if (type == nullptr) {
    issue.message = "unknown field name";
    return issue;
  }
  std::vector<std::string> paths;
  if (type == root) paths.push_back("");
  PathsOfType(root, type, "", paths);
  std::string known;
  std::string best;
  std::size_t best_distance = 1000;
  for (int i = 0; i < type->field_count(); ++i) {
    const std::string& name = type->field(i)->name();
    known += (known.empty() ? "" : ", ") + name;
    const std::size_t d = EditDistance(field_name, name);
    if (d < best_distance) {
      best_distance = d;
      best = name;
    }
  }
  std::string where;
  if (paths.size() == 1) {
    where = paths[0].empty() ? "the top level" : "block '" + paths[0] + "'";
    issue.field = paths[0].empty() ? field_name : paths[0] + "." + field_name;
  } else {
    where = "a " + type->name() + " block";
    issue.field = field_name;
  }
  issue.message = "unknown field name in " + where;
  if (best_distance <= std::max<std::size_t>(2, field_name.size() / 3)) {
    issue.message += " (did you mean '" + best + "'?)";
  }
  issue.limit = "one of: " + known;
  return issue;
}

int CountLines(const std::string& text) {
  int lines = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  if (!text.empty() && text.back() != '\n') ++lines;
  return std::max(lines, 1);
}

// Selector of a repeated element in a path: "[id=3]", "[name=ideal]" or "[2]".
std::string ElementSelector(const gp::Message& element, int index) {
  const gp::Descriptor* d = element.GetDescriptor();
  const gp::Reflection* r = element.GetReflection();
  for (const char* key : {"id", "leg_id"}) {
    if (const gp::FieldDescriptor* id = d->FindFieldByName(key);
        id != nullptr && id->cpp_type() == gp::FieldDescriptor::CPPTYPE_INT32 && r->HasField(element, id)) {
      return std::string("[") + key + "=" + std::to_string(r->GetInt32(element, id)) + "]";
    }
  }
  if (const gp::FieldDescriptor* name = d->FindFieldByName("name");
      name != nullptr && name->cpp_type() == gp::FieldDescriptor::CPPTYPE_STRING && r->HasField(element, name)) {
    return "[name=" + r->GetString(element, name) + "]";
  }
  return "[" + std::to_string(index) + "]";
}

// Maps a field path ("geometry.leg[id=3].p_BA_B_m.y", "disturbance_profile[name=ideal]")
// to the location of the deepest part of it that is written in the file.
Location Locate(const gp::Message& root, const ParseInfoTree& root_tree, const std::string& path) {
  const gp::Message* msg = &root;
  const ParseInfoTree* tree = &root_tree;
  Location best;
  std::size_t pos = 0;
  while (pos < path.size() && msg != nullptr && tree != nullptr) {
    std::size_t end = pos;
    while (end < path.size() && path[end] != '.' && path[end] != '[') ++end;
    const std::string name = path.substr(pos, end - pos);
    std::string selector;
    bool has_selector = false;
    if (end < path.size() && path[end] == '[') {
      const std::size_t close = path.find(']', end);
      if (close == std::string::npos) break;
      selector = path.substr(end + 1, close - end - 1);
      has_selector = true;
      end = close + 1;
    }
    pos = (end < path.size() && path[end] == '.') ? end + 1 : end;

    const gp::Descriptor* d = msg->GetDescriptor();
    const gp::Reflection* r = msg->GetReflection();
    const gp::FieldDescriptor* fd = d->FindFieldByName(name);
    if (fd == nullptr) break;
    int index = -1;
    if (fd->is_repeated()) {
      if (!has_selector || fd->cpp_type() != gp::FieldDescriptor::CPPTYPE_MESSAGE) {
        const Location loc = FromRange(tree->GetLocationRange(fd, 0));
        if (loc.line > 0) best = loc;
        break;
      }
      for (int k = 0; k < r->FieldSize(*msg, fd) && index < 0; ++k) {
        if (ElementSelector(r->GetRepeatedMessage(*msg, fd, k), k) == "[" + selector + "]" ||
            selector == std::to_string(k)) {
          index = k;
        }
      }
      if (index < 0) break;
    }
    const Location loc = FromRange(tree->GetLocationRange(fd, index));
    if (loc.line > 0) best = loc;
    if (fd->cpp_type() != gp::FieldDescriptor::CPPTYPE_MESSAGE) break;
    msg = index >= 0 ? &r->GetRepeatedMessage(*msg, fd, index) : &r->GetMessage(*msg, fd);
    tree = tree->GetTreeForNested(fd, index);
  }
  return best;
}

namespace {

struct PresenceContext {
  const std::string& file;
  int eof_line;
  const std::vector<std::string>& optional_blocks;
  std::vector<ConfigIssue>& issues;
};

void CheckPresence(const gp::Message& msg, const ParseInfoTree* tree, const std::string& path,
                   const Location& block, PresenceContext& ctx) {
  const gp::Descriptor* d = msg.GetDescriptor();
  const gp::Reflection* r = msg.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* fd = d->field(i);
    const std::string field_path = path.empty() ? fd->name() : path + "." + fd->name();
    const bool is_message = fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE;
    if (fd->is_repeated()) {
      if (!is_message) continue;
      for (int k = 0; k < r->FieldSize(msg, fd); ++k) {
        const gp::Message& element = r->GetRepeatedMessage(msg, fd, k);
        const Location loc = tree ? FromRange(tree->GetLocationRange(fd, k)) : Location{};
        CheckPresence(element, tree ? tree->GetTreeForNested(fd, k) : nullptr,
                      path.empty() ? fd->name() + ElementSelector(element, k)
                                   : path + "." + fd->name() + ElementSelector(element, k),
                      loc, ctx);
      }
      continue;
    }
    const Location loc = tree ? FromRange(tree->GetLocationRange(fd, -1)) : Location{};
    if (!r->HasField(msg, fd) && is_message &&
        std::find(ctx.optional_blocks.begin(), ctx.optional_blocks.end(), field_path) !=
            ctx.optional_blocks.end())
      continue;
    if (!r->HasField(msg, fd)) {
      ConfigIssue issue;
      issue.file = ctx.file;
      issue.field = field_path;
      issue.value = "(absent)";
      issue.limit = "every field must be written";
      if (path.empty()) {
        issue.line = ctx.eof_line;
        issue.column = 1;
        issue.message = std::string("required ") + (is_message ? "block" : "field") + " '" + fd->name() +
                        "' is missing from the file";
      } else {
        issue.line = block.line;
        issue.column = block.column;
        issue.message = std::string("required ") + (is_message ? "block" : "field") + " '" + fd->name() +
                        "' is missing from block '" + path + "' (lines " + std::to_string(block.line) + "-" +
                        std::to_string(block.end_line) + ")";
      }
      ctx.issues.push_back(std::move(issue));
      continue;
    }
    if (is_message) {
      CheckPresence(r->GetMessage(msg, fd), tree ? tree->GetTreeForNested(fd, -1) : nullptr, field_path, loc,
                    ctx);
    } else if (fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_DOUBLE ||
               fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_FLOAT) {
      const double v = fd->cpp_type() == gp::FieldDescriptor::CPPTYPE_DOUBLE ? r->GetDouble(msg, fd)
                                                                            : r->GetFloat(msg, fd);
      if (!std::isfinite(v)) {
        ctx.issues.push_back({ctx.file, loc.line, loc.column, field_path, "value must be a finite number",
                              internal::FormatDouble(v), "finite"});
      }
    }
  }
}

}  // namespace

void CheckEveryFieldWritten(const gp::Message& message, const ParseInfoTree& tree, const std::string& file,
                            int eof_line, const std::vector<std::string>& optional_blocks,
                            std::vector<ConfigIssue>& issues) {
  PresenceContext ctx{file, eof_line, optional_blocks, issues};
  CheckPresence(message, &tree, "", Location{1, 1, eof_line}, ctx);
}

}  // namespace hexa::config::text_format
