// hexa_recorder diff: the ValveCommand streams of two recordings compared per leg (no DDS involved).
#include <cstdio>

#include "cli.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder::cli {

int RunDiff(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"tolerance-v"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder diff A.mcap B.mcap [--tolerance-v V]\n"
                "Compares valve_v of the ValveCommand streams per leg, matched by tick: ticks in\n"
                "both, ticks in only one, max and RMS |A-B| in volts, first tick that differs\n"
                "(|A-B| > tolerance, default 0, or present in one file only).\n"
                "exit status: 0 identical, 1 different, 2 error\n"))
    return kExitOk;
  NeedPositionals(a, 2, "two recording files");
  const double tol = a.GetDouble("tolerance-v", 0.0);
  if (!(tol >= 0.0)) throw UsageError("--tolerance-v must be >= 0");
  const DiffReport r = DiffValveCommands(a.positional[0], a.positional[1], tol);
  std::fputs(FormatDiff(r).c_str(), stdout);
  return r.identical ? kExitOk : kExitDifferent;
}

}  // namespace hexa::recorder::cli
