// hexa_session's children: the session's layout (deploy/session, the same processes and role
// arguments hexa_deploy generate writes units for) with this machine's paths, log files and
// the launcher's options; and what must be ready before they start (the DDS domain, the
// security files, the session key).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "domain_probe.hpp"
#include "hexa/comm/command_auth.hpp"
#include "hexa/services/exit_code.hpp"
#include "launcher.hpp"
#include "secure_session.hpp"

namespace hexa::launcher {
namespace {

namespace fs = std::filesystem;
using deploy::ChildSpec;
using session::ProcessSpec;
using session::Role;
constexpr int kContinue = -1;

// Another session (or a process left of one) on the domain would read and command this one:
// refuse a domain in use. The default domain (100 + pid % 100) is chosen by chance, so then
// the next free one is taken.
int ChooseDomain(Options& o, spdlog::logger& log) {
  setenv("CYCLONEDDS_URI", ("file://" + o.dds_config).c_str(), 1);
  for (int attempt = 0;; ++attempt) {
    const auto probe = deploy::ProbeDomain(static_cast<int>(o.domain), 0.5);
    if (!probe.error.empty()) {
      log.error("cannot check DDS domain {} for another session: {}", o.domain, probe.error);
      return exit_code::kRunError;
    }
    if (probe.other_participants == 0 && probe.fixed_index_ports == 0) return kContinue;
    std::string who = std::to_string(probe.other_participants) + " participant(s) discovered";
    if (probe.fixed_index_ports > 0) {
      who += ", " + std::to_string(probe.fixed_index_ports) + " of its participant ports bound";
      for (std::size_t k = 0; k < probe.port_owners.size(); ++k)
        who += (k == 0 ? " by " : ", ") + probe.port_owners[k];
    }
    if (!o.domain_chosen || attempt == 20) {
      log.error("DDS domain {} is in use ({}: another session, secured or not, or a process left "
                "of one): two sessions on one domain would command each other. {}",
                o.domain, who,
                o.domain_chosen ? "No free domain among the next 20."
                                : "Choose another --domain, or stop the other session.");
      return exit_code::kUsage;
    }
    const long long next = 100 + (o.domain - 100 + 1) % 100;
    log.warn("DDS domain {} is in use ({}: another session?): trying {}", o.domain, who, next);
    o.domain = next;
  }
}

// --secure: every process gets its own identity through HEXA_IDENTITY (set per child); a bad
// file stops the session here with the file named, before any process starts. Then the
// session key that authenticates commands, every session, secured or not (docs/faults.md,
// "Foreign commands"): every child reads it through HEXA_SESSION_KEY, and
// `hexa_operator --session-key` sends commands into the session.
int SecureSession(Options& o, Launch& launch, spdlog::logger& log) {
  if (o.secure) {
    const std::vector<std::string> identities = launch.layout.Names();
    std::string error;
    const auto secured = deploy::MakeSecureSession(o.out_dir, static_cast<int>(o.domain),
                                                   identities, HEXA_MAKE_SECURITY_SCRIPT, error);
    if (!secured) {
      log.error("--secure: {}", error);
      return exit_code::kRunError;
    }
    o.dds_config = *secured;
    launch.env["CYCLONEDDS_URI"] = "file://" + o.dds_config;
    log.info("DDS Security on: {} identities signed by {}/security/ca, configuration {}",
             identities.size(), o.out_dir, o.dds_config);
  }
  if (!o.command_auth) {
    log.warn("--insecure-commands: no session key; commands are NOT authenticated and any "
             "process on domain {} can command this session", o.domain);
    return kContinue;
  }
  const std::string key_path = o.out_dir + "/session.key";  // readable by this user only
  std::error_code ignored;
  fs::remove(key_path, ignored);  // a previous session's in a reused --out
  std::string error;
  if (!comm::WriteNewSessionKey(key_path, error)) {
    log.error("{}", error);
    return exit_code::kRunError;
  }
  launch.env[comm::kSessionKeyEnvironment] = key_path;
  log.info("commands authenticated with the session key {} (operator: hexa_operator "
           "--domain {} --session-key {} ...)", key_path, o.domain, key_path);
  return kContinue;
}

// What the session will do beyond its trajectory: the bridge, the experiment, injected faults.
void LogPlan(const Options& o, const Launch& launch, spdlog::logger& log) {
  if (o.bridge) log.info("bridge: Foxglove WebSocket on ws://{}:{}", o.bridge_listen, o.bridge_port);
  if (o.identify()) {
    log.info("identification experiment: legs {} excited one after the other, {} s each, {} s "
             "simulated; the others hold home (BS-SMC), outer loop off", o.excite_legs_text,
             o.excite_duration_s, launch.plan.total_duration_s);
  }
  for (int leg = 1; leg <= 6; ++leg)
    if (const auto* fault = o.FaultOfLeg(leg))
      log.warn("fault injection: leg {} primary controller, '{}' at t = {} s", leg, fault->kind,
               fault->at);
  if (o.fault_supervisor())
    log.warn("fault injection: supervisor crash (SIGKILL) at t = {} s", o.FaultOfLeg(0)->at);
  if (!o.plant_faults.empty()) log.warn("fault injection into the plant: {}", o.plant_faults);
  if (o.free_fall()) {
    log.info("free-fall experiment: every cylinder hung rod down, chambers vented, {} kg load, "
             "released at {} s (Appendix B)", o.free_fall_load_kg, kFreeFallReleaseS);
  }
}

// A UDP port of 127.0.0.1 free now (the kernel's choice), for the board emulator; 0 and
// `error` when none can be had.
int FreeLoopbackUdpPort(std::string& error) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = 0;
  if (fd >= 0 && bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    port = ntohs(a.sin_port);
  } else {
    error = std::string("no free UDP port on 127.0.0.1: ") + std::strerror(errno);
  }
  if (fd >= 0) close(fd);
  return port;
}

void Append(std::vector<std::string>& argv, const std::vector<std::string>& more) {
  argv.insert(argv.end(), more.begin(), more.end());
}

// The child of a layout process: its binary, identity, environment and console log.
ChildSpec ChildOf(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec s;
  s.name = p.name;
  s.argv = {Executable("/" + p.build_dir + "/" + p.binary)};
  if (!p.verb.empty()) s.argv.push_back(p.verb);
  s.env = launch.env;
  s.env["HEXA_IDENTITY"] = p.name;  // the process's DDS Security identity (--secure)
  s.log_path = o.out_dir + "/" + p.name + ".console.log";
  return s;
}

// The control processes' (plant, legs, supervisor) arguments after their own.
void AppendControlCommon(std::vector<std::string>& argv, const ProcessSpec& p, const Options& o) {
  Append(argv, {"--rig", o.rig, "--domain", std::to_string(o.domain), "--mode", o.mode,
                "--rt-lease", o.rt_lease, "--lockstep-lease", o.lockstep_lease,
                "--cpu-latency-us", o.cpu_latency_us, "--rt-dds-event-thread",
                o.rt_dds_event_thread});
  if (!o.rt_sched) argv.push_back("--no-rt-sched");
  if (!p.cpus.empty()) Append(argv, {"--cpus", p.cpus});
  Append(argv, {"--log-file", o.out_dir + "/" + p.name + ".log"});
}

std::vector<std::string> OverlayArgs(const Options& o) {
  std::vector<std::string> args;  // legs and supervisor only: the plant keeps its truth
  for (const auto& overlay : o.rig_overlays) Append(args, {"--rig-overlay", overlay});
  return args;
}

ChildSpec Recorder(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec r = ChildOf(p, o, launch);
  // --rig/--profile/--seed: the 3-D scene draws the simulated plant's true joints.
  Append(r.argv, {"--output", launch.mcap, "--domain", std::to_string(o.domain), "--rig", o.rig,
                  "--profile", o.profile, "--seed", std::to_string(o.seed)});
  if (!p.cpus.empty()) Append(r.argv, {"--cpus", p.cpus});
  if (o.split_recording)
    Append(r.argv, {"--split-size-mb", o.record_split_mb, "--split-duration-s", o.record_split_s,
                    "--keep-files", o.record_keep_files});
  // Real time: SCHED_FIFO below the control processes (70-80), which take their own
  // defaults. A SCHED_OTHER recorder beside SCHED_FIFO peers is starved and loses samples.
  if (p.rt_priority > 0) Append(r.argv, {"--rt-priority", std::to_string(p.rt_priority)});
  Append(r.argv, p.args);
  return r;
}

ChildSpec Bridge(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec b = ChildOf(p, o, launch);  // --secure: reads every topic, publishes nothing
  Append(b.argv, {"--domain", std::to_string(o.domain), "--listen", o.bridge_listen, "--port",
                  o.bridge_port, "--client-queue-kb", o.bridge_queue_kb, "--max-clients",
                  o.bridge_max_clients, "--cpus", p.cpus.empty() ? "none" : p.cpus, "--rig",
                  o.rig, "--profile", o.profile, "--seed", std::to_string(o.seed), "--log-file",
                  o.out_dir + "/bridge.log"});
  if (o.bridge_operator_input) b.argv.push_back("--operator-input");
  return b;
}

ChildSpec Leg(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec s = ChildOf(p, o, launch);
  Append(s.argv, p.args);
  const ExcitationParams& excitation = launch.plan.legs[static_cast<std::size_t>(p.leg - 1)];
  if (!p.standby && o.identify() && excitation.enabled()) {
    Append(s.argv, {"--controller", "excite", "--excite-start", std::to_string(excitation.start_s),
                    "--excite-duration", std::to_string(excitation.duration_s),
                    "--excite-seed", std::to_string(excitation.seed)});
  } else {
    Append(s.argv, {"--controller", o.controller});
  }
  Append(s.argv, OverlayArgs(o));
  if (o.coupled_legs) s.argv.push_back("--coupled-legs");
  if (const auto* fault = o.FaultOfLeg(p.leg); fault != nullptr && !p.standby)
    Append(s.argv, {"--fault", fault->kind, "--fault-at", fault->at});
  AppendControlCommon(s.argv, p, o);
  return s;
}

ChildSpec Supervisor(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec s = ChildOf(p, o, launch);
  std::vector<std::string> args{"--trajectory", o.trajectory, "--exit-when-done", "--periods",
                                std::to_string(o.periods), "--hold-timeout", o.hold_timeout_text,
                                "--hold-report", launch.hold_report, "--end-report",
                                launch.end_report};
  if (!o.wait_for_operator) args.push_back("--autostart");
  if (o.operator_activation) Append(args, {"--activation", "operator"});
  // Identification: the supervisor only holds home (no trajectory); its outer loop would
  // fight the excited leg, which moves the platform. The free-fall bench has no platform, but
  // lockstep legs answer a tick only with its setpoint: the supervisor runs (holding, outer
  // loop off); the vented bench ignores the valves. The calibration procedure holds the
  // platform still at each pose: the outer loop would integrate estimation noise there (idle
  // wander, docs/task_space.md), so it is off.
  if (o.is_experiment()) args = {"--no-outer-loop"};
  else if (!o.outer_loop || o.trajectory == "calibration") args.push_back("--no-outer-loop");
  if (o.fault_supervisor()) Append(args, {"--fault", "crash", "--fault-at", o.FaultOfLeg(0)->at});
  if (!o.feedforward) args.push_back("--no-feedforward");
  if (o.stream) Append(args, {"--stream", "--stream-port", o.stream_port});
  Append(args, OverlayArgs(o));
  Append(s.argv, args);
  Append(s.argv, p.args);
  AppendControlCommon(s.argv, p, o);
  return s;
}

// The emulated I/O board: the rig file's plant and board calibration, the session's profile
// and seed (the same physics the plant would simulate).
ChildSpec Board(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec s = ChildOf(p, o, launch);
  Append(s.argv, {"--rig", o.rig, "--profile", o.profile, "--seed", std::to_string(o.seed)});
  Append(s.argv, p.args);
  if (p.rt_priority > 0) Append(s.argv, {"--rt-priority", std::to_string(p.rt_priority)});
  if (!p.cpus.empty()) Append(s.argv, {"--cpus", p.cpus});
  Append(s.argv, o.board_extra_args);
  return s;
}

ChildSpec Plant(const ProcessSpec& p, const Options& o, const Launch& launch) {
  ChildSpec s = ChildOf(p, o, launch);
  Append(s.argv, {"--profile", o.profile, "--seed", std::to_string(o.seed)});
  Append(s.argv, p.args);
  Append(s.argv, {"--summary", o.out_dir + "/plant.json"});
  if (o.tracker) s.argv.push_back("--tracker");
  if (!o.plant_faults.empty()) Append(s.argv, {"--fault", o.plant_faults});
  if (o.operator_activation) Append(s.argv, {"--activation", "operator"});
  Append(s.argv, o.plant_extra_args);
  if (o.identify()) {
    Append(s.argv, {"--duration", std::to_string(launch.plan.total_duration_s), "--truth-out",
                    launch.truth_path});
  }
  if (o.free_fall()) {
    Append(s.argv, {"--bench", "free-fall", "--bench-load-kg", std::to_string(o.free_fall_load_kg),
                    "--bench-release-s", std::to_string(kFreeFallReleaseS), "--duration",
                    std::to_string(kFreeFallReleaseS + kFreeFallAfterS), "--truth-out",
                    launch.truth_path});
  }
  AppendControlCommon(s.argv, p, o);
  return s;
}

}  // namespace

std::string Executable(const std::string& build_relative) {
#ifdef HEXA_INSTALLED_BIN_DIR
  return std::string(HEXA_INSTALLED_BIN_DIR) + build_relative.substr(build_relative.rfind('/'));
#else
  return std::string(HEXA_BINARY_DIR) + build_relative;
#endif
}

session::SessionOptions LayoutOptionsOf(const Options& o) {
  session::SessionOptions s;
  s.realtime = o.mode == "realtime";
  s.recorder = o.recorder;
  s.bridge = o.bridge;
  s.standby.fill(o.standby);
  s.rt_sched = o.rt_sched;
  s.stale_ticks = o.stale_ticks;
  s.cpus_control = o.cpus_control;
  s.cpus_standby = o.cpus_standby;
  s.cpus_supervisor = o.cpus_supervisor;
  s.cpus_recorder = o.cpus_recorder;
  s.cpus_bridge = o.cpus_bridge;
  s.board_port = o.device == "board" ? o.board_port : 0;
  return s;
}

int PrepareSession(Options& o, Launch& launch, spdlog::logger& log) {
  if (int rc = ChooseDomain(o, log); rc != kContinue) return rc;
  log.info("session: trajectory={} controller={} profile={} mode={} seed={} domain={} out={}",
           o.trajectory, o.controller, o.profile, o.mode, o.seed, o.domain, o.out_dir);
  log.info("DDS config: {}", o.dds_config);
  log.info("CPUs: plant and legs {}, supervisor {}, recorder {}{}{}{}{}",
           o.cpus_control.empty() ? "any" : o.cpus_control,
           o.cpus_supervisor.empty() ? "any" : o.cpus_supervisor,
           o.cpus_recorder.empty() ? "any" : o.cpus_recorder,
           o.standby ? ", hot standbys " : "",
           o.standby ? (o.cpus_standby.empty() ? "any" : o.cpus_standby) : "",
           o.bridge ? ", bridge " : "",
           o.bridge ? (o.cpus_bridge.empty() ? "any" : o.cpus_bridge) : "");
  for (const auto& overlay : o.rig_overlays)
    log.info("rig overlay for the controllers and the supervisor: {}", overlay);
  if (o.device == "board") {
    std::string error;
    o.board_port = FreeLoopbackUdpPort(error);
    if (o.board_port == 0) {
      log.error("--device board: {}", error);
      return exit_code::kRunError;
    }
    log.info("device: the I/O board emulated by hexa_board_emulator on UDP 127.0.0.1:{} ({})",
             o.board_port, o.mode == "realtime" ? "wall clock, 1 kHz" : "stepped once per command");
  }
  launch.layout = session::BuildSessionLayout(LayoutOptionsOf(o));
  launch.env = {{"CYCLONEDDS_URI", "file://" + o.dds_config}};
  if (int rc = SecureSession(o, launch, log); rc != kContinue) return rc;
  launch.mcap = o.out_dir + "/session.mcap";
  launch.hold_report = o.out_dir + "/hold.txt";
  launch.end_report = o.out_dir + "/end.txt";
  std::remove(launch.end_report.c_str());  // a previous session's in the same --out
  launch.truth_path = o.out_dir + "/plant_truth.textproto";
  // The identification experiment's schedule (the same plan hexa_sim --experiment uses).
  launch.plan = o.identify() ? PlanIdentificationExperiment(o.excite_legs, o.excite_duration_s,
                                                            static_cast<std::uint64_t>(o.seed))
                             : ExcitationPlan{};
  LogPlan(o, launch, log);
  launch.children = BuildChildren(o, launch);
  return kContinue;
}

std::vector<ChildSpec> BuildChildren(const Options& o, const Launch& launch) {
  std::vector<ChildSpec> children;
  for (const ProcessSpec& p : launch.layout.processes) {
    switch (p.role) {
      case Role::kRecorder: children.push_back(Recorder(p, o, launch)); break;
      case Role::kBridge: children.push_back(Bridge(p, o, launch)); break;
      case Role::kLeg: children.push_back(Leg(p, o, launch)); break;
      case Role::kSupervisor: children.push_back(Supervisor(p, o, launch)); break;
      case Role::kPlant: children.push_back(Plant(p, o, launch)); break;
      case Role::kBoard: children.push_back(Board(p, o, launch)); break;
    }
  }
  return children;
}

}  // namespace hexa::launcher
