// hexa_recorder export: one CSV file per topic (no DDS involved).
#include <cstdio>

#include "cli.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder::cli {

int RunExport(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"out-dir", "topics", "exclude"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder export FILE.mcap --out-dir DIR [--topics GLOB,..] "
                "[--exclude GLOB,..]\n"
                "Writes DIR/<topic>.csv per topic: log_time_ns, publish_time_ns, sequence, then\n"
                "every message field (nested as a.b, repeated as name[i], enums by name, doubles\n"
                "with 17 significant digits).\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one recording file");
  if (!a.Has("out-dir")) throw UsageError("--out-dir DIR is required");
  TopicFilter f{a.GetAll("topics"), a.GetAll("exclude")};
  const ExportResult r = ExportCsv(a.positional[0], a.Get("out-dir", ""), f);
  for (const auto& w : r.warnings) std::fprintf(stderr, "hexa_recorder export: warning: %s\n", w.c_str());
  for (const auto& [path, rows] : r.files)
    std::printf("%s: %llu rows\n", path.c_str(), static_cast<unsigned long long>(rows));
  if (r.files.empty()) std::printf("no messages matched; no file written\n");
  return kExitOk;
}

}  // namespace hexa::recorder::cli
