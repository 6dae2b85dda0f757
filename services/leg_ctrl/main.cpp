// hexa_leg_ctrl: the position controller of one leg (BS-SMC, Sec. 3.2, or the PI baseline).
#include <cstdio>
#include <exception>

#include "hexa/services/logging.hpp"
#include "leg_node.hpp"

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_leg_ctrl",
                        "Position controller of one leg: answers each sensor sample of its leg "
                        "with a valve command (1 kHz).");
  hexa::node::AddCommonOptions(cli);
  cli.AddOption("leg", "1..6", "the leg this process controls");
  cli.AddChoice("controller", {"bssmc", "pi", "excite"},
                "control law; excite = identification experiment: open-loop valve excitation "
                "inside --excite-start / --excite-duration, BS-SMC outside", "bssmc");
  cli.AddOption("excite-start", "s", "excite: simulated time the leg's excitation starts", "1");
  cli.AddOption("excite-duration", "s", "excite: length of the excitation window", "30");
  cli.AddOption("excite-seed", "N", "excite: seed of the pseudo-random sequence", "1");
  cli.AddFlag("standby", "hot standby: same law, lower ownership strength");
  cli.AddChoice("fault", {"none", "crash", "hang", "slow", "garbage", "silence"},
                "fault injection (safety tests)", "none");
  cli.AddOption("fault-at", "s", "simulated time at which the fault starts", "0");
  cli.AddOption("fault-slow", "s", "extra time per cycle for --fault slow", "0.005");
  cli.AddOption("startup-timeout", "s", "the plant must appear within this", "30");
  cli.AddOption("valve-readers", "N",
                "readers of this leg's valve commands to match before running: 1 = the plant, "
                "2 = the plant and a recorder (so that the recording has tick 0 on)", "1");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  if (!cli.Has("leg")) {
    std::fprintf(stderr, "error: --leg is required (1..6)\n(see --help)\n");
    return 2;
  }
  hexa::leg_ctrl::LegNodeOptions o;
  const auto leg = cli.GetInt("leg", 1, 6);
  const auto at = cli.GetDouble("fault-at", 0, 1e7);
  const auto slow = cli.GetDouble("fault-slow", 0, 10);
  const auto startup = cli.GetDouble("startup-timeout", 0.1, 3600);
  const auto valve_readers = cli.GetInt("valve-readers", 1, 16);
  const auto excite_start = cli.GetDouble("excite-start", 0, 1e7);
  const auto excite_duration = cli.GetDouble("excite-duration", 0, 1e7);
  const auto excite_seed = cli.GetInt("excite-seed", 0, 1LL << 62);
  if (!hexa::node::ReadCommonOptions(cli, o.common) || !leg || !at || !slow || !startup ||
      !valve_readers || !excite_start || !excite_duration || !excite_seed) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
  }
  o.leg = static_cast<int>(*leg);
  o.controller = cli.Get("controller") == "pi"       ? hexa::LegControllerKind::kPi
                 : cli.Get("controller") == "excite" ? hexa::LegControllerKind::kExcitation
                                                      : hexa::LegControllerKind::kBsSmc;
  o.excitation.start_s = *excite_start;
  o.excitation.duration_s = o.controller == hexa::LegControllerKind::kExcitation ? *excite_duration : 0.0;
  o.excitation.seed = static_cast<std::uint64_t>(*excite_seed);
  o.standby = cli.Flag("standby");
  hexa::leg_ctrl::ParseFaultKind(cli.Get("fault"), o.fault.kind);
  o.fault.at_sim_time_s = *at;
  o.fault.slow_extra_s = *slow;
  o.startup_timeout_s = *startup;
  o.valve_readers = static_cast<int>(*valve_readers);

  const std::string name = "leg" + std::to_string(o.leg) + (o.standby ? "_standby" : "");
  auto log = hexa::logging::Init(name, o.common.log_file, o.common.log_level);
  try {
    hexa::comm::EnsureDdsConfig(o.common.dds_config);
    auto config = hexa::node::LoadConfig(o.common, *log);
    if (!config) return 1;
    // Before the participant exists: Cyclone's threads inherit the policy (docs/platform_notes.md).
    // 80: the highest of the loop's processes; a leg has the tightest deadline (its 10 ms
    // liveliness lease) and the shortest work (docs/measurements/deployment.md, "Where the lapses' milliseconds go").
    auto latency_hold = hexa::node::ApplyScheduling(o.common, 80, *log);
    hexa::leg_ctrl::LegNode node(o, *config, log);
    const int rc = node.Run();
    // The loop is over: its teardown must not starve the processes still running (real time).
    hexa::node::LeaveRealtimeScheduling(o.common, latency_hold, *log);
    return rc;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
}
