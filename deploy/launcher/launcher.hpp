// hexa_session in four steps: parse the options (options.cpp), build the session's children
// from its layout (build.cpp, deploy/session), start and supervise them (supervise.cpp), then
// stop them, recover / attach / report the recording and choose the exit code
// (post_process.cpp). Exit codes: hexa/services/exit_code.hpp, docs/exit_codes.md.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <spdlog/logger.h>

#include "hexa/core/excitation.hpp"
#include "process_group.hpp"
#include "session_layout.hpp"

namespace hexa::launcher {

struct Options {
  std::string trajectory, controller, profile, mode, out_dir, rig, dds_config;
  long long seed = 1, domain = 0, periods = 0, stale_ticks = 15;
  bool domain_chosen = true;  // no --domain: the next free one is taken when in use
  bool recorder = true, standby = false, coupled_legs = false, outer_loop = true, rt_sched = true, bridge = false,
       feedforward = true, tracker = false, secure = false, command_auth = true,
       wait_for_operator = false;
  // --activation operator: the hardware stays inactive until an operator start or home is
  // granted (implies --wait-for-operator; docs/faults.md, "Hardware lifecycle").
  bool operator_activation = false;
  std::string cpus_control, cpus_recorder, cpus_standby, cpus_supervisor, cpus_bridge;
  std::string bridge_listen, bridge_port, bridge_queue_kb, bridge_max_clients;
  bool bridge_operator_input = false;
  // The external motion stream (hexa_task_space --stream), on 127.0.0.1:stream_port.
  bool stream = false;
  std::string stream_port;
  // Passed on to the control processes as given.
  std::string rt_lease, lockstep_lease, cpu_latency_us, rt_dds_event_thread;
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
  std::string plant_faults;  // --plant-fault, passed to the plant's --fault
  double timeout_s = 0;
  std::string timeout_text, hold_timeout_text;  // as given, for messages and the supervisor
  bool split_recording = false;                  // --record-split-mb / --record-split-s
  std::string record_split_mb, record_split_s, record_keep_files;
  std::vector<std::string> rig_overlays;      // absolute paths, for the legs and the supervisor
  std::vector<std::string> plant_extra_args;  // --plant-arg, passed on as given
  std::string device = "sim";                 // "board": hexa_board_emulator behind the plant
  std::vector<std::string> board_extra_args;  // --board-arg, passed on as given
  int board_port = 0;                         // the emulator's UDP port (PrepareSession)
  std::string experiment = "none";            // "identify": docs/identification.md
  std::vector<int> excite_legs;
  std::string excite_legs_text;
  double excite_duration_s = 30.0;
  double free_fall_load_kg = 12.0;
  std::string command;  // the command line, for the identification recording's session info

  bool identify() const { return experiment == "identify"; }
  bool free_fall() const { return experiment == "free-fall"; }
  bool is_experiment() const { return identify() || free_fall(); }
};

// The free-fall bench (Appendix B): released at 0.5 s, watched for 1 s after.
inline constexpr double kFreeFallReleaseS = 0.5, kFreeFallAfterS = 1.0;

// Parses and checks the command line, creates the output directory. Returns -1 to go on,
// else the exit code (0 after --help, 2 for bad arguments, with the message on stderr).
int ParseOptions(int argc, char** argv, Options& o);

// The layout options of the session (deploy/session): the same processes hexa_deploy
// generate writes units for.
session::SessionOptions LayoutOptionsOf(const Options& o);

// What the session runs, built before anything starts.
struct Launch {
  session::SessionLayout layout;
  std::map<std::string, std::string> env;     // every child's: CYCLONEDDS_URI, the session key
  std::vector<deploy::ChildSpec> children;    // in the layout's start order
  ExcitationPlan plan;                        // --experiment identify
  std::string mcap, hold_report, truth_path;  // files in the output directory
  std::string end_report;  // the supervisor's line on how the session ended (--end-report)
};

// Checks the DDS domain (another session on it: the next free one, or exit 2), makes the
// security files (--secure) and the session key. Returns -1 to go on, else the exit code.
int PrepareSession(Options& o, Launch& launch, spdlog::logger& log);
// The children's command lines: the layout's processes with this machine's paths, log
// files and the launcher's options.
std::vector<deploy::ChildSpec> BuildChildren(const Options& o, const Launch& launch);
// The path of a binary of the build tree ("/services/recorder/hexa_recorder"), or of the
// installed one (Debian package: all in bin/).
std::string Executable(const std::string& build_relative);

// How the session ended (supervise.cpp).
struct SessionEnd {
  bool completed = false;
  bool failed = false;
  int outcome = 1;             // exit code when not completed
  std::string ended_because;   // one line for the console and report.md when not completed
  std::vector<deploy::ChildExit> exits;  // every child's exit, with its CPU time
  bool recorder_clean = false;  // the recorder exited 0 after closing its file
  bool start_failed = false;    // a child could not start: every process was stopped
  std::chrono::steady_clock::time_point t0;
};

// Starts the children in order (telling each the pids of its peers) and watches them until
// the session completes or fails.
SessionEnd Supervise(deploy::ProcessGroup& group, const Options& o, const Launch& launch,
                     spdlog::logger& log);

// Stops every process in order, writes processes.json, recovers / attaches / reports the
// recording, and returns the exit code of the session.
int PostProcess(deploy::ProcessGroup& group, const Options& o, const Launch& launch,
                SessionEnd& end, spdlog::logger& log);

// The last `lines` lines of a file, indented, for log messages.
std::string TailOf(const std::string& path, int lines);

}  // namespace hexa::launcher
