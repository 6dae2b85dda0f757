// hexa_recorder: records every DDS topic of the system to MCAP, and inspects, exports,
// compares, repairs and replays recordings. Thin shell over hexa_recording (docs/recorder.md).
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include <google/protobuf/stubs/logging.h>

#include "cli.hpp"
#include "hexa/recording/mcap.hpp"

namespace {
constexpr const char* kUsage =
    "usage: hexa_recorder <command> [options]   (hexa_recorder <command> --help for details)\n"
    "\n"
    "commands:\n"
    "  record   subscribe to every topic (or a subset) and write an MCAP file\n"
    "  info     duration, channels, message counts, rates, gaps and loss per topic\n"
    "  play     republish a recording onto DDS with its original timing\n"
    "  diff     compare the ValveCommand streams of two recordings per leg\n"
    "  export   one CSV file per topic\n"
    "  recover  rewrite a truncated recording (e.g. after kill -9) as a complete MCAP file\n"
    "  report   session report (RMSE tables, latency, deadline misses, plots) from a recording\n"
    "  annotate add the Foxglove 3-D scene to a recording made without it\n"
    "  attach   add the session description / plant truth channels to a recording\n"
    "\n"
    "exit status: 0 success, 1 diff found differences, 2 error (message on stderr)\n";
// libprotobuf logs each string field that is not UTF-8 while parsing; the reader repairs such
// messages and reports them once per channel (recording.hpp), so those lines are dropped here.
// Everything else libprotobuf logs still goes to stderr.
void ProtobufLog(google::protobuf::LogLevel level, const char* file, int line,
                 const std::string& message) {
  if (message.find("contains invalid UTF-8 data when parsing") != std::string::npos) return;
  static const char* const kLevel[] = {"INFO", "WARNING", "ERROR", "FATAL"};
  std::fprintf(stderr, "[libprotobuf %s %s:%d] %s\n", kLevel[std::min<int>(level, 3)], file, line,
               message.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  namespace cli = hexa::recorder::cli;
  google::protobuf::SetLogHandler(&ProtobufLog);
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0 ||
      std::strcmp(argv[1], "help") == 0) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? cli::kExitError : cli::kExitOk;
  }
  const std::string command = argv[1];
  const std::vector<std::string> rest(argv + 2, argv + argc);
  try {
    if (command == "info") return cli::RunInfo(rest);
    if (command == "export") return cli::RunExport(rest);
    if (command == "recover") return cli::RunRecover(rest);
    if (command == "diff") return cli::RunDiff(rest);
    if (command == "record") return cli::RunRecord(rest);
    if (command == "play") return cli::RunPlay(rest);
    if (command == "report") return cli::RunReport(rest);
    if (command == "annotate") return cli::RunAnnotate(rest);
    if (command == "attach") return cli::RunAttach(rest);
    std::fprintf(stderr, "hexa_recorder: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return cli::kExitError;
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "hexa_recorder %s: %s (see hexa_recorder %s --help)\n", command.c_str(),
                 e.what(), command.c_str());
  } catch (const hexa::recorder::McapError& e) {
    std::fprintf(stderr, "hexa_recorder %s: error: %s\n", command.c_str(), e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexa_recorder %s: error: %s\n", command.c_str(), e.what());
  }
  return cli::kExitError;
}
