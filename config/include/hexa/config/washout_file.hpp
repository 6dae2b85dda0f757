// Motion-cueing parameter file (protobuf text format, proto/motion_cueing.proto; the default is
// deploy/cueing/washout.textproto): read, parsed, checked for completeness and validated here,
// at the edge; the core gets a hexa::WashoutConfig. Every field must be written. Errors name
// the file, the line, the field, the value and the limit, as the rig file's do:
//   "washout.textproto:9:3: error: tilt.rate_limit_rad_s: tilt rate limit is out of range:
//    value 2, limit [0.0001, 1]"
#pragma once

#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/washout.hpp"

namespace hexa::config {

struct WashoutFileResult {
  bool ok = false;
  WashoutConfig config;               // valid when ok
  std::string error;                  // every issue, one per line ("" when ok)
  std::vector<ConfigIssue> issues;
};

// `display_name` is used in messages (normally the path).
WashoutFileResult ParseWashoutFile(const std::string& text, const std::string& display_name);
WashoutFileResult LoadWashoutFile(const std::string& path);

}  // namespace hexa::config
