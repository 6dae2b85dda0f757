// hexa_bridge's command line.
#include <cstdio>

#include "bridge_node.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/scheduling.hpp"

namespace hexa::bridge {
namespace {

void AddOptions(cli::Parser& cli) {
  cli.AddOption("domain", "id", "DDS domain id of the session", "0");
  cli.AddOption("dds-config", "file", "Cyclone DDS configuration (default: loopback only)");
  cli.AddOption("listen", "address",
                "IP address to serve on; the default serves this machine only. Give the "
                "control network's address to let other hosts connect", "127.0.0.1");
  cli.AddOption("port", "n", "TCP port (0 = any free port, printed at start)", "8765");
  cli.AddOption("client-queue-kb", "n",
                "per client: KiB of messages waiting for its socket (counted with their "
                "allocation overhead) before messages are dropped for that client (and counted)",
                "4096");
  cli.AddOption("max-clients", "n",
                "clients served at once; more connections are refused with HTTP 503 (logged)",
                "32");
  cli.AddOption("total-queue-mb", "n",
                "MiB of messages waiting for all clients together: each client's queue is "
                "capped at min(--client-queue-kb, this / --max-clients)", "128");
  cli.AddOption("cpus", "list|auto|none",
                "pin the bridge (every thread) to these CPUs; auto: off the CPU a session's "
                "control loop takes by default (hexa_session --cpus-control auto)", "auto");
  cli.AddOption("nice", "n", "scheduling niceness of every thread (0 = normal, 19 = lowest)",
                "10");
  cli.AddOption("stats-s", "s", "log every client's sent / dropped counts this often (0 = only "
                "when a client leaves)", "5");
  cli.AddFlag("operator-input",
              "accept the operator's commands (start stop reset home jog goal stream frames) from "
              "Foxglove clients on topic hexa_OperatorInput and forward them to the supervisor: "
              "whoever can connect can then move the platform (docs/foxglove.md, \"Operator input\")");
  cli.AddOption("operator-input-rate-hz", "hz",
                "per client: operator inputs a second beyond which they are refused", "10");
  cli.AddOption("operator-jog-rate-hz", "hz",
                "per client: jog messages a second beyond which they are refused (the supervisor's "
                "dead-man is 0.25 s: 5-10 Hz keeps a jog going)", "25");
  cli.AddFlag("operator-input-any-host",
              "allow --operator-input with a --listen address other than loopback");
  cli.AddOption("rig", "file", "rig file whose joints the 3-D scene draws",
                config::DefaultRigFile());
  cli.AddOption("profile", "name", "disturbance profile of the simulated plant (with --seed)");
  cli.AddOption("seed", "n", "seed of the simulated plant: the scene draws its true joints");
  cli.AddOption("scene-hz", "hz", "3-D scene frames per simulated second", "50");
  cli.AddOption("log-file", "file", "also log to this file");
}

}  // namespace

bool BridgeOptions::loopback() const {
  return server.listen_address.rfind("127.", 0) == 0 || server.listen_address == "::1";
}

int ParseOptions(int argc, char** argv, BridgeOptions& o) {
  cli::Parser cli("hexa_bridge",
                  "Serves the DDS topics of a running session and its 3-D scene over the "
                  "Foxglove WebSocket protocol (open ws://HOST:PORT in Foxglove).");
  AddOptions(cli);
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 232);
  const auto port = cli.GetInt("port", 0, 65535);
  const auto queue_kb = cli.GetInt("client-queue-kb", 1, 1 << 20);
  const auto max_clients = cli.GetInt("max-clients", 1, 4096);
  const auto total_queue_mb = cli.GetInt("total-queue-mb", 1, 1 << 16);
  const auto nice = cli.GetInt("nice", 0, 19);
  const auto operator_rate_hz = cli.GetDouble("operator-input-rate-hz", 0.1, 100);
  const auto jog_rate_hz = cli.GetDouble("operator-jog-rate-hz", 1, 200);
  const auto stats_s = cli.GetDouble("stats-s", 0, 3600);
  const auto scene_hz = cli.GetDouble("scene-hz", 1, 1000);
  std::optional<long long> seed;
  if (cli.Has("seed")) seed = cli.GetInt("seed", 0, 1LL << 62);
  if (cli.Get("cpus") == "auto") {
    o.cpus = sched::AutoCpuSplit().others;
  } else if (cli.Get("cpus") != "none" && !sched::ParseCpuList(cli.Get("cpus"), o.cpus)) {
    std::fprintf(stderr, "hexa_bridge: error: --cpus '%s': expected CPU numbers such as 1, 0,1 "
                 "or 0-1, auto or none\n", cli.Get("cpus").c_str());
    return exit_code::kUsage;
  }
  if (!domain || !port || !queue_kb || !max_clients || !total_queue_mb || !nice || !stats_s ||
      !scene_hz || !operator_rate_hz || !jog_rate_hz || (cli.Has("seed") && !seed)) {
    return services::UsageError(cli, "hexa_bridge");
  }
  o.domain_id = static_cast<int>(*domain);
  if (cli.Has("dds-config")) o.dds_config = cli.Get("dds-config");
  if (cli.Has("log-file")) o.log_file = cli.Get("log-file");
  o.nice = static_cast<int>(*nice);
  o.stats_s = *stats_s;
  o.scene_hz = *scene_hz;
  o.rig_path = cli.Get("rig");
  if (cli.Has("profile")) o.profile = cli.Get("profile");
  if (seed) o.seed = static_cast<std::uint64_t>(*seed);
  ServerConfig& sc = o.server;
  sc.listen_address = cli.Get("listen");
  sc.port = static_cast<uint16_t>(*port);
  sc.client_queue_bytes = static_cast<std::size_t>(*queue_kb) * 1024;
  sc.max_clients = static_cast<std::size_t>(*max_clients);
  sc.total_queue_bytes = static_cast<std::size_t>(*total_queue_mb) << 20;
  sc.operator_input = cli.Flag("operator-input");
  sc.operator_input_rate_hz = *operator_rate_hz;
  sc.operator_input_burst = std::max(1.0, *operator_rate_hz);
  sc.operator_jog_rate_hz = *jog_rate_hz;
  if (sc.operator_input && !o.loopback() && !cli.Flag("operator-input-any-host")) {
    std::fprintf(stderr, "hexa_bridge: error: --operator-input with --listen %s: every host that "
                 "can reach it could move the platform; add --operator-input-any-host to mean "
                 "it (docs/foxglove.md)\n", sc.listen_address.c_str());
    return exit_code::kUsage;
  }
  return -1;
}

}  // namespace hexa::bridge
