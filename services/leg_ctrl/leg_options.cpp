// hexa_leg_ctrl's command line: the common service options and the leg's own.
#include <cstdio>

#include "hexa/services/exit_code.hpp"
#include "hexa/services/runtime.hpp"
#include "leg_node.hpp"

namespace hexa::leg_ctrl {

std::string NodeName(const LegNodeOptions& o) {
  return "leg" + std::to_string(o.leg) + (o.standby ? "_standby" : "");
}

int ParseOptions(int argc, char** argv, LegNodeOptions& o) {
  cli::Parser cli("hexa_leg_ctrl",
                  "Position controller of one leg: answers each sensor sample of its leg "
                  "with a valve command (1 kHz).");
  node::AddCommonOptions(cli);
  cli.AddOption("leg", "1..6", "the leg this process controls");
  cli.AddChoice("controller", {"bssmc", "pi", "excite"},
                "control law; excite = identification experiment: open-loop valve excitation "
                "inside --excite-start / --excite-duration, BS-SMC outside", "bssmc");
  cli.AddOption("excite-start", "s", "excite: simulated time the leg's excitation starts", "1");
  cli.AddOption("excite-duration", "s", "excite: length of the excitation window", "30");
  cli.AddOption("excite-seed", "N", "excite: seed of the pseudo-random sequence", "1");
  cli.AddFlag("standby", "hot standby: same law, lower ownership strength");
  cli.AddFlag("coupled-legs",
              "the coupled leg feedback (the rig file's leg_controller.coupled_legs, turned on "
              "whatever its 'enabled' says; docs/controller_additions.md \"Coupled leg "
              "feedback\")");
  cli.AddChoice("fault", {"none", "crash", "hang", "slow", "garbage", "silence"},
                "fault injection (safety tests)", "none");
  cli.AddOption("fault-at", "s", "simulated time at which the fault starts", "0");
  cli.AddOption("fault-slow", "s", "extra time per cycle for --fault slow", "0.005");
  cli.AddOption("startup-timeout", "s", "the plant must appear within this", "30");
  cli.AddOption("valve-readers", "N",
                "readers of this leg's valve commands to match before running: 1 = the plant, "
                "2 = the plant and a recorder (so that the recording has tick 0 on)", "1");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  if (!cli.Has("leg")) {
    std::fprintf(stderr, "error: --leg is required (1..6)\n(see --help)\n");
    return exit_code::kUsage;
  }
  const auto leg = cli.GetInt("leg", 1, 6);
  const auto at = cli.GetDouble("fault-at", 0, 1e7);
  const auto slow = cli.GetDouble("fault-slow", 0, 10);
  const auto startup = cli.GetDouble("startup-timeout", 0.1, 3600);
  const auto valve_readers = cli.GetInt("valve-readers", 1, 16);
  const auto excite_start = cli.GetDouble("excite-start", 0, 1e7);
  const auto excite_duration = cli.GetDouble("excite-duration", 0, 1e7);
  const auto excite_seed = cli.GetInt("excite-seed", 0, 1LL << 62);
  if (!node::ReadCommonOptions(cli, o.common) || !leg || !at || !slow || !startup ||
      !valve_readers || !excite_start || !excite_duration || !excite_seed) {
    return services::UsageError(cli);
  }
  o.leg = static_cast<int>(*leg);
  o.controller = cli.Get("controller") == "pi"       ? LegControllerKind::kPi
                 : cli.Get("controller") == "excite" ? LegControllerKind::kExcitation
                                                      : LegControllerKind::kBsSmc;
  o.excitation.start_s = *excite_start;
  o.excitation.duration_s = o.controller == LegControllerKind::kExcitation ? *excite_duration : 0.0;
  o.excitation.seed = static_cast<std::uint64_t>(*excite_seed);
  o.standby = cli.Flag("standby");
  o.coupled_legs = cli.Flag("coupled-legs");
  ParseFaultKind(cli.Get("fault"), o.fault.kind);
  o.fault.at_sim_time_s = *at;
  o.fault.slow_extra_s = *slow;
  o.startup_timeout_s = *startup;
  o.valve_readers = static_cast<int>(*valve_readers);
  return -1;
}

}  // namespace hexa::leg_ctrl
