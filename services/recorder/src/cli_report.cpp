// hexa_recorder report: the session report (docs/measurements/results.md) from a recording alone.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/services/progress.hpp"

namespace hexa::recorder::cli {

int RunReport(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"out", "meta", "title", "python"}, {"no-plots"});
  if (a.help) {
    std::fputs(
        "usage: hexa_recorder report RECORDING.mcap [PART.mcap..] --out DIR [--meta key=value,..] "
        "[--title TEXT] [--no-plots] [--python /abs/path/python3]\n"
        "Computes the session figures from the recording alone and writes into DIR (a recording\n"
        "split into parts, record --split-*: every part, oldest first, as one recording):\n"
        "report.md, report.json (RMSE per axis against ground truth and against the measured\n"
        "pose over the tracking window, relative errors, leg-length RMSE per leg, deadline\n"
        "misses per topic, control round-trip latency median/p99/max, wall and simulated time,\n"
        "faults; for a BS-SMC session each leg's adapted friction scale theta at the end of the\n"
        "tracking window, min and max), pose.csv, legs.csv and events.csv (faults, HOLD, take-overs,\n"
        "operator commands), and the PNG plots, summary.png first (deploy/plot_session.py, run with\n"
        "/usr/bin/python3, or the absolute path given with --python; never looked up on PATH).\n"
        "Progress on stderr (a line rewritten on a terminal, every 10 s otherwise).\n"
        "--meta adds session facts (trajectory=combined,controller=bssmc,...);\n"
        "trajectory=<name> adds the paper's Table 9 / 10 figures for comparison.\n",
        stdout);
    return kExitOk;
  }
  if (a.positional.empty()) throw UsageError("a recording is required");
  const std::string out = a.Get("out", "");
  if (out.empty()) throw UsageError("--out DIR is required");
  // The interpreter by its absolute path, also as argv[0]: Python finds its prefix (and with
  // it the site-packages holding matplotlib) from argv[0], and a bare "python3" is looked up
  // on PATH, where a virtual environment's python3 may come first.
  const std::string python = a.Get("python", "/usr/bin/python3");
  if (python.empty() || python[0] != '/')
    throw UsageError("--python wants an absolute path, got '" + python + "'");
  std::filesystem::create_directories(out);
  SessionReport report;
  {
    progress::Line line("report: reading " + std::filesystem::path(a.positional.back()).filename().string());
    report = ComputeSessionReport(a.positional, [&](double f) { line.Update(f); });
  }
  for (const auto& kv : a.GetAll("meta")) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw UsageError("--meta wants key=value, got '" + kv + "'");
    report.meta[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  for (const auto& w : report.warnings) std::fprintf(stderr, "hexa_recorder report: warning: %s\n", w.c_str());
  WriteSessionReport(report, out);
  std::printf("report: %s/report.md, report.json, pose.csv, legs.csv, events.csv\n", out.c_str());
  std::fflush(stdout);
  if (a.Has("no-plots")) return kExitOk;
  const std::string script = std::string(HEXA_SOURCE_DIR) + "/deploy/plot_session.py";
  std::string title = a.Get("title", "");
  if (title.empty()) {
    for (const char* k : {"trajectory", "controller", "profile", "mode"}) {
      auto it = report.meta.find(k);
      if (it != report.meta.end()) title += (title.empty() ? "" : " / ") + it->second;
    }
    if (title.empty()) title = "session";
  }
  const pid_t pid = fork();
  if (pid == 0) {
    execl(python.c_str(), python.c_str(), script.c_str(), out.c_str(), "--title", title.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "hexa_recorder report: the plots failed (%s %s); the "
                 "figures in report.md / report.json are complete\n", python.c_str(), script.c_str());
    return kExitError;
  }
  return kExitOk;
}

}  // namespace hexa::recorder::cli
