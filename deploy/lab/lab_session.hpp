// A whole networked session on one machine: five hosts in network namespaces (NetnsLab),
// a deployment description written for them, `hexa_deploy generate --in-place`, the DDS
// Security files from deploy/make_security.sh, and every process started from its generated
// unit (UnitLauncher). Used by the multi-host tests (tests/netns) and the deployment
// benchmark (bench/deployment).
//
// Hosts (the reference five-host layout; its processes are the session's layout,
// deploy/session):             io-sup     plant + supervisor (+ operator identity)
//                              legs-a     legs 1-3
//                              legs-b     legs 4-6
//                              standby-b  hot standbys of legs 4-6 (optional)
//                              recorder   recorder
// or those of a deployment file (LabSessionOptions::layout_file).
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netns_lab.hpp"
#include "process_group.hpp"
#include "unit_launcher.hpp"

namespace hexa::deploy {

struct LabSessionOptions {
  std::string tag = "hx15";        // namespace / interface prefix (keep it to 4 characters)
  std::string subnet = "10.15.0";  // private /24 inside the lab
  std::string work_dir;            // short path: notify sockets live here
  // Binaries: name -> path (hexa_plant_sim hexa_leg_ctrl hexa_task_space hexa_recorder
  // hexa_deploy hexa_operator); symlinked into <work_dir>/bin, the deployment's bin_dir.
  std::map<std::string, std::string> binaries;
  std::string make_security;       // deploy/make_security.sh
  std::string rig_file;
  bool secure = true;
  bool realtime = false;
  bool standbys = true;
  int domain = 7;
  std::vector<std::string> supervisor_args;  // e.g. --trajectory z --periods 1 --autostart --exit-when-done
  std::vector<std::string> plant_args;       // e.g. --seed 1 --profile realistic
  double watchdog_s = 0;          // 0: the generator's default
  double lockstep_timeout_s = 0;
  int stale_ticks = 0;
  double startup_timeout_s = 120;
  // security { metadata_protection: ... }: "" = the deployment's default, else ENCRYPT, SIGN
  // or NONE (the benchmark's governance variants).
  std::string metadata_protection;
  std::string loop_metadata_protection;  // security { loop_metadata_protection: ... } likewise
  bool audit = false;              // security.audit_dir = <work_dir>/audit
  // Every process gets a `cpu:` as the one-machine session places it (hexa_session
  // --cpus-control/--cpus-supervisor/--cpus-standby/--cpus-recorder auto): the plant and the
  // primary legs on this machine's last allowed CPU, the supervisor, the standbys and the
  // recorder on its first. The lab's five hosts share one machine's CPUs; on real boards each
  // board has its own and the deployment pins what it needs. Off, or with one CPU: unpinned.
  bool cpu_placement = true;
  // With cpu_placement: the primary legs of host "legs-b" (legs 4-6) on the first CPU with the
  // supervisor and the recorder instead of beside the plant: the control load of the two legs
  // boards spread over both CPUs, closer to boards that each have their own CPU (the
  // benchmark's --cpu-placement split).
  bool split_legs_b = false;
  // Start the plant (the real-time clock) this long after every other process: their
  // discovery and security handshakes with each other are then over before tick 0.
  double plant_start_delay_s = 0;
  std::vector<std::string> extra_hosts;  // more lab hosts outside the deployment (e.g. "intruder")
  // A deployment file whose hosts and processes the lab runs instead of the built-in layout
  // above (e.g. deploy/deployments/four-hosts.textproto): its host names, and per process the
  // role, leg, standby and args. The lab replaces its interfaces and addresses by its own
  // veths, its mode, security and timing by the options above, and its `cpu:` by the lab's
  // placement (cpu_placement). `standbys` is then ignored. Empty: the built-in layout.
  std::string layout_file;
};

class LabSession {
 public:
  // Builds the lab, writes and generates the deployment, makes the security files.
  static std::unique_ptr<LabSession> Create(const LabSessionOptions& options, std::string& error);
  ~LabSession();

  // Starts every unit of every host (recorder first, plant last).
  bool StartAll(std::string& error);
  // Waits for the supervisor's exit; other exits are returned too (the caller decides).
  ProcessGroup::Event Wait(std::chrono::milliseconds timeout) { return group_.WaitEvent(timeout); }
  // Stops the named process (unit name without .service), SIGTERM then SIGKILL.
  std::optional<ChildExit> Stop(const std::string& name) {
    return group_.Stop(name, std::chrono::milliseconds(8000));
  }
  void StopAll() { group_.StopAll(std::chrono::milliseconds(8000)); }

  // The newest recording in the record directory ("" if none).
  std::string Recording() const;
  NetnsLab& lab() { return *lab_; }
  UnitLauncher& units() { return *launcher_; }
  ProcessGroup& group() { return group_; }
  const std::string& generated_dir() const { return generated_; }
  const std::string& work_dir() const { return options_.work_dir; }
  // The generated Cyclone configuration of a host (in place).
  std::string DdsConfigOf(const std::string& host) const;
  // Every host of the deployment with its units.
  std::vector<std::pair<std::string, std::vector<std::string>>> Plan() const;

  // The deployment text the session generated from.
  const std::string& deployment_text() const { return deployment_text_; }

 private:
  LabSession() = default;
  LabSessionOptions options_;
  ProcessGroup group_;
  std::unique_ptr<NetnsLab> lab_;
  std::unique_ptr<UnitLauncher> launcher_;
  std::string generated_, deployment_text_;
  std::vector<std::string> hosts_;  // the deployment's hosts, in start order (recorder first)
};

// Runs a command to completion (stdout+stderr to `log`), returns its exit code (-1 on
// failure to start, 128+signal when killed).
int RunToCompletion(ProcessGroup& group, const std::string& name, const std::vector<std::string>& argv,
                    const std::string& log, std::chrono::seconds timeout,
                    const std::map<std::string, std::string>& env = {});

}  // namespace hexa::deploy
