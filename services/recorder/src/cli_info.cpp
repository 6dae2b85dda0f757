// hexa_recorder info: duration, channels, counts, rates, gaps and loss of a recording (no DDS involved).
#include <cstdio>

#include "cli.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder::cli {

int RunInfo(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {}, {"tolerant", "no-crc"});
  if (PrintHelp(a,
                "usage: hexa_recorder info FILE.mcap [--tolerant] [--no-crc]\n"
                "Prints duration, channels (topic, type, QoS metadata), message counts, rates, the\n"
                "largest log-time gap, and loss per topic and instance from tick numbers (periodic\n"
                "topics: a tick difference of k expected steps = k-1 missing samples).\n"
                "  --tolerant  read a truncated file up to its last intact chunk instead of failing\n"
                "  --no-crc    skip CRC verification\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one recording file");
  McapScanOptions o;
  o.tolerant = a.Has("tolerant");
  o.verify_crcs = !a.Has("no-crc");
  const RecordingInfo info = Inspect(a.positional[0], o);
  std::fputs(FormatInfo(info).c_str(), stdout);
  return kExitOk;
}

}  // namespace hexa::recorder::cli
