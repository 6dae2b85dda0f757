// hexa_plant_sim's command line: the common service options and the plant's own.
#include <cstdio>
#include <cstdlib>

#include "hexa/services/exit_code.hpp"
#include "plant_node.hpp"

namespace hexa::plant_sim {
namespace {

void AddOptions(cli::Parser& cli) {
  node::AddCommonOptions(cli);
  cli.AddOption("profile", "name", "disturbance profile of the rig file (realistic, ideal)",
                "realistic");
  cli.AddOption("seed", "N", "seed of noise and calibration errors", "1");
  cli.AddOption("legs", "N", "leg controllers that must answer (lockstep)", "6");
  cli.AddFlag("supervisor", "the supervisor must be running before the first tick (lockstep: the "
              "legs then wait for its setpoints, docs/architecture.md)");
  cli.AddFlag("expect-recorder", "wait for the recorder before the first tick");
  cli.AddFlag("expect-standbys", "wait for a hot standby per leg before the first tick (a "
              "standby that misses ticks no longer computes its primary's commands)");
  cli.AddOption("duration", "s", "stop after this simulated time (0 = until stopped)", "0");
  cli.AddOption("startup-timeout", "s", "peers must be ready within this", "30");
  cli.AddFlag("tracker", "publish the external pose instrument hexa_TrackerPose (laser tracker, "
                         "100 Hz, for kinematic calibration; never read by a controller)");
  // 15 ms: this VM shows scheduling stalls of several ms even under SCHED_FIFO
  // (docs/platform_notes.md), and a hot-standby hand-over takes the 10 ms liveliness lease + 0.5 ms;
  // a late command is still used within it, beyond it the valve closes.
  cli.AddOption("summary", "file", "write the run's figures (ticks, command ages per leg, ...) "
                "as JSON here at exit");
  cli.AddOption("stale-ticks", "N", "real time: ticks a command may lag before null + fault", "15");
  cli.AddOption("startup-grace-ticks", "N",
                "real time: ticks a leg's first command may take before it is missing", "500");
  cli.AddOption("lose-supervisor-inputs", "tick",
                "lockstep fault injection: withhold the supervisor's inputs of this tick (a "
                "multiple of 5; its six leg samples in the all-legs partition and its IMU "
                "sample) as if lost on the wire; the re-ask must recover them (-1 = none)",
                "-1");
  cli.AddChoice("bench", {"none", "free-fall"},
                "free-fall: simulate the Appendix B free-fall bench (each leg's cylinder hung rod "
                "down, chambers vented, a load on the rod, released at --bench-release-s) instead "
                "of the platform", "none");
  cli.AddOption("bench-load-kg", "kg", "free-fall bench: load hung on each rod", "12");
  cli.AddOption("bench-release-s", "s", "free-fall bench: simulated time of the release", "0.5");
  cli.AddOption("truth-out", "file",
                "write the plant's true parameters (hexa.rec.PlantTruth, text format) to this "
                "file at start-up, for evaluation (docs/identification.md)");
  cli.AddOption("compute-budget", "s",
                "leg controllers' compute time per cycle (ValveCommand.compute_time_s) beyond "
                "which a cycle overruns", "0.0005");
  cli.AddOption("compute-overrun-cycles", "N",
                "consecutive overrunning cycles of a leg that make a FAULT_COMPUTE_OVERRUN", "20");
  cli.AddChoice("device", {"sim", "board"},
                "the rig behind the plant's device seam: sim (simulated here) or board (a remote "
                "I/O board over UDP, docs/board_protocol.md: hexa_board_emulator or hardware)",
                "sim");
  cli.AddOption("board-address", "HOST:PORT",
                "--device board: the board's dotted IPv4 address and UDP port, e.g. 127.0.0.1:5005");
  cli.AddOption("board-timeout", "s",
                "--device board: the board must answer a command within this (bring-up; lockstep: "
                "every tick)", "2");
  cli.AddOption("board-lost-ticks", "N",
                "--device board: ticks in a row without an intact sensor frame (lost, refused) after "
                "which the link is lost (FAULT_BOARD_LINK, exit 7; lockstep: also no answer within "
                "--board-timeout)", "20");
  cli.AddChoice("activation", {"auto", "operator"},
                "the hardware lifecycle (docs/faults.md, \"Hardware lifecycle\"): auto activates the "
                "valves at the first tick, once the peers are up; operator keeps them at their safe "
                "state (sensors published, commands computed but not applied) until an operator "
                "start or home (hexa_operator) is granted. Either activation is refused, named, "
                "with the e-stop open, a leg without a live controller, a sensor out of range or "
                "the supply pressure low", "auto");
  cli.AddOption("fault", "kind:leg:time_s[,...]",
                "inject rig faults (docs/faults.md): pot-stuck, pot-drift, pressure-dead (leg "
                "1..6), imu-dropout, supply-loss (leg 0); e.g. pot-stuck:3:1.5");
}

// "HOST:PORT" with a dotted IPv4 host and a port 1..65535; "" or the error.
std::string ParseBoardAddress(const std::string& text, BoardLinkOptions& b) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0)
    return "--board-address '" + text + "': expected HOST:PORT (e.g. 127.0.0.1:5005)";
  b.host = text.substr(0, colon);
  const std::string port = text.substr(colon + 1);
  char* end = nullptr;
  const long value = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || value < 1 || value > 65535)
    return "--board-address '" + text + "': port '" + port + "' is not in 1..65535";
  b.port = static_cast<std::uint16_t>(value);
  if (!device::ParseIpv4(b.host, b.port))
    return "--board-address '" + text + "': host '" + b.host + "' is not a dotted IPv4 address";
  return {};
}

// Reads the parsed options into `o`; false with the error printed (exit_code::kUsage).
bool ReadOptions(cli::Parser& cli, PlantNodeOptions& o) {
  const auto seed = cli.GetInt("seed", 0, 1LL << 62);
  const auto legs = cli.GetInt("legs", 0, 6);
  const auto duration = cli.GetDouble("duration", 0, 1e7);
  const auto startup = cli.GetDouble("startup-timeout", 0.1, 3600);
  const auto stale = cli.GetInt("stale-ticks", 0, 1000);
  const auto grace = cli.GetInt("startup-grace-ticks", 0, 600000);
  const auto lose = cli.GetInt("lose-supervisor-inputs", -1, 1LL << 40);
  const auto bench_load = cli.GetDouble("bench-load-kg", 0, 1000);
  const auto bench_release = cli.GetDouble("bench-release-s", 0, 1e6);
  const auto budget = cli.GetDouble("compute-budget", 1e-6, 10);
  const auto overrun = cli.GetInt("compute-overrun-cycles", 1, 1000000);
  const auto board_timeout = cli.GetDouble("board-timeout", 0.01, 60);
  const auto board_lost = cli.GetInt("board-lost-ticks", 1, 100000);
  if (!node::ReadCommonOptions(cli, o.common) || !seed || !legs || !duration || !startup ||
      !stale || !grace || !lose || !bench_load || !bench_release || !budget ||
      !overrun || !board_timeout || !board_lost) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return false;
  }
  o.compute_budget.budget_s = *budget;
  o.compute_budget.overrun_limit = static_cast<std::uint64_t>(*overrun);
  if (cli.Has("fault")) {
    const std::string error = ParsePlantFaultList(cli.Get("fault"), o.plant_faults.faults);
    if (!error.empty()) {
      std::fprintf(stderr, "error: --fault %s\n(see --help)\n", error.c_str());
      return false;
    }
  }
  o.device = cli.Get("device") == "board" ? DeviceKind::kBoard
                                           : DeviceKind::kSim;
  o.activation = cli.Get("activation") == "operator" ? HardwareActivation::kOperator
                                                    : HardwareActivation::kAuto;
  o.board.answer_timeout_s = *board_timeout;
  o.board.lost_after_ticks = static_cast<std::uint64_t>(*board_lost);
  if (o.device == DeviceKind::kBoard) {
    if (!cli.Has("board-address")) {
      std::fprintf(stderr, "error: --device board needs --board-address HOST:PORT\n(see --help)\n");
      return false;
    }
    if (const std::string error = ParseBoardAddress(cli.Get("board-address"), o.board); !error.empty()) {
      std::fprintf(stderr, "error: %s\n(see --help)\n", error.c_str());
      return false;
    }
  } else if (cli.Has("board-address")) {
    std::fprintf(stderr, "error: --board-address is for --device board (the device is sim)\n(see --help)\n");
    return false;
  }
  o.profile = cli.Get("profile");
  o.seed = static_cast<std::uint64_t>(*seed);
  o.expected_legs = static_cast<int>(*legs);
  o.expect_supervisor = cli.Flag("supervisor");
  o.expect_recorder = cli.Flag("expect-recorder");
  o.expect_standbys = cli.Flag("expect-standbys");
  o.duration_s = *duration;
  o.startup_timeout_s = *startup;
  o.realtime_stale_ticks = static_cast<std::uint64_t>(*stale);
  o.startup_grace_ticks = static_cast<std::uint64_t>(*grace);
  o.summary_path = cli.Get("summary");
  o.truth_out_path = cli.Get("truth-out");
  o.tracker = cli.Flag("tracker");
  o.lose_supervisor_inputs_tick = *lose;
  if (o.lose_supervisor_inputs_tick >= 0 && o.lose_supervisor_inputs_tick % 5 != 0) {
    std::fprintf(stderr, "error: --lose-supervisor-inputs %lld: not a supervisor tick (a multiple "
                 "of 5)\n", static_cast<long long>(o.lose_supervisor_inputs_tick));
    return false;
  }
  o.free_fall.enabled = cli.Get("bench") == "free-fall";
  o.free_fall.load_kg = *bench_load;
  o.free_fall.release_s = *bench_release;
  return true;
}

}  // namespace

int ParseOptions(int argc, char** argv, PlantNodeOptions& o) {
  cli::Parser cli("hexa_plant_sim",
                  "The rig's I/O node and clock master: publishes leg sensors (1 kHz), IMU "
                  "(200 Hz) and (simulated rig) ground truth; applies the leg controllers' "
                  "valve commands to the simulated rig or to a remote I/O board (--device).");
  AddOptions(cli);
  const bool parsed = cli.Parse(argc, argv);
  if (const int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  if (!ReadOptions(cli, o)) return exit_code::kUsage;
  return -1;
}

}  // namespace hexa::plant_sim
