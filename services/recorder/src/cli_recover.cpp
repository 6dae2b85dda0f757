// hexa_recorder recover: a truncated or damaged recording rewritten as a complete MCAP file (no DDS involved).
#include <cstdio>

#include "cli.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder::cli {

int RunRecover(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"output", "o", "compression"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder recover DAMAGED.mcap --output FIXED.mcap "
                "[--compression none|zstd]\n"
                "Reads every intact chunk of a recording that lacks its summary and footer (e.g.\n"
                "the recorder was killed) or has corrupt chunks, and writes a complete MCAP file\n"
                "with summary, indexes and footer. Sequence numbers and times are kept. String\n"
                "fields that are not valid UTF-8 are repaired (U+FFFD). Exit status 2, and no\n"
                "output, when no intact message was found.\n"
                "Chunks of the output are zstd-compressed unless --compression none.\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one input file");
  const std::string out = a.Get("output", a.Get("o", ""));
  if (out.empty()) throw UsageError("--output FILE is required");
  if (out == a.positional[0]) throw UsageError("--output must differ from the input file");
  McapWriterConfig config;
  config.compression = ParseCompressionOption(a);
  const RecoverResult r = Recover(a.positional[0], out, config);
  for (const auto& p : r.problems) std::printf("problem: %s\n", p.c_str());
  const char* status = r.input_readable ? "was complete"
                       : r.input_complete ? "was complete in structure but not readable as it was"
                                          : "was incomplete";
  if (r.messages == 0) {
    // Nothing to keep: an output without messages would only look like a recovery.
    std::remove(out.c_str());
    std::fprintf(stderr,
                 "hexa_recorder recover: nothing recovered: no intact message in '%s' (input %s, "
                 "%llu chunks read, %llu corrupt chunks, %llu bytes dropped at the end); no "
                 "output written\n",
                 a.positional[0].c_str(), status, static_cast<unsigned long long>(r.chunks_read),
                 static_cast<unsigned long long>(r.bad_chunks),
                 static_cast<unsigned long long>(r.bytes_dropped));
    return kExitError;
  }
  std::printf("input %s; recovered %llu messages from %llu chunks (%llu corrupt chunks skipped, "
              "%llu bytes dropped at the end, %llu messages repaired, %llu undecodable) into %s\n",
              status, static_cast<unsigned long long>(r.messages),
              static_cast<unsigned long long>(r.chunks_read),
              static_cast<unsigned long long>(r.bad_chunks),
              static_cast<unsigned long long>(r.bytes_dropped),
              static_cast<unsigned long long>(r.repaired_messages),
              static_cast<unsigned long long>(r.undecodable_messages), out.c_str());
  return kExitOk;
}

}  // namespace hexa::recorder::cli
