// JSON output of the system's programs (report.json, summaries, study results): built as a
// nlohmann::ordered_json value, so that every string is escaped, the fields keep the order
// they are written in, and a number that is not finite (NaN, infinity) is written as null
// (JSON has neither). Strings that are not valid UTF-8 are written with U+FFFD in place of
// each invalid byte (JSON text is UTF-8, RFC 8259).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace hexa::json {

using Value = nlohmann::ordered_json;

// The text of `value`: on one line (indent < 0) or indented by `indent` spaces per level,
// without a trailing newline.
std::string Dump(const Value& value, int indent = -1);

// Writes Dump(value, indent) and a newline to `path`. False (with `error` naming the file) if
// the file cannot be written.
bool WriteFile(const std::string& path, const Value& value, int indent, std::string& error);

}  // namespace hexa::json
