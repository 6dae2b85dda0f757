// Reading a protobuf text-format file the same way everywhere: the rig file, rig overlays and
// washout files (config/), deployment files (deploy/deployment). The parser's set-up with its
// errors turned into ConfigIssues ("FILE:LINE:COLUMN: error: FIELD: message (value V, limit
// L)", with the field path and "did you mean" for an unknown field), the every-field-written
// check, and line lookup of a field path through the parser's ParseInfoTree.
#pragma once

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"

namespace hexa::config::text_format {

struct Location {
  int line = 0;    // 1-based, 0 = unknown
  int column = 0;  // 1-based
  int end_line = 0;
};

Location FromRange(const google::protobuf::TextFormat::ParseLocationRange& range);

class CollectingErrors : public google::protobuf::io::ErrorCollector {
 public:
  struct Error {
    int line;
    int column;
    std::string message;
  };
  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override;
  void AddWarning(int, google::protobuf::io::ColumnNumber, const std::string&) override {}
  std::vector<Error> errors;
};

// Turns the parser's "Message type "X" has no field named "y"." into an issue with the
// field path under `root` (when the type is used in one place only), the known fields and a
// guess; other parser errors become "syntax error: ...".
ConfigIssue ParserIssue(const CollectingErrors::Error& e, const std::string& file,
                        const google::protobuf::Descriptor* root);

// Parses `text` (protobuf text format) into `message`, the parser's field locations into
// `tree`. On a parse error: false, with one issue per parser error in `issues` (ParserIssue
// under `message`'s type; "text format parse failed" when the parser gave none).
bool ParseTextFormat(const std::string& text, const std::string& display_name,
                     google::protobuf::Message& message,
                     google::protobuf::TextFormat::ParseInfoTree& tree,
                     std::vector<ConfigIssue>& issues);

// Every singular field of every block written (nothing takes a silent default) and every
// floating-point value finite, in `message` parsed from `file` (ParseTextFormat) with its
// locations in `tree`; the blocks at the paths `optional_blocks` ("board",
// "leg_controller.coupled_legs") may be absent. One issue per
// field, at its line (a missing one: at its block's first line, or at `eof_line`).
void CheckEveryFieldWritten(const google::protobuf::Message& message,
                            const google::protobuf::TextFormat::ParseInfoTree& tree,
                            const std::string& file, int eof_line,
                            const std::vector<std::string>& optional_blocks,
                            std::vector<ConfigIssue>& issues);

int CountLines(const std::string& text);

// Selector of a repeated element in a path: "[id=3]", "[leg_id=3]", "[name=ideal]" or "[2]".
std::string ElementSelector(const google::protobuf::Message& element, int index);

// Maps a field path ("geometry.leg[id=3].p_BA_B_m.y", "leg[leg_id=2].friction.extend") to
// the location of the deepest part of it that is written in the file parsed into `root`.
Location Locate(const google::protobuf::Message& root,
                const google::protobuf::TextFormat::ParseInfoTree& tree, const std::string& path);

}  // namespace hexa::config::text_format
