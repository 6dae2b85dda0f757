// hexa_multihost_bench: the networked deployment's figures (docs/measurements/deployment.md):
// five hosts in network namespaces, every process from its generated unit, DDS Security on
// (or off for the side-by-side cost), z trajectory. Scenarios:
//   lockstep        secured lockstep session: speed, RMSE, round trip, loss, bit-identity
//   lockstep-plain  the same without DDS Security (cost of security, same run)
//   realtime        secured real-time session: RMSE, round trip, loss, faults
//   realtime-plain  the same without DDS Security
//   loss            real time with nftables `numgen random` drops on the input of legs-a
//                   (sensors and setpoints of legs 1-3), for each --loss percentage
//   recorder-loss   real time with drops on the recorder host's input: the recorder's loss
//                   count beside the packets nftables dropped
//   partition       real time, operator-driven: start, cut legs-a off for --partition-ms,
//                   heal, reset, start again; detection delay, HOLD, resumption
// Needs root (network namespaces, nftables). Timing figures depend on the machine's load:
// the bench prints the load average with each row. Not a test: nothing is asserted.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/services/cli.hpp"
#include "multihost_session.hpp"

using namespace hexa::deploy;
using namespace hexa::deploy::multihost;

namespace {

void AddOptions(hexa::cli::Parser& cli) {
  cli.AddOption("scenarios", "list", "comma list: lockstep lockstep-plain realtime realtime-plain loss recorder-loss partition",
                "lockstep,lockstep-plain,realtime,loss,recorder-loss,partition");
  cli.AddOption("runs", "N", "runs of each session scenario", "1");
  cli.AddOption("loss", "list", "loss percentages of the loss scenarios", "1,5");
  cli.AddOption("partition-ms", "ms", "length of the partition", "300");
  cli.AddOption("build", "dir", "build directory", HEXA_BUILD_DIR);
  cli.AddOption("stale-ticks", "N", "real time: the plant's stale-command tolerance (0 = default 15)", "0");
  cli.AddChoice("metadata-protection", {"default", "ENCRYPT", "SIGN", "NONE"},
                "secured scenarios: the governance's metadata protection (data stay ENCRYPTED)",
                "default");
  cli.AddChoice("loop-metadata-protection", {"default", "ENCRYPT", "SIGN", "NONE"},
                "secured scenarios: the metadata protection of the 1 kHz loop topics (LegSensors, "
                "ValveCommand, GroundTruth; default: the deployment's default, as the metadata: ENCRYPT)",
                "default");
  cli.AddOption("plant-delay-s", "s",
                "start the plant this long after every other process (their discovery and "
                "security handshakes with each other done before the clock starts)", "0");
  cli.AddFlag("no-cpu-placement",
              "leave every process unpinned (default: the one-machine session's CPU placement)");
  cli.AddFlag("split-legs-b",
              "with the CPU placement: the primary legs of host legs-b on the first CPU (with the "
              "supervisor and the recorder) instead of beside the plant on the last");
  cli.AddFlag("faults-plain", "run the loss / recorder-loss / partition scenarios without DDS Security");
  cli.AddFlag("capture-drops",
              "loss / recorder-loss: capture every packet the loss rule drops (nftables log to an "
              "nflog group, tcpdump in the lossy host's namespace) to <logs>/dropped.pcap, for "
              "bench/deployment/dropped_datagrams.py");
  cli.AddOption("deployment", "name|file",
                "the hosts and processes: five-hosts (default: the built-in five-host layout, the same "
                "as deploy/deployments/five-hosts.textproto), four-hosts "
                "(deploy/deployments/four-hosts.textproto: no standbys) or a deployment file",
                "five-hosts");
}

// A real-time session with `percent` % of the packets into `host` dropped by nftables from the
// plant's READY on (legs-a: sensors and setpoints of legs 1-3; recorder: the recorder's link).
Row RunLoss(const LabSessionOptions& base, int percent, const char* host, bool secure, bool capture,
            const std::vector<std::string>& auto_args) {
  auto o = base;
  o.realtime = true;
  o.secure = secure;
  o.supervisor_args = auto_args;
  bool applied = false, failed = false;
  long long dropped = -1, input = -1;
  Row row = RunSession(std::string(o.secure ? "rt secured " : "rt plain ") + std::to_string(percent) + "% loss " + host, o,
                       [&](LabSession& s, double since_ready) {
                         std::string err;
                         if (!applied && !failed && since_ready >= 0) {
                           // The capture listens before the rule logs to its group: a
                           // packet logged to a group nobody reads is not kept.
                           if (capture && !StartDropCapture(s, host, err)) {
                             failed = true;
                             std::fprintf(stderr, "%s\n", err.c_str());
                             return;
                           }
                           applied = s.lab().SetInputLoss(host, percent, err, "", capture ? kDropLogGroup : 0);
                           failed = !applied;
                           if (failed) std::fprintf(stderr, "%s\n", err.c_str());
                         }
                         if (applied) {
                           dropped = std::max(dropped, s.lab().DroppedInput(host));
                           input = std::max(input, s.lab().InputPackets(host));
                         }
                       });
  row.dropped = dropped;
  row.input_packets = input;
  return row;
}

// The session scenarios (all but the partition), --runs times each.
void RunSessionScenarios(const hexa::cli::Parser& cli, const LabSessionOptions& base, long long runs,
                         const std::vector<int>& losses) {
  const std::string scenarios = "," + cli.Get("scenarios") + ",";
  auto want = [&](const std::string& s) { return scenarios.find("," + s + ",") != std::string::npos; };
  const std::vector<std::string> auto_args{"--trajectory", "z", "--periods", "1", "--autostart", "--exit-when-done"};
  for (long long k = 0; k < runs; ++k) {
    if (want("lockstep")) {
      auto o = base;
      o.supervisor_args = auto_args;
      Print(RunSession("lockstep secured", o));
    }
    if (want("lockstep-plain")) {
      auto o = base;
      o.secure = false;
      o.supervisor_args = auto_args;
      Print(RunSession("lockstep plain", o));
    }
    if (want("realtime")) {
      auto o = base;
      o.realtime = true;
      o.supervisor_args = auto_args;
      o.watchdog_s = 0;
      Print(RunSession("realtime secured", o));
    }
    if (want("realtime-plain")) {
      auto o = base;
      o.realtime = true;
      o.secure = false;
      o.supervisor_args = auto_args;
      o.watchdog_s = 0;
      Print(RunSession("realtime plain", o));
    }
    for (int p : losses) {
      for (const char* host : {"legs-a", "recorder"}) {
        if (want(std::string(host) == "recorder" ? "recorder-loss" : "loss"))
          Print(RunLoss(base, p, host, !cli.Flag("faults-plain"), cli.Flag("capture-drops"), auto_args));
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_multihost_bench",
                        "Networked deployment figures: four or five hosts in network namespaces (root).");
  AddOptions(cli);
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto runs = cli.GetInt("runs", 1, 100);
  const auto partition_ms = cli.GetDouble("partition-ms", 1, 100000);
  const auto stale = cli.GetInt("stale-ticks", 0, 1000);
  if (!runs || !partition_ms || !stale) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  if (geteuid() != 0) {
    std::fprintf(stderr, "error: needs root (network namespaces, nftables)\n");
    return 1;
  }
  const std::string build = cli.Get("build");
  const std::string scenarios = "," + cli.Get("scenarios") + ",";
  auto want = [&](const char* s) { return scenarios.find(std::string(",") + s + ",") != std::string::npos; };
  std::vector<int> losses;
  {
    std::stringstream ss(cli.Get("loss"));
    for (std::string x; std::getline(ss, x, ',');) losses.push_back(std::stoi(x));
  }
  const int domain = 60 + getpid() % 40;
  LabSessionOptions base = BaseOptions(build, HEXA_SOURCE_DIR, "b", domain);
  base.stale_ticks = static_cast<int>(*stale);
  if (cli.Get("metadata-protection") != "default") base.metadata_protection = cli.Get("metadata-protection");
  if (cli.Get("loop-metadata-protection") != "default")
    base.loop_metadata_protection = cli.Get("loop-metadata-protection");
  base.cpu_placement = !cli.Flag("no-cpu-placement");
  base.split_legs_b = cli.Flag("split-legs-b");
  const auto plant_delay = cli.GetDouble("plant-delay-s", 0, 300);
  if (!plant_delay) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  base.plant_start_delay_s = *plant_delay;
  const std::string deployment = cli.Get("deployment");
  if (deployment != "five-hosts") {
    base.layout_file = deployment.find('/') == std::string::npos && deployment.find('.') == std::string::npos
                           ? std::string(HEXA_SOURCE_DIR) + "/deploy/deployments/" + deployment + ".textproto"
                           : deployment;
  }

  std::printf("deployment %s in network namespaces, z trajectory (1 period, 13 s simulated), DDS Security on "
              "unless '-plain' (metadata protection %s, loop topics %s); real-time stale tolerance %d ticks; CPU placement %s; "
              "plant started %.1f s after the others; "
              "machine shared (load average per row)\n\n",
              base.layout_file.empty() ? "five-hosts (built-in layout)" : base.layout_file.c_str(),
              cli.Get("metadata-protection").c_str(), cli.Get("loop-metadata-protection").c_str(), base.stale_ticks > 0 ? base.stale_ticks : 15,
              !base.cpu_placement ? "none"
              : base.split_legs_b ? "as the one-machine session but legs-b's legs on the first CPU"
                                  : "as the one-machine session",
              base.plant_start_delay_s);
  std::printf("| scenario | done | wall s | sim/wall | CPU s per sim s: all, loop | RMSE x y z mm | rtt med us | rtt p99 us | missing | faults | dropped pkts | load | notes\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  RunSessionScenarios(cli, base, *runs, losses);
  if (want("partition")) {
    LabSessionOptions o = base;
    o.secure = !cli.Flag("faults-plain");
    Partition(o, *partition_ms, build + "/services/task_space/hexa_operator");
  }
  return 0;
}
