// hexa_session: runs one complete closed-loop session on this machine. Starts the
// recorder, the six leg controllers, the supervisor and the plant as separate processes
// on loopback DDS (own domain id), runs one trajectory, stops everything cleanly, writes
// the report, and exits 0 only if the session completed. Ctrl-C or the death of any
// process stops all of them; children die with this process even if it is SIGKILLed.
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <map>
#include <optional>
#include <regex>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <google/protobuf/text_format.h>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/excitation.hpp"
#include "hexa/core/plant_faults.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/json.hpp"
#include "identification.pb.h"
#include "hexa/services/logging.hpp"
#include "hexa/services/progress.hpp"
#include "hexa/services/scheduling.hpp"
#include "child_progress.hpp"
#include "process_group.hpp"
#include "domain_probe.hpp"
#include "hexa/comm/command_auth.hpp"
#include "secure_session.hpp"

namespace fs = std::filesystem;
using hexa::deploy::ChildSpec;
using hexa::deploy::ProcessGroup;

namespace {

std::string Timestamp() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  return buf;
}

std::string TailOf(const std::string& path, int lines) {
  std::ifstream in(path);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  std::ostringstream os;
  for (size_t i = all.size() > size_t(lines) ? all.size() - lines : 0; i < all.size(); ++i)
    os << "    " << all[i] << "\n";
  return os.str();
}

struct Options {
  std::string trajectory, controller, profile, mode, out_dir, rig, dds_config;
  long long seed = 1, domain = 0, periods = 0, stale_ticks = 15;
  bool recorder = true, standby = false, outer_loop = true, rt_sched = true, bridge = false,
       feedforward = true, tracker = false, secure = false, command_auth = true;
  std::string cpus_control, cpus_recorder, cpus_standby, cpus_supervisor, cpus_bridge;
  std::string bridge_listen, bridge_port, bridge_queue_kb, bridge_max_clients;
  bool bridge_operator_input = false;
  // --fault, repeatable: at most one per process (leg 1..6 primary, or the supervisor).
  struct InjectedFault {
    int leg = 0;  // 1..6; 0: the supervisor (crash)
    std::string kind, at;
  };
  std::vector<InjectedFault> faults;
  const InjectedFault* FaultOfLeg(int leg) const {
    for (const auto& f : faults)
      if (f.leg == leg) return &f;
    return nullptr;
  }
  bool fault_supervisor() const { return FaultOfLeg(0) != nullptr; }
  std::string plant_faults;     // --plant-fault, passed to the plant's --fault
  double timeout_s = 0;
  bool split_recording = false;  // --record-split-mb / --record-split-s
  std::vector<std::string> rig_overlays;  // absolute paths, for the legs and the supervisor
  std::vector<std::string> plant_extra_args;  // --plant-arg, passed on as given
  std::string experiment = "none";        // "identify": docs/identification.md
  std::vector<int> excite_legs;
  double excite_duration_s = 30.0;
};

// CPU time of every process over its whole life (start-up and discovery included), per
// simulated second when the plant's summary says how much was simulated: `processes.json`
// and a table in the log (docs/performance.md).
void WriteProcessTable(const std::string& out_dir, const std::vector<hexa::deploy::ChildExit>& exits,
                       double wall_s, spdlog::logger& log) {
  double sim_s = 0.0;
  {
    std::ifstream summary(out_dir + "/plant.json");
    const auto plant = hexa::json::Value::parse(summary, nullptr, false);  // no summary: 0
    if (plant.is_object() && plant.contains("sim_time_s") && plant["sim_time_s"].is_number())
      sim_s = plant["sim_time_s"].get<double>();
  }
  hexa::json::Value json = {{"wall_time_s", wall_s}, {"sim_time_s", sim_s},
                            {"processes", hexa::json::Value::array()}};
  double user = 0, sys = 0;
  std::string table;
  for (std::size_t k = 0; k < exits.size(); ++k) {
    const auto& e = exits[k];
    user += e.cpu_user_s;
    sys += e.cpu_system_s;
    json["processes"].push_back({{"name", e.name},
                                 {"cpu_user_s", e.cpu_user_s},
                                 {"cpu_system_s", e.cpu_system_s},
                                 {"max_rss_kb", e.max_rss_kb}});
    char line[160];
    std::snprintf(line, sizeof line, "\n  %-16s user %7.3f s  system %7.3f s", e.name.c_str(),
                  e.cpu_user_s, e.cpu_system_s);
    table += line;
    if (sim_s > 0) {
      std::snprintf(line, sizeof line, "  = %.3f s per simulated s",
                    (e.cpu_user_s + e.cpu_system_s) / sim_s);
      table += line;
    }
  }
  json["cpu_user_s"] = user;
  json["cpu_system_s"] = sys;
  std::string error;
  if (!hexa::json::WriteFile(out_dir + "/processes.json", json, 2, error)) log.error("{}", error);
  log.info("CPU time per process (whole life, start-up included):{}\n  {:<16} user {:7.3f} s  "
           "system {:7.3f} s{}",
           table, "all", user, sys,
           sim_s > 0 ? fmt::format("  = {:.3f} s per simulated s ({:.3f} s simulated)",
                                   (user + sys) / sim_s, sim_s)
                     : std::string());
}

// The samples the recording lost, as the report counted them (report.json,
// "recording_lost_samples"); 0 when there is no report.
long long ReadReportLostSamples(const std::string& out_dir) {
  std::ifstream in(out_dir + "/report.json");
  const hexa::json::Value report = hexa::json::Value::parse(in, nullptr, false);
  if (!report.is_object() || !report.contains("recording_lost_samples") ||
      !report["recording_lost_samples"].is_number())
    return 0;
  return report["recording_lost_samples"].get<long long>();
}

// "N MB free of M MB on the file system of DIR", for messages about write errors.
std::string FreeSpaceOf(const std::string& dir) {
  struct statvfs st {};
  if (statvfs(dir.c_str(), &st) != 0) return "free space of " + dir + " unknown";
  const double unit = static_cast<double>(st.f_frsize);
  char text[160];
  std::snprintf(text, sizeof text, "%.1f MB free of %.1f MB on the file system of ",
                static_cast<double>(st.f_bavail) * unit * 1e-6,
                static_cast<double>(st.f_blocks) * unit * 1e-6);
  return text + dir;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_session",
                        "Runs a complete closed-loop session: plant, six leg controllers, "
                        "supervisor and recorder as separate processes over loopback DDS.\n"
                        "Exit status (docs/exit_codes.md): 0 completed; 1 a process failed or the "
                        "session was stopped (signal, --timeout); 2 bad arguments; 3 held after a "
                        "fault and not reset within --hold-timeout; 4 the plant stopped; 5 the "
                        "supervisor was lost; 6 stopped by the operator (hexa_operator stop) "
                        "before the trajectory's end; 7 the trajectory completed but the recording "
                        "lost samples.");
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
  cli.AddFlag("tracker", "the plant publishes the external pose instrument (hexa_TrackerPose, for "
                         "hexa_calibrate; use with --trajectory calibration)");
  cli.AddFlag("standby", "also start a hot-standby controller per leg");
  cli.AddOption("cpus-control", "list|auto|none",
                "pin the plant, the leg controllers and the supervisor to these CPUs; auto: the "
                "last CPU this process may use, when it may use two or more (the loop's wake-ups "
                "then stay on one CPU: docs/performance.md)", "auto");
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
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;

  Options o;
  o.trajectory = cli.Get("trajectory");
  o.controller = cli.Get("controller");
  o.profile = cli.Get("profile");
  o.mode = cli.Get("mode");
  o.rig = fs::absolute(cli.Get("rig")).string();
  o.dds_config = fs::absolute(cli.Get("dds-config")).string();
  o.recorder = !cli.Flag("no-recorder");
  o.standby = cli.Flag("standby");
  o.secure = cli.Flag("secure");
  o.command_auth = !cli.Flag("insecure-commands");
  if (o.secure && cli.Get("dds-config") != HEXA_DEFAULT_CYCLONE_CONFIG) {
    std::fprintf(stderr, "error: --secure makes its own DDS configuration (loopback, secured); "
                 "it cannot be combined with --dds-config\n");
    return 2;
  }
  o.outer_loop = !cli.Flag("no-outer-loop");
  o.rt_sched = !cli.Flag("no-rt-sched");
  {
    // auto: the control loop on the last allowed CPU, the recorder on the others.
    const hexa::sched::CpuSplit split = hexa::sched::AutoCpuSplit();
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
      return 2;
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
  {
    // The bridge: off the control CPUs whichever they are, so that its clients cannot take
    // the loop's CPU (docs/foxglove.md); nowhere in particular when the control has none.
    std::vector<int> control, others;
    if (!o.cpus_control.empty() && hexa::sched::ParseCpuList(o.cpus_control, control))
      for (int c : hexa::sched::AllowedCpus())
        if (std::find(control.begin(), control.end(), c) == control.end()) others.push_back(c);
    o.cpus_bridge = hexa::sched::FormatCpuList(others);
  }
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
    return 2;
  }
  o.feedforward = !cli.Flag("no-feedforward");
  o.tracker = cli.Flag("tracker");
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
    return 2;
  }
  o.seed = *seed;
  o.split_recording = *split_mb > 0 || *split_s > 0;
  if (*keep_files > 0 && !o.split_recording) {
    std::fprintf(stderr, "error: --record-keep-files needs --record-split-mb or --record-split-s\n");
    return 2;
  }
  o.bridge_port = std::to_string(*bridge_port);
  o.periods = *periods;
  o.timeout_s = *timeout;
  o.stale_ticks = *stale_ticks;
  o.domain = *domain;
  o.experiment = cli.Get("experiment");
  o.excite_duration_s = *excite_duration;
  if (!hexa::cli::ParseLegList(cli.Get("legs"), o.excite_legs)) {
    std::fprintf(stderr, "error: --legs '%s': expected legs 1..6 as a list or range (1-6, 1,3)\n",
                 cli.Get("legs").c_str());
    return 2;
  }
  const bool identify = o.experiment == "identify";
  const bool free_fall = o.experiment == "free-fall";
  const bool experiment = identify || free_fall;
  constexpr double kFreeFallReleaseS = 0.5, kFreeFallAfterS = 1.0;
  if (experiment && (o.standby || cli.Has("fault"))) {
    std::fprintf(stderr, "error: --experiment runs without --standby and --fault\n");
    return 2;
  }
  static const std::vector<std::string> kNamed{"x",   "y",        "z",          "roll",
                                                "pitch", "yaw", "combined", "calibration"};
  if (std::find(kNamed.begin(), kNamed.end(), o.trajectory) == kNamed.end()) {
    if (!fs::exists(o.trajectory)) {
      std::fprintf(stderr, "error: --trajectory '%s' is neither one of x y z roll pitch yaw calibration "
                   "combined nor an existing CSV file\n", o.trajectory.c_str());
      return 2;
    }
    o.trajectory = fs::absolute(o.trajectory).string();
  }
  o.plant_extra_args = cli.GetAll("plant-arg");
  for (const auto& overlay : cli.GetAll("rig-overlay")) {
    o.rig_overlays.push_back(fs::absolute(overlay).string());
    if (!fs::exists(o.rig_overlays.back())) {
      std::fprintf(stderr, "error: rig overlay '%s' does not exist\n", overlay.c_str());
      return 2;
    }
  }
  for (const auto& [what, path] : {std::pair{"rig file", o.rig}, {"DDS config", o.dds_config}}) {
    if (!fs::exists(path)) {
      std::fprintf(stderr, "error: %s '%s' does not exist\n", what, path.c_str());
      return 2;
    }
  }
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
      return 2;
    }
    fault.leg = supervisor ? 0 : leg[0] - '0';
    if (o.FaultOfLeg(fault.leg) != nullptr) {
      const Options::InjectedFault& first = *o.FaultOfLeg(fault.leg);
      std::fprintf(stderr, "error: --fault '%s': %s already has a fault (--fault %s:%s:%s); one "
                   "fault per process\n", f.c_str(),
                   supervisor ? "the supervisor" : ("leg " + leg).c_str(), leg.c_str(),
                   first.kind.c_str(), first.at.c_str());
      return 2;
    }
    o.faults.push_back(fault);
  }
  if (cli.Has("plant-fault")) {
    std::vector<hexa::PlantFault> faults;
    const std::string error = hexa::ParsePlantFaultList(cli.Get("plant-fault"), faults);
    if (!error.empty()) {
      std::fprintf(stderr, "error: --plant-fault %s\n(see --help)\n", error.c_str());
      return 2;
    }
    o.plant_faults = cli.Get("plant-fault");
  }
  o.out_dir = cli.Has("out") ? cli.Get("out") : "out/session-" + Timestamp();
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "error: cannot create output directory '%s': %s\n",
                 o.out_dir.c_str(), ec.message().c_str());
    return 2;
  }
  o.out_dir = fs::absolute(o.out_dir).string();

  ProcessGroup group;  // blocks SIGINT/SIGTERM/SIGCHLD before any thread exists
  // A closed console (the terminal or the pipe reading this process's output went away) must
  // not kill the session half-way: the console lines are lost, session.log keeps everything.
  std::signal(SIGPIPE, SIG_IGN);
  auto log = hexa::logging::Init("session", o.out_dir + "/session.log");
  {
    // Another session (or a process left of one) on the domain would read and command this
    // one: refuse a domain in use. The default domain (100 + pid % 100) is chosen by chance,
    // so then the next free one is taken.
    setenv("CYCLONEDDS_URI", ("file://" + o.dds_config).c_str(), 1);
    const bool chosen = !cli.Has("domain");
    for (int attempt = 0;; ++attempt) {
      const auto probe = hexa::deploy::ProbeDomain(static_cast<int>(o.domain), 0.5);
      if (!probe.error.empty()) {
        log->error("cannot check DDS domain {} for another session: {}", o.domain, probe.error);
        return 1;
      }
      if (probe.other_participants == 0) break;
      if (!chosen || attempt == 20) {
        log->error("DDS domain {} is in use: {} other participant(s) on it (another session, or "
                   "a process left of one): two sessions on one domain would command each other. "
                   "{}", o.domain, probe.other_participants,
                   chosen ? "No free domain among the next 20."
                          : "Choose another --domain, or stop the other session.");
        return 2;
      }
      const long long next = 100 + (o.domain - 100 + 1) % 100;
      log->warn("DDS domain {} is in use ({} other participant(s): another session?): trying {}",
                o.domain, probe.other_participants, next);
      o.domain = next;
    }
  }
  log->info("session: trajectory={} controller={} profile={} mode={} seed={} domain={} out={}",
            o.trajectory, o.controller, o.profile, o.mode, o.seed, o.domain, o.out_dir);
  log->info("DDS config: {}", o.dds_config);
  log->info("CPUs: plant and legs {}, supervisor {}, recorder {}{}{}{}{}",
            o.cpus_control.empty() ? "any" : o.cpus_control,
            o.cpus_supervisor.empty() ? "any" : o.cpus_supervisor,
            o.cpus_recorder.empty() ? "any" : o.cpus_recorder,
            o.standby ? ", hot standbys " : "",
            o.standby ? (o.cpus_standby.empty() ? "any" : o.cpus_standby) : "",
            o.bridge ? ", bridge " : "",
            o.bridge ? (o.cpus_bridge.empty() ? "any" : o.cpus_bridge) : "");
  std::vector<std::string> overlay_args;  // legs and supervisor only: the plant keeps its truth
  for (const auto& overlay : o.rig_overlays) {
    log->info("rig overlay for the controllers and the supervisor: {}", overlay);
    overlay_args.insert(overlay_args.end(), {"--rig-overlay", overlay});
  }

  // Build tree: each binary in its own directory; installed (Debian package): all in bin/.
  auto executable = [](const std::string& build_relative) {
#ifdef HEXA_INSTALLED_BIN_DIR
    return std::string(HEXA_INSTALLED_BIN_DIR) + build_relative.substr(build_relative.rfind('/'));
#else
    return std::string(HEXA_BINARY_DIR) + build_relative;
#endif
  };
  std::map<std::string, std::string> env{{"CYCLONEDDS_URI", "file://" + o.dds_config}};
  std::vector<std::string> identities{"plant", "supervisor", "leg1", "leg2", "leg3", "leg4", "leg5", "leg6"};
  if (o.standby)
    for (int leg = 1; leg <= 6; ++leg) identities.push_back("leg" + std::to_string(leg) + "_standby");
  if (o.recorder) identities.push_back("recorder");
  if (o.bridge) identities.push_back("bridge");
  if (o.secure) {
    // Every process gets its own identity through HEXA_IDENTITY (set per child below); a bad
    // file stops the session here with the file named, before any process starts.
    std::string error;
    const auto secured = hexa::deploy::MakeSecureSession(o.out_dir, static_cast<int>(o.domain),
                                                         identities, HEXA_MAKE_SECURITY_SCRIPT, error);
    if (!secured) {
      log->error("--secure: {}", error);
      return 1;
    }
    o.dds_config = *secured;
    env["CYCLONEDDS_URI"] = "file://" + o.dds_config;
    log->info("DDS Security on: {} identities signed by {}/security/ca, configuration {}",
              identities.size(), o.out_dir, o.dds_config);
  }
  if (!o.command_auth) {
    log->warn("--insecure-commands: no session key; commands are NOT authenticated and any "
              "process on domain {} can command this session", o.domain);
  } else {
    // Command authentication, every session, secured or not (docs/faults.md, "Foreign
    // commands"): a new key, readable by this user only; every child reads it through
    // HEXA_SESSION_KEY, and `hexa_operator --session-key` sends commands into the session.
    const std::string key_path = o.out_dir + "/session.key";
    std::error_code ignored;
    fs::remove(key_path, ignored);  // a previous session's in a reused --out
    std::string error;
    if (!hexa::comm::WriteNewSessionKey(key_path, error)) {
      log->error("{}", error);
      return 1;
    }
    env[hexa::comm::kSessionKeyEnvironment] = key_path;
    log->info("commands authenticated with the session key {} (operator: hexa_operator "
              "--domain {} --session-key {} ...)", key_path, o.domain, key_path);
  }
  std::vector<std::string> common{"--rig", o.rig, "--domain", std::to_string(o.domain),
                                  "--mode", o.mode, "--rt-lease", cli.Get("rt-lease"),
                                  "--lockstep-lease", cli.Get("lockstep-lease"),
                                  "--cpu-latency-us", cli.Get("cpu-latency-us"),
                                  "--rt-dds-event-thread", cli.Get("rt-dds-event-thread")};
  if (!o.rt_sched) common.push_back("--no-rt-sched");
  // `cpus`: the control CPUs unless the child has its own (--cpus-standby, --cpus-supervisor).
  auto spec = [&](const std::string& name, const std::string& exe,
                  std::vector<std::string> args, const std::string& cpus) {
    ChildSpec s;
    s.name = name;
    s.argv = {executable(exe)};
    s.argv.insert(s.argv.end(), args.begin(), args.end());
    s.argv.insert(s.argv.end(), common.begin(), common.end());
    if (!cpus.empty()) s.argv.insert(s.argv.end(), {"--cpus", cpus});
    s.argv.push_back("--log-file");
    s.argv.push_back(o.out_dir + "/" + name + ".log");
    s.env = env;
    s.env["HEXA_IDENTITY"] = name;  // the process's DDS Security identity (--secure)
    s.log_path = o.out_dir + "/" + name + ".console.log";
    return s;
  };

  std::vector<ChildSpec> specs;
  const std::string mcap = o.out_dir + "/session.mcap";
  if (o.recorder) {
    ChildSpec r;
    r.name = "recorder";
    // --rig/--profile/--seed: the 3-D scene draws the simulated plant's true joints.
    r.argv = {executable("/services/recorder/hexa_recorder"), "record", "--output", mcap, "--domain",
              std::to_string(o.domain), "--rig", o.rig, "--profile", o.profile, "--seed",
              std::to_string(o.seed)};
    if (!o.cpus_recorder.empty()) r.argv.insert(r.argv.end(), {"--cpus", o.cpus_recorder});
    if (o.split_recording)
      r.argv.insert(r.argv.end(), {"--split-size-mb", cli.Get("record-split-mb"), "--split-duration-s",
                                   cli.Get("record-split-s"), "--keep-files",
                                   cli.Get("record-keep-files")});
    // Real time: SCHED_FIFO below the control processes (70-80). A SCHED_OTHER recorder
    // beside SCHED_FIFO peers is starved and loses samples.
    if (o.mode == "realtime" && o.rt_sched) r.argv.insert(r.argv.end(), {"--rt-priority", "50"});
    // Real time: the periodic topics best effort, as the controllers read them; no control
    // writer repairs what the recorder misses (docs/measurements/deployment.md, "The lossy recorder link").
    if (o.mode == "realtime") r.argv.insert(r.argv.end(), {"--periodic-reliability", "best-effort"});
    r.env = env;
    r.env["HEXA_IDENTITY"] = "recorder";
    r.log_path = o.out_dir + "/recorder.console.log";
    specs.push_back(r);
  }
  if (o.bridge) {
    ChildSpec b;
    b.name = "bridge";
    b.argv = {executable("/services/bridge/hexa_bridge"), "--domain", std::to_string(o.domain),
              "--listen", o.bridge_listen, "--port", o.bridge_port, "--client-queue-kb",
              o.bridge_queue_kb, "--max-clients", o.bridge_max_clients, "--cpus",
              o.cpus_bridge.empty() ? "none" : o.cpus_bridge, "--rig", o.rig,
              "--profile", o.profile, "--seed", std::to_string(o.seed), "--log-file",
              o.out_dir + "/bridge.log"};
    if (o.bridge_operator_input) b.argv.push_back("--operator-input");
    b.env = env;
    b.env["HEXA_IDENTITY"] = "bridge";  // --secure: reads every topic, publishes nothing
    b.log_path = o.out_dir + "/bridge.console.log";
    specs.push_back(b);
    log->info("bridge: Foxglove WebSocket on ws://{}:{}", o.bridge_listen, o.bridge_port);
  }
  // The identification experiment's schedule (the same plan hexa_sim --experiment uses).
  const hexa::ExcitationPlan plan =
      identify ? hexa::PlanIdentificationExperiment(o.excite_legs, o.excite_duration_s,
                                                    static_cast<std::uint64_t>(o.seed))
               : hexa::ExcitationPlan{};
  if (identify) {
    log->info("identification experiment: legs {} excited one after the other, {} s each, {} s "
              "simulated; the others hold home (BS-SMC), outer loop off", cli.Get("legs"),
              o.excite_duration_s, plan.total_duration_s);
  }
  for (int leg = 1; leg <= 6; ++leg) {
    std::vector<std::string> leg_args{"--leg", std::to_string(leg), "--controller", o.controller};
    const hexa::ExcitationParams& excitation = plan.legs[static_cast<std::size_t>(leg - 1)];
    if (identify && excitation.enabled()) {
      leg_args = {"--leg", std::to_string(leg), "--controller", "excite", "--excite-start",
                  std::to_string(excitation.start_s), "--excite-duration",
                  std::to_string(excitation.duration_s), "--excite-seed",
                  std::to_string(excitation.seed)};
    }
    leg_args.insert(leg_args.end(), overlay_args.begin(), overlay_args.end());
    // With a recorder, a leg runs only once the recorder has matched its valve commands too:
    // otherwise a recorder that discovers a leg late misses its first ticks.
    if (o.recorder) leg_args.insert(leg_args.end(), {"--valve-readers", "2"});
    if (const auto* fault = o.FaultOfLeg(leg)) {
      leg_args.insert(leg_args.end(), {"--fault", fault->kind, "--fault-at", fault->at});
      log->warn("fault injection: leg {} primary controller, '{}' at t = {} s", leg,
                fault->kind, fault->at);
    }
    specs.push_back(spec("leg" + std::to_string(leg), "/services/leg_ctrl/hexa_leg_ctrl", leg_args,
                         o.cpus_control));
    if (o.standby) {
      ChildSpec sb = spec("leg" + std::to_string(leg) + "_standby",
                          "/services/leg_ctrl/hexa_leg_ctrl", [&] {
                            std::vector<std::string> a{"--leg", std::to_string(leg),
                                                       "--controller", o.controller,
                                                       "--standby"};
                            a.insert(a.end(), overlay_args.begin(), overlay_args.end());
                            if (o.recorder) a.insert(a.end(), {"--valve-readers", "2"});
                            return a;
                          }(), o.cpus_standby);
      specs.push_back(sb);
    }
  }
  const std::string hold_report = o.out_dir + "/hold.txt";
  std::vector<std::string> sup_args{"--trajectory", o.trajectory, "--exit-when-done",
                                    "--periods", std::to_string(o.periods),
                                    "--hold-timeout", cli.Get("hold-timeout"),
                                    "--hold-report", hold_report};
  if (!cli.Flag("wait-for-operator")) sup_args.push_back("--autostart");
  // Identification: the supervisor only holds home (no trajectory); its outer loop would
  // fight the excited leg, which moves the platform. The free-fall bench has no platform, but
  // lockstep legs answer a tick only with its setpoint: the supervisor runs (holding, outer
  // loop off); the vented bench ignores the valves. The calibration procedure holds the
  // platform still at each pose: the outer loop would integrate estimation noise there (idle
  // wander, docs/task_space.md), so it is off.
  if (experiment) sup_args = {"--no-outer-loop"};
  else if (!o.outer_loop || o.trajectory == "calibration") sup_args.push_back("--no-outer-loop");
  if (o.fault_supervisor()) {
    sup_args.insert(sup_args.end(), {"--fault", "crash", "--fault-at", o.FaultOfLeg(0)->at});
    log->warn("fault injection: supervisor crash (SIGKILL) at t = {} s", o.FaultOfLeg(0)->at);
  }
  if (!o.feedforward) sup_args.push_back("--no-feedforward");
  sup_args.insert(sup_args.end(), overlay_args.begin(), overlay_args.end());
  if (o.recorder) sup_args.insert(sup_args.end(), {"--pose-readers", "1"});
  specs.push_back(
      spec("supervisor", "/services/task_space/hexa_task_space", sup_args, o.cpus_supervisor));
  std::vector<std::string> plant_args{"--profile", o.profile, "--seed", std::to_string(o.seed),
                                      "--legs", "6", "--supervisor", "--summary",
                                      o.out_dir + "/plant.json", "--stale-ticks",
                                      std::to_string(o.stale_ticks)};
  if (o.recorder) plant_args.push_back("--expect-recorder");
  if (o.tracker) plant_args.push_back("--tracker");
  if (o.standby) plant_args.push_back("--expect-standbys");
  if (!o.plant_faults.empty()) {
    plant_args.insert(plant_args.end(), {"--fault", o.plant_faults});
    log->warn("fault injection into the plant: {}", o.plant_faults);
  }
  plant_args.insert(plant_args.end(), o.plant_extra_args.begin(), o.plant_extra_args.end());
  const std::string truth_path = o.out_dir + "/plant_truth.textproto";
  if (identify) {
    plant_args.insert(plant_args.end(), {"--duration", std::to_string(plan.total_duration_s),
                                         "--truth-out", truth_path});
  }
  if (free_fall) {
    plant_args.insert(plant_args.end(),
                      {"--bench", "free-fall", "--bench-load-kg", std::to_string(*free_fall_load),
                       "--bench-release-s", std::to_string(kFreeFallReleaseS), "--duration",
                       std::to_string(kFreeFallReleaseS + kFreeFallAfterS), "--truth-out", truth_path});
    log->info("free-fall experiment: every cylinder hung rod down, chambers vented, {} kg load, "
              "released at {} s (Appendix B)", *free_fall_load, kFreeFallReleaseS);
  }
  specs.push_back(spec("plant", "/services/plant_sim/hexa_plant_sim", plant_args, o.cpus_control));

  // Start order: the supervisor before the legs, so that each leg knows the supervisor's
  // process id; the plant last, knowing every other process's. In lockstep a process that
  // ended is dead at once for them, where DDS would see it after its participant's lease
  // (10 s); a stopped or slow one is waited for (docs/faults.md).
  std::stable_partition(specs.begin(), specs.end(), [](const ChildSpec& s) {
    return s.name == "recorder" || s.name == "bridge" || s.name == "supervisor";
  });
  std::vector<std::string> peer_pids;  // "name=pid" of every control process started so far
  const auto t0 = std::chrono::steady_clock::now();
  for (auto s : specs) {
    const bool leg = s.name.rfind("leg", 0) == 0;
    if (leg || s.name == "plant") {
      for (const auto& p : peer_pids)
        if (s.name == "plant" || p.rfind("supervisor=", 0) == 0)
          s.argv.insert(s.argv.end(), {"--peer-pid", p});
    }
    std::string err;
    const pid_t pid = group.Start(s, err);
    if (pid < 0) {
      log->error("cannot start {}: {}", s.name, err);
      group.StopAll(std::chrono::milliseconds(2000));
      return 1;
    }
    if (s.name != "bridge") peer_pids.push_back(s.name + "=" + std::to_string(pid));
    log->info("started {} (pid {})", s.name, pid);
  }

  bool completed = false;
  bool failed = false;
  // Exit code when not completed (docs/exit_codes.md): 1 a process failed or the session was
  // stopped; 3 the supervisor held the platform after a fault; 4 the plant stopped (lockstep
  // deadlock, non-finite state); 5 the supervisor was lost (the legs hold their valves); 6 the
  // operator stopped the motion. 7 (below): completed, but the recording lost samples.
  int outcome = 1;
  std::string ended_because;  // one line for the console and report.md when not completed
  // The supervisor's one-line hold description (--hold-report): shown on the console when it
  // appears, again when a reset removes it.
  std::string hold_line;
  auto watch_hold = [&] {
    std::ifstream in(hold_report);
    std::string line;
    if (in && std::getline(in, line) && !line.empty()) {
      if (line != hold_line)
        log->error("platform HOLD: {}; waiting up to {} s for an operator reset "
                   "(hexa_operator --domain {} reset), then the session ends held (exit 3)",
                   line, cli.Get("hold-timeout"), o.domain);
      hold_line = line;
    } else if (!in && !hold_line.empty()) {
      log->warn("the operator's reset left HOLD ({}): the session resumes", hold_line);
      hold_line.clear();
    }
  };
  double supervisor_lost_at_s = -1;  // the supervisor died: watch the legs hold for 2 s
  std::vector<hexa::deploy::ChildExit> exits;  // every child's exit, with its CPU time
  bool recorder_clean = false;  // the recorder exited 0 after closing its file
  // Progress: on a terminal one line (the recorder's newest progress line), in session.log a
  // line every 10 s.
  hexa::progress::Line progress("session", stderr, 10.0);
  progress.SetLogSink([&](const std::string& line) { log->info("{}", line); });
  const std::string recorder_console = o.out_dir + "/recorder.console.log";
  while (!completed && !failed) {
    auto ev = group.WaitEvent(std::chrono::milliseconds(supervisor_lost_at_s >= 0 ? 100 : 1000));
    const double elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    watch_hold();
    if (ev.kind == ProcessGroup::Event::kChildExited || ev.kind == ProcessGroup::Event::kInterrupted)
      progress.Clear();
    else
      progress.Update(-1, hexa::deploy::NewestProgress(recorder_console, {"record: progress: "}));
    if (supervisor_lost_at_s >= 0 && elapsed_s > supervisor_lost_at_s + 2.0) {
      log->error("the supervisor was lost {:.1f} s ago: stopping (exit 5)",
                 elapsed_s - supervisor_lost_at_s);
      ended_because = "the supervisor was lost (its process died; the legs held their valves)";
      outcome = 5;
      failed = true;
    }
    if (ev.kind == ProcessGroup::Event::kInterrupted) {
      log->warn("interrupted by signal {}: stopping every process", ev.signal);
      ended_because = "interrupted by signal " + std::to_string(ev.signal);
      failed = true;
    } else if (ev.kind == ProcessGroup::Event::kChildExited) {
      const auto& e = ev.exit;
      exits.push_back(e);
      if (experiment && e.name == "plant" && e.signal == 0 && e.exit_code == 0) {
        log->info("plant reached the end of the experiment after {:.1f} s wall", elapsed_s);
        completed = true;
      } else if (e.name == "supervisor" && e.signal == 0 && e.exit_code == 0) {
        log->info("supervisor finished the trajectory after {:.1f} s wall", elapsed_s);
        completed = true;
      } else if (e.name == "supervisor" && e.signal == 0 && e.exit_code == 5) {
        watch_hold();
        ended_because = "held after a fault, no operator reset within --hold-timeout " +
                        cli.Get("hold-timeout") + " s" +
                        (hold_line.empty() ? std::string() : ": " + hold_line);
        log->error("the supervisor left HOLD unreset (exit 3): {}", ended_because);
        outcome = 3;
        failed = true;
      } else if (e.name == "supervisor" && e.signal == 0 && e.exit_code == 6) {
        ended_because = "stopped by the operator before the trajectory's end";
        log->warn("the motion was {} ({:.1f} s wall; exit 6)", ended_because, elapsed_s);
        outcome = 6;
        failed = true;
      } else if (e.name == "supervisor" && (o.fault_supervisor() || e.signal != 0)) {
        // The legs see its setpoint writer's lease lapse and hold (docs/faults.md): watch
        // that for 2 s, then stop the session with exit 5.
        log->warn("{}{}: watching the legs hold for 2 s", e.Describe(),
                  o.fault_supervisor() ? " (injected fault)" : "");
        supervisor_lost_at_s = elapsed_s;
      } else if (e.name == "plant" && e.signal == 0 && (e.exit_code == 3 || e.exit_code == 4)) {
        log->error("{}: the plant stopped (exit 4); its last log lines:\n{}", e.Describe(),
                   TailOf(o.out_dir + "/plant.console.log", 15));
        ended_because = "the plant stopped (" + e.Describe() + "; plant.log says why)";
        outcome = 4;
        failed = true;
      } else if (o.standby && e.name.rfind("leg", 0) == 0 &&
                 e.name.find("_standby") == std::string::npos &&
                 group.Running(e.name + "_standby")) {
        log->warn("{}; its hot standby {}_standby takes over the valve", e.Describe(), e.name);
      } else if (e.name == "bridge") {
        // A viewer, not part of the control loop: the session goes on without it.
        log->error("{}; the session goes on without the Foxglove bridge; its last log "
                   "lines:\n{}", e.Describe(), TailOf(o.out_dir + "/bridge.console.log", 15));
      } else if (e.name.size() == 4 && e.name.rfind("leg", 0) == 0 &&
                 o.FaultOfLeg(e.name[3] - '0') != nullptr) {
        // The death was injected on purpose: let the plant and the supervisor handle it.
        log->warn("{} (injected fault): watching the plant and the supervisor react",
                  e.Describe());
      } else {
        log->error("{} before the session completed; its last log lines:\n{}", e.Describe(),
                   TailOf(o.out_dir + "/" + e.name + ".console.log", 15));
        ended_because = e.Describe();
        failed = true;
      }
    } else if (o.timeout_s > 0 && elapsed_s > o.timeout_s) {
      log->error("session exceeded --timeout {} s", o.timeout_s);
      ended_because = "exceeded --timeout " + cli.Get("timeout") + " s";
      failed = true;
    }
  }

  progress.Close();  // the log says how the session ended
  // Stop order: plant first (the clock), then controllers, recorder last so that it
  // records everything the others published.
  bool clean = completed;
  auto report_exit = [&](const hexa::deploy::ChildExit& e) {
    exits.push_back(e);
    const bool ok = e.signal == 0 && e.exit_code == 0;
    if (!ok) clean = false;
    if (e.name == "recorder") recorder_clean = ok;
    (ok ? log->info("{}", e.Describe()) : log->error("{}", e.Describe()));
  };
  auto stop = [&](const std::string& name) {
    if (!group.Running(name)) return;
    if (auto e = group.Stop(name, std::chrono::milliseconds(5000))) report_exit(*e);
  };
  if (o.recorder && !group.Running("recorder")) {
    // The recorder died: there is nothing left to record, so the others stop together. One
    // by one took ~10 s: each process needs about a second per DDS writer to delete it while
    // its reliable samples to the dead recorder stay unacknowledged (Cyclone lingers on them).
    log->warn("the recorder is gone: stopping the other processes together");
    for (const auto& e : group.StopTogether(group.RunningNames(), std::chrono::milliseconds(5000)))
      report_exit(e);
  } else {
    stop("plant");
    stop("supervisor");
    for (const auto& name : group.RunningNames())
      if (name != "recorder" && name != "bridge") stop(name);
    stop("recorder");
    stop("bridge");
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  log->info("all processes stopped; session wall time {:.1f} s", wall_s);
  WriteProcessTable(o.out_dir, exits, wall_s, *log);

  // Runs a short tool (recover, report) to its end; nullopt if it could not start or this
  // process was interrupted.
  auto run_tool = [&](const ChildSpec& spec) -> std::optional<hexa::deploy::ChildExit> {
    std::string err;
    if (group.Start(spec, err) < 0) {
      log->error("cannot start {}: {}", spec.name, err);
      return std::nullopt;
    }
    // Its progress lines (report: reading ..., plot_session: [k/n] ...) on ours.
    hexa::progress::Line line(spec.name, stderr, 10.0);
    line.SetLogSink([&](const std::string& text) { log->info("{}", text); });
    while (true) {
      auto ev = group.WaitEvent(std::chrono::milliseconds(1000));
      if (ev.kind == ProcessGroup::Event::kChildExited) return ev.exit;  // "<tool>: done in .."
      if (ev.kind != ProcessGroup::Event::kTimeout) {
        line.Close();
        group.Stop(spec.name, std::chrono::milliseconds(2000));
        return std::nullopt;
      }
      line.Update(-1, hexa::deploy::NewestProgress(spec.log_path, {"report: ", "plot_session: "}));
    }
  };
  // The report is written whenever there is a recording: after a fault it shows what
  // happened. The session still exits non-zero unless it completed. A recording whose
  // recorder did not close it (killed, crashed) lacks its summary: it is recovered first
  // (hexa_recorder recover) and the report is made from the recovered copy.
  std::string recording = mcap;
  if (o.recorder && std::filesystem::exists(mcap) && !recorder_clean) {
    const std::string recovered = o.out_dir + "/session.recovered.mcap";
    ChildSpec rc;
    rc.name = "recover";
    rc.argv = {executable("/services/recorder/hexa_recorder"), "recover", mcap, "--output", recovered};
    rc.env = env;
    rc.log_path = o.out_dir + "/recover.console.log";
    const auto e = run_tool(rc);
    if (e && e->signal == 0 && e->exit_code == 0) {
      log->warn("the recorder did not close {}: recovered into {}:\n{}", mcap, recovered,
                TailOf(rc.log_path, 15));
      recording = recovered;
    } else {
      // Say why even when the tool could not write its own console log (a full disk), and
      // leave no partial copy that could pass for a recovered recording.
      std::string why = TailOf(rc.log_path, 15);
      if (why.empty()) why = "    (" + rc.log_path + " is empty)\n";
      why += "    " + FreeSpaceOf(o.out_dir);
      std::error_code ignored;
      if (fs::remove(recovered, ignored)) why += "; the partial " + recovered + " was removed";
      log->error("the recorder did not close {} and recovering it failed: {}:\n{}", mcap,
                 e ? e->Describe() : std::string("recover did not run"), why);
      clean = false;
    }
  }
  // Identification: the recording gets the session description and, for evaluation only,
  // the plant's true parameters as channels of their own; hexa_identify reads it.
  if (experiment && o.recorder && std::filesystem::exists(recording)) {
    hexa::rec::SessionInfo info;
    const auto rig = hexa::config::LoadSystemConfig(o.rig);
    info.set_rig_name(rig.ok ? rig.config.rig_name : "");
    info.set_rig_file(o.rig);
    info.set_experiment(o.experiment);
    if (free_fall) {
      info.set_free_fall_load_kg(*free_fall_load);
      info.set_free_fall_release_s(kFreeFallReleaseS);
    }
    info.set_profile(o.profile);
    info.set_seed(static_cast<std::uint64_t>(o.seed));
    std::string command;
    for (int k = 0; k < argc; ++k) command += (k ? " " : "") + std::string(argv[k]);
    info.set_command(command);
    info.set_excitation_per_leg_s(o.excite_duration_s);
    for (int leg : identify ? o.excite_legs : std::vector<int>{}) {
      info.add_excited_legs(static_cast<std::uint32_t>(leg));
      info.add_excitation_start_s(plan.legs[static_cast<std::size_t>(leg - 1)].start_s);
    }
    std::string text;
    google::protobuf::TextFormat::PrintToString(info, &text);
    const std::string info_path = o.out_dir + "/session_info.textproto";
    std::ofstream(info_path) << text;
    ChildSpec a;
    a.name = "attach";
    a.argv = {executable("/services/recorder/hexa_recorder"), "attach", recording, "--session-info", info_path};
    if (std::filesystem::exists(truth_path)) a.argv.insert(a.argv.end(), {"--plant-truth", truth_path});
    a.env = env;
    a.log_path = o.out_dir + "/attach.console.log";
    const auto attached = run_tool(a);
    if (!attached || attached->signal != 0 || attached->exit_code != 0) {
      log->error("could not add the session info / plant truth to {}: {}", recording, TailOf(a.log_path, 5));
      clean = false;
    } else {
      log->info("recording {} ready for hexa_identify (session info and plant truth attached)", recording);
      std::printf("\n%s recording: %s\n", o.experiment.c_str(), recording.c_str());
    }
  }
  // (Not for the identification experiments: they track no trajectory.)
  if (!experiment && o.recorder && std::filesystem::exists(recording)) {
    ChildSpec r;
    r.name = "report";
    // A split recording: every part still on disk, oldest first, then the last one.
    std::vector<std::string> parts;
    if (o.split_recording) {
      static const std::regex kPart(R"(session-[0-9]{4,}\.mcap)");
      std::error_code ignored;
      for (const auto& e : fs::directory_iterator(o.out_dir, ignored))
        if (std::regex_match(e.path().filename().string(), kPart)) parts.push_back(e.path().string());
      // session-0009 before session-0010, and session-9999 before session-10000.
      std::sort(parts.begin(), parts.end(), [](const std::string& a, const std::string& b) {
        return a.size() != b.size() ? a.size() < b.size() : a < b;
      });
    }
    parts.push_back(recording);
    r.argv = {executable("/services/recorder/hexa_recorder"), "report"};
    r.argv.insert(r.argv.end(), parts.begin(), parts.end());
    r.argv.insert(r.argv.end(), {"--out", o.out_dir,
              "--meta", "trajectory=" + o.trajectory, "--meta", "controller=" + o.controller,
              "--meta", "profile=" + o.profile, "--meta", "mode=" + o.mode,
              "--meta", "seed=" + std::to_string(o.seed),
              "--meta", std::string("outer_loop=") + (o.outer_loop ? "on" : "off"),
              "--meta", std::string("feedforward=") + (o.feedforward ? "on" : "off"),
              "--meta", std::string("dds_security=") + (o.secure ? "on" : "off"),
              "--meta", std::string("command_auth=") + (o.command_auth ? "on" : "off"),
              "--meta", std::string("completed=") +
                            (completed ? "yes" : "NO" + (ended_because.empty() ? std::string()
                                                                               : ": " + ended_because))});
    // hexa_recorder splits --meta values at commas.
    std::replace(r.argv.back().begin(), r.argv.back().end(), ',', ';');
    if (!o.rig_overlays.empty()) {
      std::string list;
      for (const auto& overlay : o.rig_overlays) list += (list.empty() ? "" : " ") + overlay;
      r.argv.insert(r.argv.end(), {"--meta", "rig_overlays=" + list});
    }
    if (!o.faults.empty()) {
      std::string list;
      for (const auto& f : o.faults)
        list += (list.empty() ? "" : "; ") +
                (f.leg == 0 ? std::string("supervisor") : "leg " + std::to_string(f.leg)) + " " +
                f.kind + " at " + f.at + " s";
      r.argv.insert(r.argv.end(), {"--meta", "fault=" + list});
    }
    if (recording != mcap) r.argv.insert(r.argv.end(), {"--meta", "recording=recovered"});
    if (o.split_recording)
      r.argv.insert(r.argv.end(), {"--meta", "recording_parts=" + std::to_string(parts.size()) +
                                                 " files still on disk (--record-split-*; older "
                                                 "parts deleted by --record-keep-files are not in "
                                                 "the figures)"});
    if (!o.plant_faults.empty())
      r.argv.insert(r.argv.end(), {"--meta", "plant_fault=" + o.plant_faults});
    r.env = env;
    r.log_path = o.out_dir + "/report.console.log";
    const auto e = run_tool(r);
    if (!e || e->signal != 0 || e->exit_code != 0) {
      log->error("report failed: {}\n{}", e ? e->Describe() : std::string("not run"),
                 TailOf(r.log_path, 15));
      clean = false;
    }
    if (e) {
      std::ifstream md(o.out_dir + "/report.md");
      if (!completed) md.setstate(std::ios::failbit);  // the log says why; keep the tail short
      if (md) std::printf("\n%s\n", std::string(std::istreambuf_iterator<char>(md), {}).c_str());
    }
  }
  // A recording that lost samples is not a completed session: its figures miss them.
  const long long lost = o.recorder && !experiment ? ReadReportLostSamples(o.out_dir) : 0;
  if (completed && clean && lost > 0) {
    log->error("session did NOT complete (exit 7): the trajectory ran to its end, but the "
               "recording lost {} samples (report.md, \"Recording\"); logs in {}", lost, o.out_dir);
    return 7;
  }
  if (completed && clean) {
    log->info("session completed; outputs in {}", o.out_dir);
    return 0;
  }
  if (completed) outcome = 1;  // completed but a process did not stop cleanly
  log->error("session did NOT complete (exit {}){}{}; logs in {}", outcome,
             ended_because.empty() ? "" : ": ", ended_because, o.out_dir);
  return outcome;
}
