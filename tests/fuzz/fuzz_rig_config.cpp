// libFuzzer target: the rig-file parser and validator (config/rig_config.hpp) on arbitrary text,
// and, for a file that translates with valid structs, the physical limits and their text.
// Invariants: never crash, never throw (the status API), every issue names a file and a field
// or a syntax error, an accepted config passes its own validation again.
#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/physical_limits.hpp"

// libprotobuf logs every string that is not UTF-8 while parsing (the reader repairs them):
// silenced, it would drown libFuzzer's output.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return -1;  // rig files are a few kB; keep executions fast
  const std::string text(reinterpret_cast<const char*>(data), size);
  const hexa::config::ConfigResult r = hexa::config::ParseSystemConfig(text, "fuzz.textproto");
  if (r.ok) {
    if (!hexa::config::ValidateSystemConfig(r.config).empty()) __builtin_trap();
    (void)hexa::config::Summary(r.config);
    (void)hexa::config::ToTextFormat(r.config);
  } else {
    if (r.issues.empty() || r.error.empty()) __builtin_trap();
    for (const auto& issue : r.issues) {
      if (issue.file != "fuzz.textproto") __builtin_trap();
    }
  }
  bool structs_valid = r.translated;
  for (const auto& issue : r.issues) structs_valid = structs_valid && issue.physical_limit;
  if (structs_valid) (void)hexa::ExplainLimits(hexa::config::DerivePhysicalLimits(r.config));
  return 0;
}
