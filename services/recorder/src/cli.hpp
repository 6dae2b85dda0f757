// Command-line plumbing of hexa_recorder: a small option parser and the subcommand entry
// points. Exit codes: 0 success, 1 `diff` found differences, 2 bad input (usage, unreadable
// or malformed file, DDS failure).
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "hexa/recording/mcap.hpp"

namespace hexa::recorder {
struct SceneOptions;
}

namespace hexa::recorder::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitDifferent = 1;
inline constexpr int kExitError = 2;

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> options;
  bool help = false;

  bool Has(const std::string& name) const { return options.count(name) > 0; }
  std::string Get(const std::string& name, const std::string& fallback) const;
  std::vector<std::string> GetAll(const std::string& name) const;  // repeated and/or comma lists
  // A finite number; `allow_infinity` also takes +inf for options that give it a meaning
  // ("play --deadline-s inf": no deadline). NaN and -inf never.
  double GetDouble(const std::string& name, double fallback, bool allow_infinity = false) const;
  long long GetInt(const std::string& name, long long fallback) const;
};

// `value_options` take a value (--name v or --name=v); `flag_options` take none. Anything else
// starting with "--" is a UsageError naming it.
Args ParseArgs(const std::vector<std::string>& argv, const std::set<std::string>& value_options,
               const std::set<std::string>& flag_options);

// Prints `text` when --help was given; true then (the verb returns kExitOk).
bool PrintHelp(const Args& a, const char* text);
// Throws a UsageError "expected <what>" unless there are exactly `n` positional arguments.
void NeedPositionals(const Args& a, size_t n, const char* what);

// --compression none|zstd (default zstd), as every writing subcommand takes it.
McapCompression ParseCompressionOption(const Args& a);
// --zstd-level 1..19 (default McapWriterConfig's).
int ParseZstdLevelOption(const Args& a);

// One file per verb: cli_<verb>.cpp.
int RunInfo(const std::vector<std::string>& argv);
int RunExport(const std::vector<std::string>& argv);
int RunRecover(const std::vector<std::string>& argv);
int RunDiff(const std::vector<std::string>& argv);
int RunRecord(const std::vector<std::string>& argv);
int RunPlay(const std::vector<std::string>& argv);
int RunReport(const std::vector<std::string>& argv);
int RunAnnotate(const std::vector<std::string>& argv);

// The scene options of `record` and `annotate` (--rig, --profile, --seed, --scene-hz) and
// their help text (cli_scene.cpp).
extern const char* kSceneOptionsHelp;
SceneOptions SceneOptionsFromArgs(const Args& a);
int RunAttach(const std::vector<std::string>& argv);

}  // namespace hexa::recorder::cli
