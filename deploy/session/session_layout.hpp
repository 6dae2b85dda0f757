// The process layout of a session, in one place: which processes run, with which binary,
// role arguments, CPUs, SCHED_FIFO priorities, reader counts and recorder QoS, in which
// order they start and whose process ids each must know. hexa_session launches it on one
// machine; hexa_deploy generate writes it as systemd units (docs/deployment.md). Each adds
// only what belongs to its way of running a process (log files and peer pids; the
// deployment's paths, start-up timeout and per-process overrides).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace hexa::session {

enum class Role { kPlant, kSupervisor, kLeg, kRecorder, kBridge, kBoard };

struct SessionOptions {
  bool realtime = false;       // lockstep otherwise
  bool recorder = true;        // hexa_recorder records the session
  bool bridge = false;         // hexa_bridge (Foxglove) watches it
  std::array<bool, 6> standby{};  // legs 1..6 that have a hot-standby controller
  // The plant waits for one live standby per leg before tick 0 (--expect-standbys).
  bool plant_waits_for_standbys = false;
  bool rt_sched = true;        // real time: the processes run SCHED_FIFO
  long long stale_ticks = 15;  // ticks a leg's command may lag before the plant closes its valve
  // The rig behind the plant: its own simulation, or a remote I/O board. With board_port > 0
  // the session runs hexa_board_emulator on 127.0.0.1:board_port (lockstep: stepped once per
  // command; real time: on the wall clock) and the plant drives it over UDP.
  int board_port = 0;
  // CPU lists ("0-1", "3"; empty: any CPU).
  std::string cpus_control;     // the plant and the primary legs
  std::string cpus_standby;     // the hot standbys
  std::string cpus_supervisor;
  std::string cpus_recorder;
  std::string cpus_bridge;
};

struct ProcessSpec {
  std::string name;  // NodeStatus name and DDS Security identity: plant, leg3, leg3_standby
  Role role = Role::kPlant;
  int leg = 0;  // 1..6 for a leg controller
  bool standby = false;
  std::string binary;      // file name: hexa_leg_ctrl
  std::string build_dir;   // its directory in the build tree: services/leg_ctrl
  std::string verb;        // first argument (hexa_recorder: "record"); empty: none
  // The arguments that define the process's part in the session, the same wherever it runs:
  // --leg 3 --standby --valve-readers 2, --legs 6 --supervisor --stale-ticks 15, ...
  std::vector<std::string> args;
  std::string cpus;     // CPU list; empty: any
  int rt_priority = 0;  // real time: SCHED_FIFO priority (0: SCHED_OTHER or lockstep)
  // Readers to match before running.
  int valve_readers = 0;  // leg: the plant, and the recorder when there is one
  int pose_readers = 0;   // supervisor: the recorder (0: none, no argument)
  bool expect_recorder = false;      // plant: waits for the recorder before tick 0
  std::string periodic_reliability;  // recorder: QoS of the periodic topics ("" = reliable)
  // Processes whose pid this one is told (--peer-pid name=pid) when they run on the same
  // machine: a peer that ended is then dead at once (lockstep), not after its DDS lease.
  std::vector<std::string> peers;
};

struct SessionLayout {
  // In start order: board emulator, recorder, bridge, supervisor, legs, plant.
  std::vector<ProcessSpec> processes;
  const ProcessSpec* Find(const std::string& name) const;
  std::vector<std::string> Names() const;
};

// The SCHED_FIFO priority of a role in real time, the same as the services' own defaults.
int DefaultRtPriority(Role role);

SessionLayout BuildSessionLayout(const SessionOptions& options);

// "leg3", "leg3_standby".
std::string LegName(int leg, bool standby);

}  // namespace hexa::session
