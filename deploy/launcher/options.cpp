// hexa_session's options: their definitions (the --help text, docs/cli/hexa_session.md) and
// the checks that refuse a bad command line with exit 2 before anything starts.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include "hexa/core/plant_faults.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/scheduling.hpp"
#include "launcher.hpp"

namespace hexa::launcher {
namespace {

namespace fs = std::filesystem;
constexpr int kContinue = -1;

std::string Timestamp() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  return buf;
}

// What runs: trajectory, controller, plant, time base, files, recording, the processes.
void AddSessionOptions(hexa::cli::Parser& cli) {
  cli.AddOption("trajectory", "name|file.csv",
                "x y z roll pitch yaw (pure motions, Table 9), combined (eq 49, Table 10), "
                "calibration (kinematic calibration poses, with --tracker; docs/calibration.md), "
                "or a CSV file (docs/trajectories.md)", "combined");
  cli.AddChoice("controller", {"bssmc", "pi"}, "leg position controller", "bssmc");
  cli.AddChoice("profile", {"realistic", "ideal"}, "plant disturbance profile", "realistic");
  cli.AddChoice("mode", {"lockstep", "realtime"}, "time base", "lockstep");
  cli.AddOption("seed", "N", "random seed of the plant (noise, calibration errors)", "1");
  cli.AddOption("out", "dir", "output directory (default: out/session-<timestamp>)");
  cli.AddOption("rig", "file", "rig file (protobuf text format)", HEXA_DEFAULT_RIG_FILE);
  cli.AddRepeatable("rig-overlay", "file",
                    "rig overlay (identified / calibrated values) for the leg controllers and the "
                    "supervisor; the plant keeps the rig file + profile (docs/config.md)");
  cli.AddChoice("experiment", {"none", "identify", "free-fall"},
                "identify: the identification experiment instead of a trajectory: the legs of "
                "--legs are driven open loop one after the other (steps, pseudo-random levels, "
                "chirp, position guard) while the others hold; recorded with the plant's truth "
                "for hexa_identify (docs/identification.md); free-fall: the Appendix B free-fall "
                "bench (every cylinder hung rod down, chambers vented, a load, released at "
                "0.5 s) for hexa_identify --free-fall", "none");
  cli.AddOption("free-fall-load-kg", "kg", "--experiment free-fall: load hung on each rod", "12");
  cli.AddOption("legs", "list", "--experiment identify: legs to excite (1-6, 1,3, ...)", "1-6");
  cli.AddOption("excite-duration", "s", "--experiment identify: excitation per leg", "30");
  cli.AddOption("dds-config", "file", "Cyclone DDS configuration", HEXA_DEFAULT_CYCLONE_CONFIG);
  cli.AddOption("domain", "id",
                "DDS domain id (default: derived from the pid, 100-199, the next free one if "
                "another session uses it); a domain with other participants on it is refused");
  cli.AddOption("periods", "N", "trajectory periods to track (0 = the trajectory's default)", "0");
  cli.AddOption("timeout", "s", "wall-clock limit of the session (0 = none)", "0");
  cli.AddOption("hold-timeout", "s",
                "after a fault the platform is held and the session waits this long (simulated "
                "time: wall time in real time, the machine's pace in lockstep) for an operator "
                "reset (hexa_operator --domain D reset), which resumes the trajectory from the "
                "held pose; without one the session ends held (exit 3)", "30");
  cli.AddFlag("no-recorder", "do not record (no report)");
  cli.AddOption("record-split-mb", "MB",
                "split the recording into files of this size (10^6 bytes; 0 = one file): "
                "session.mcap is the open part, the closed ones session-0001.mcap, ... (a "
                "real-time session records about 4.6 GB an hour); the report covers the parts "
                "still on disk", "0");
  cli.AddOption("record-split-s", "s", "split the recording every s seconds (0 = never)", "0");
  cli.AddOption("record-keep-files", "N",
                "with a split: keep at most N recording files, deleting the oldest parts (0 = all)",
                "0");
  cli.AddFlag("no-outer-loop", "disable the task-space outer loop");
  cli.AddFlag("no-feedforward",
              "no platform inverse-dynamics feed-forward on the leg setpoints (paper-faithful)");
  cli.AddFlag("stream",
              "the supervisor accepts the external motion stream on UDP 127.0.0.1:--stream-port; "
              "`hexa_operator stream` starts following it (docs/operate.md); off by default");
  cli.AddOption("stream-port", "port", "--stream: the UDP port", "47800");
  cli.AddFlag("tracker", "the plant publishes the external pose instrument (hexa_TrackerPose, for "
                         "hexa_calibrate; use with --trajectory calibration)");
  cli.AddFlag("standby", "also start a hot-standby controller per leg");
  cli.AddFlag("coupled-legs",
              "the leg controllers run the coupled leg feedback (the rig file's "
              "leg_controller.coupled_legs, turned on; docs/controller_additions.md \"Coupled "
              "leg feedback\")");
  cli.AddChoice("device", {"sim", "board"},
                "the rig behind the plant: sim (the plant simulates it) or board (the session also "
                "runs hexa_board_emulator on 127.0.0.1 at a free UDP port, stepped once per command "
                "in lockstep, on the wall clock in real time, and the plant drives it over the "
                "board protocol: docs/board_protocol.md)", "sim");
  cli.AddRepeatable("board-arg", "arg",
                    "--device board: an argument passed on to hexa_board_emulator as given (e.g. "
                    "--board-arg=--estop-open --board-arg=2500:4000)");
}

// Where and how the processes run: CPUs, scheduling, the bridge, security, leases, faults.
void AddProcessOptions(hexa::cli::Parser& cli) {
  cli.AddOption("cpus-control", "list|auto|none",
                "pin the plant, the leg controllers and the supervisor to these CPUs; auto: in "
                "real time the last CPU this process may use, when it may use two or more (the "
                "loop's wake-ups then stay on one CPU: docs/performance.md), in lockstep none "
                "(pinned at normal priority, real-time loops on that CPU starve them: "
                "docs/measurements/faults.md)", "auto");
  cli.AddOption("cpus-recorder", "list|auto|none",
                "pin the recorder to these CPUs; auto: the other CPUs when --cpus-control is auto",
                "auto");
  cli.AddOption("cpus-standby", "list|auto|none",
                "pin the hot standbys (--standby) to these CPUs; auto: the recorder's CPUs when "
                "--cpus-control is auto (twelve legs at SCHED_FIFO saturate one CPU and the "
                "kernel then stops them up to 50 ms a second: docs/performance.md), else the "
                "control CPUs", "auto");
  cli.AddOption("cpus-supervisor", "list|auto|none",
                "pin the supervisor to these CPUs; auto: the recorder's CPUs when --cpus-control "
                "is auto (a supervisor killed on the control CPU stalls the legs ~10 ms while the "
                "kernel tears it down: docs/faults.md), else the control CPUs", "auto");
  cli.AddOption("stale-ticks", "N",
                "real time: ticks a leg's command may lag before the plant closes its valve and "
                "reports it", "15");
  cli.AddFlag("no-rt-sched", "real time: do not ask for SCHED_FIFO (control 70-80, recorder 50)");
  cli.AddOption("cpu-latency-us", "N|none",
                "the plant, the leg controllers and the supervisor hold the kernel's CPU wake-up "
                "latency limit (/dev/cpu_dma_latency) at N us while they run, both modes; 0: idle "
                "CPUs poll instead of halting; none: the machine's setting (docs/performance.md)",
                "0");
  cli.AddChoice("rt-dds-event-thread", {"normal", "fifo"},
                "real time: scheduling of Cyclone's timed-event thread in the control processes "
                "(docs/performance.md)", "normal");
  cli.AddFlag("bridge", "also start hexa_bridge: the session live in Foxglove over WebSocket "
              "(docs/foxglove.md)");
  cli.AddOption("bridge-listen", "address", "address hexa_bridge serves on", "127.0.0.1");
  cli.AddOption("bridge-port", "n", "TCP port of hexa_bridge (0 = any free port, see bridge.log)",
                "8765");
  cli.AddOption("bridge-queue-kb", "n", "hexa_bridge --client-queue-kb", "4096");
  cli.AddOption("bridge-max-clients", "n", "hexa_bridge --max-clients", "32");
  cli.AddFlag("wait-for-operator",
              "the supervisor holds the home pose until an operator start (hexa_operator start, "
              "or Foxglove with --bridge-operator-input) instead of starting the trajectory "
              "itself; the session ends when the trajectory has finished or was stopped");
  cli.AddChoice("activation", {"auto", "operator"},
                "the hardware lifecycle (docs/faults.md, \"Hardware lifecycle\"): auto, the plant "
                "activates the valves at its first tick once every peer is up; operator, the valves "
                "stay at their safe state (sensors published, commands computed, not applied) until "
                "an operator start or home (hexa_operator) is granted; implies --wait-for-operator. "
                "Activation is refused, with the reason, when the e-stop is open, a leg has no live "
                "controller, a sensor is out of range or the supply pressure is low", "auto");
  cli.AddFlag("bridge-operator-input",
              "hexa_bridge --operator-input: Foxglove clients may start, stop, reset and home "
              "the platform (docs/foxglove.md)");
  cli.AddFlag("secure", "DDS Security for the whole session: a project CA, one identity per "
                        "process, signed governance and permissions, encryption on the wire "
                        "(files in <out>/security; docs/security.md)");
  cli.AddFlag("insecure-commands",
              "no session key: commands are not authenticated and ANY process on the domain can "
              "command the session (only to measure what the check costs; docs/faults.md, "
              "\"Foreign commands\")");
  cli.AddOption("rt-lease", "s",
                "real time: liveliness lease of the leg controllers (a leg silent this long is "
                "dead; docs/faults.md)", "0.01");
  cli.AddOption("lockstep-lease", "s",
                "lockstep: liveliness lease of the leg controllers and the supervisor: how soon "
                "a hot standby takes over; a lapse alone is no fault in lockstep, which waits "
                "for a slow or stopped process (docs/faults.md)", "0.2");
  cli.AddRepeatable("fault", "leg:kind:time_s",
                    "inject a fault into a primary leg controller, e.g. 3:crash:2.0 (kinds: crash "
                    "hang slow garbage silence), or supervisor:crash:time_s; repeatable, one fault "
                    "per process (docs/faults.md)");
  cli.AddOption("plant-fault", "kind:leg:time_s[,...]",
                "inject rig faults into the plant: pot-stuck, pot-drift, pressure-dead (leg "
                "1..6), imu-dropout, supply-loss (leg 0); e.g. pot-stuck:3:1.5 (docs/faults.md)");
  cli.AddRepeatable("plant-arg", "arg",
                    "one more argument for hexa_plant_sim, e.g. --plant-arg "
                    "--lose-supervisor-inputs --plant-arg 500 (fault injection; see "
                    "hexa_plant_sim --help)");
}

// --cpus-*: CPU lists, "auto" or "none" (docs/performance.md).
bool ParseCpus(const hexa::cli::Parser& cli, Options& o) {
  {
    // auto: in real time, the control loop on the last allowed CPU, the recorder on the
    // others. In lockstep, no pinning: the processes run at normal priority, and pinned to one
    // CPU they could not move off it when real-time loops (this machine's other sessions pin
    // to the same CPU at SCHED_FIFO) take it: a tick then waits past the 10 s last resort and
    // a secured start-up past 30 s (docs/measurements/faults_under_load.md, "Lockstep beside
    // real-time load").
    const hexa::sched::CpuSplit split =
        o.mode == "realtime" ? hexa::sched::AutoCpuSplit() : hexa::sched::CpuSplit{};
    if (cli.Get("cpus-control") == "auto") o.cpus_control = hexa::sched::FormatCpuList(split.control);
    if (cli.Get("cpus-recorder") == "auto")
      o.cpus_recorder = cli.Get("cpus-control") == "auto" ? hexa::sched::FormatCpuList(split.others) : "";
  }
  for (auto [name, field] : {std::pair{"cpus-control", &o.cpus_control},
                             std::pair{"cpus-recorder", &o.cpus_recorder},
                             std::pair{"cpus-standby", &o.cpus_standby},
                             std::pair{"cpus-supervisor", &o.cpus_supervisor}}) {
    if (cli.Get(name) == "auto" || cli.Get(name) == "none") continue;
    std::vector<int> cpus;
    if (!hexa::sched::ParseCpuList(cli.Get(name), cpus)) {
      std::fprintf(stderr, "error: --%s '%s': expected CPU numbers such as 1, 0,1 or 0-1\n",
                   name, cli.Get(name).c_str());
      return false;
    }
    *field = cli.Get(name);
  }
  // auto: off the control CPU when the CPUs are chosen automatically (the recorder's); with
  // one CPU, where the control runs. Standbys: a primary and its standby on different CPUs.
  const std::string off_control = cli.Get("cpus-control") == "auto" && !o.cpus_recorder.empty()
                                      ? o.cpus_recorder
                                      : o.cpus_control;
  if (cli.Get("cpus-standby") == "auto") o.cpus_standby = off_control;
  if (cli.Get("cpus-supervisor") == "auto") o.cpus_supervisor = off_control;
  // The bridge: off the control CPUs whichever they are, so that its clients cannot take
  // the loop's CPU (docs/foxglove.md); nowhere in particular when the control has none.
  std::vector<int> control, others;
  if (!o.cpus_control.empty() && hexa::sched::ParseCpuList(o.cpus_control, control))
    for (int c : hexa::sched::AllowedCpus())
      if (std::find(control.begin(), control.end(), c) == control.end()) others.push_back(c);
  o.cpus_bridge = hexa::sched::FormatCpuList(others);
  return true;
}

// The numbers, each within its range (the parser's message names the option and the limit).
bool ParseNumbers(hexa::cli::Parser& cli, Options& o) {
  auto seed = cli.GetInt("seed", 0, (1LL << 62));
  auto periods = cli.GetInt("periods", 0, 1000);
  auto timeout = cli.GetDouble("timeout", 0, 1e6);
  auto stale_ticks = cli.GetInt("stale-ticks", 1, 1000);
  auto rt_lease = cli.GetDouble("rt-lease", 0.003, 10);
  auto lockstep_lease = cli.GetDouble("lockstep-lease", 0.01, 60);
  std::optional<long long> domain = 100 + getpid() % 100;
  if (cli.Has("domain")) domain = cli.GetInt("domain", 0, 230);
  const auto excite_duration = cli.GetDouble("excite-duration", 1, 3600);
  const auto free_fall_load = cli.GetDouble("free-fall-load-kg", 0, 1000);
  const auto cpu_latency =
      cli.GetIntOrWord("cpu-latency-us", "none", -1, 0, hexa::sched::kMaxCpuLatencyUs);
  // Checked here, not only by the bridge: a bridge that refuses its port dies alone and the
  // session would go on without it.
  const auto bridge_port = cli.GetInt("bridge-port", 0, 65535);
  const auto hold_timeout = cli.GetDouble("hold-timeout", 0.001, 1e6);
  const auto split_mb = cli.GetDouble("record-split-mb", 0, 1e7);
  const auto split_s = cli.GetDouble("record-split-s", 0, 1e7);
  const auto keep_files = cli.GetInt("record-keep-files", 0, 1000000);
  if (!seed || !periods || !timeout || !domain || !stale_ticks || !excite_duration ||
      !free_fall_load || !rt_lease || !lockstep_lease || !cpu_latency || !bridge_port ||
      !hold_timeout || !split_mb || !split_s || !keep_files) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return false;
  }
  o.seed = *seed;
  o.split_recording = *split_mb > 0 || *split_s > 0;
  if (*keep_files > 0 && !o.split_recording) {
    std::fprintf(stderr, "error: --record-keep-files needs --record-split-mb or --record-split-s\n");
    return false;
  }
  o.bridge_port = std::to_string(*bridge_port);
  o.periods = *periods;
  o.timeout_s = *timeout;
  o.stale_ticks = *stale_ticks;
  o.domain = *domain;
  o.domain_chosen = !cli.Has("domain");
  o.excite_duration_s = *excite_duration;
  o.free_fall_load_kg = *free_fall_load;
  return true;
}

// --fault leg:kind:time_s or supervisor:crash:time_s, at most one per process.
bool ParseFaults(const hexa::cli::Parser& cli, Options& o) {
  for (const std::string& f : cli.GetAll("fault")) {
    const auto a = f.find(':'), b = f.find(':', a == std::string::npos ? a : a + 1);
    static const std::vector<std::string> kKinds{"crash", "hang", "slow", "garbage", "silence"};
    const std::string leg = a == std::string::npos ? "" : f.substr(0, a);
    Options::InjectedFault fault;
    fault.kind = b == std::string::npos ? "" : f.substr(a + 1, b - a - 1);
    fault.at = b == std::string::npos ? "" : f.substr(b + 1);
    char* end = nullptr;
    const double at = fault.at.empty() ? -1 : std::strtod(fault.at.c_str(), &end);
    const bool supervisor = leg == "supervisor" && fault.kind == "crash";
    if ((!supervisor && (leg.size() != 1 || leg[0] < '1' || leg[0] > '6' ||
                         std::find(kKinds.begin(), kKinds.end(), fault.kind) == kKinds.end())) ||
        end == nullptr || *end != '\0' || !(at >= 0) || !std::isfinite(at)) {
      std::fprintf(stderr, "error: --fault '%s': expected leg:kind:time_s with leg 1..6, kind "
                   "one of crash hang slow garbage silence, or supervisor:crash:time_s; "
                   "time_s a finite number >= 0 (e.g. 3:crash:2.0)\n",
                   f.c_str());
      return false;
    }
    fault.leg = supervisor ? 0 : leg[0] - '0';
    if (o.FaultOfLeg(fault.leg) != nullptr) {
      const Options::InjectedFault& first = *o.FaultOfLeg(fault.leg);
      std::fprintf(stderr, "error: --fault '%s': %s already has a fault (--fault %s:%s:%s); one "
                   "fault per process\n", f.c_str(),
                   supervisor ? "the supervisor" : ("leg " + leg).c_str(), leg.c_str(),
                   first.kind.c_str(), first.at.c_str());
      return false;
    }
    o.faults.push_back(fault);
  }
  if (cli.Has("plant-fault")) {
    std::vector<hexa::PlantFault> faults;
    const std::string error = hexa::ParsePlantFaultList(cli.Get("plant-fault"), faults);
    if (!error.empty()) {
      std::fprintf(stderr, "error: --plant-fault %s\n(see --help)\n", error.c_str());
      return false;
    }
    o.plant_faults = cli.Get("plant-fault");
  }
  return true;
}

// The trajectory, the experiment, the rig overlays and the files named: they must exist.
bool CheckWhatRuns(const hexa::cli::Parser& cli, Options& o) {
  o.experiment = cli.Get("experiment");
  o.excite_legs_text = cli.Get("legs");
  if (!hexa::cli::ParseLegList(cli.Get("legs"), o.excite_legs)) {
    std::fprintf(stderr, "error: --legs '%s': expected legs 1..6 as a list or range (1-6, 1,3)\n",
                 cli.Get("legs").c_str());
    return false;
  }
  if (o.is_experiment() && (o.standby || cli.Has("fault"))) {
    std::fprintf(stderr, "error: --experiment runs without --standby and --fault\n");
    return false;
  }
  static const std::vector<std::string> kNamed{"x",   "y",        "z",          "roll",
                                                "pitch", "yaw", "combined", "calibration"};
  if (std::find(kNamed.begin(), kNamed.end(), o.trajectory) == kNamed.end()) {
    if (!fs::exists(o.trajectory)) {
      std::fprintf(stderr, "error: --trajectory '%s' is neither one of x y z roll pitch yaw calibration "
                   "combined nor an existing CSV file\n", o.trajectory.c_str());
      return false;
    }
    o.trajectory = fs::absolute(o.trajectory).string();
  }
  o.plant_extra_args = cli.GetAll("plant-arg");
  for (const auto& overlay : cli.GetAll("rig-overlay")) {
    o.rig_overlays.push_back(fs::absolute(overlay).string());
    if (!fs::exists(o.rig_overlays.back())) {
      std::fprintf(stderr, "error: rig overlay '%s' does not exist\n", overlay.c_str());
      return false;
    }
  }
  o.device = cli.Get("device");
  o.board_extra_args = cli.GetAll("board-arg");
  if (o.device == "board") {
    // What only a simulating plant can do: its truth, its instruments, its injected faults.
    const char* sim_only = o.is_experiment() ? "--experiment" : o.tracker ? "--tracker"
                           : cli.Has("plant-fault") ? "--plant-fault" : nullptr;
    if (sim_only != nullptr) {
      std::fprintf(stderr, "error: %s needs --device sim (the plant's own simulation)\n", sim_only);
      return false;
    }
  } else if (!o.board_extra_args.empty()) {
    std::fprintf(stderr, "error: --board-arg is for --device board\n");
    return false;
  }
  for (const auto& [what, path] : {std::pair{"rig file", o.rig}, {"DDS config", o.dds_config}}) {
    if (!fs::exists(path)) {
      std::fprintf(stderr, "error: %s '%s' does not exist\n", what, path.c_str());
      return false;
    }
  }
  return true;
}

// The flags and texts taken as given; false for a combination that cannot run.
bool TakeFlags(const hexa::cli::Parser& cli, Options& o) {
  o.trajectory = cli.Get("trajectory");
  o.controller = cli.Get("controller");
  o.profile = cli.Get("profile");
  o.mode = cli.Get("mode");
  o.rig = fs::absolute(cli.Get("rig")).string();
  o.dds_config = fs::absolute(cli.Get("dds-config")).string();
  o.recorder = !cli.Flag("no-recorder");
  o.standby = cli.Flag("standby");
  o.coupled_legs = cli.Flag("coupled-legs");
  o.secure = cli.Flag("secure");
  o.command_auth = !cli.Flag("insecure-commands");
  if (o.secure && cli.Get("dds-config") != HEXA_DEFAULT_CYCLONE_CONFIG) {
    std::fprintf(stderr, "error: --secure makes its own DDS configuration (loopback, secured); "
                 "it cannot be combined with --dds-config\n");
    return false;
  }
  o.outer_loop = !cli.Flag("no-outer-loop");
  o.rt_sched = !cli.Flag("no-rt-sched");
  o.bridge = cli.Flag("bridge");
  o.bridge_listen = cli.Get("bridge-listen");
  o.bridge_port = cli.Get("bridge-port");
  o.bridge_queue_kb = cli.Get("bridge-queue-kb");
  o.bridge_max_clients = cli.Get("bridge-max-clients");
  o.bridge_operator_input = cli.Flag("bridge-operator-input");
  if (o.bridge_operator_input && (!o.bridge || o.secure)) {
    std::fprintf(stderr, "error: --bridge-operator-input %s\n",
                 !o.bridge ? "needs --bridge"
                           : "cannot be combined with --secure: the bridge's DDS permissions "
                             "allow it to read only (docs/foxglove.md)");
    return false;
  }
  o.feedforward = !cli.Flag("no-feedforward");
  o.stream = cli.Flag("stream");
  o.stream_port = cli.Get("stream-port");
  o.tracker = cli.Flag("tracker");
  o.operator_activation = cli.Get("activation") == "operator";
  o.wait_for_operator = cli.Flag("wait-for-operator") || o.operator_activation;
  o.rt_lease = cli.Get("rt-lease");
  o.lockstep_lease = cli.Get("lockstep-lease");
  o.cpu_latency_us = cli.Get("cpu-latency-us");
  o.rt_dds_event_thread = cli.Get("rt-dds-event-thread");
  o.timeout_text = cli.Get("timeout");
  o.hold_timeout_text = cli.Get("hold-timeout");
  o.record_split_mb = cli.Get("record-split-mb");
  o.record_split_s = cli.Get("record-split-s");
  o.record_keep_files = cli.Get("record-keep-files");
  return true;
}

}  // namespace

int ParseOptions(int argc, char** argv, Options& o) {
  hexa::cli::Parser cli("hexa_session",
                        "Runs a complete closed-loop session: plant, six leg controllers, "
                        "supervisor and recorder as separate processes over loopback DDS.\n"
                        "Exit status (docs/exit_codes.md): 0 completed; 1 a process failed or the "
                        "session was stopped (signal, --timeout); 2 bad arguments; 3 held after a "
                        "fault and not reset within --hold-timeout; 4 the plant stopped; 5 the "
                        "supervisor was lost; 6 stopped by the operator (hexa_operator stop or shutdown) "
                        "before the trajectory's end, or shut down before it started; 7 the "
                        "trajectory completed but the recording lost samples.");
  AddSessionOptions(cli);
  AddProcessOptions(cli);
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  if (!TakeFlags(cli, o) || !ParseCpus(cli, o) || !ParseNumbers(cli, o) ||
      !CheckWhatRuns(cli, o) || !ParseFaults(cli, o))
    return exit_code::kUsage;
  for (int k = 0; k < argc; ++k) o.command += (k ? " " : "") + std::string(argv[k]);
  o.out_dir = cli.Has("out") ? cli.Get("out") : "out/session-" + Timestamp();
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "error: cannot create output directory '%s': %s\n",
                 o.out_dir.c_str(), ec.message().c_str());
    return exit_code::kUsage;
  }
  o.out_dir = fs::absolute(o.out_dir).string();
  return kContinue;
}

}  // namespace hexa::launcher
