#include "session_layout.hpp"

namespace hexa::session {

const ProcessSpec* SessionLayout::Find(const std::string& name) const {
  for (const auto& p : processes)
    if (p.name == name) return &p;
  return nullptr;
}

std::vector<std::string> SessionLayout::Names() const {
  std::vector<std::string> names;
  for (const auto& p : processes) names.push_back(p.name);
  return names;
}

int DefaultRtPriority(Role role) {
  switch (role) {
    // The legs highest: the tightest deadline (10 ms lease) and the shortest work; a plant or
    // supervisor above them on their CPU made them lapse (docs/measurements/deployment.md,
    // "Where the lapses' milliseconds go"). The same defaults as the services' own.
    case Role::kPlant: return 70;       // hexa_plant_sim: late, its schedule slips
    case Role::kLeg: return 80;         // hexa_leg_ctrl
    case Role::kSupervisor: return 75;  // hexa_task_space
    case Role::kRecorder: return 50;    // below the loop; starved, it loses samples
    case Role::kBridge: return 0;       // a viewer: never above the loop
    // The emulated board does the physics each 1 ms tick that a simulating plant does: the
    // plant's priority, which a board-driving plant hardly needs.
    case Role::kBoard: return 70;       // hexa_board_emulator
  }
  return 0;
}

std::string LegName(int leg, bool standby) {
  return "leg" + std::to_string(leg) + (standby ? "_standby" : "");
}

namespace {

ProcessSpec Process(const SessionOptions& o, Role role, std::string name, std::string binary,
                    std::string build_dir, std::string cpus) {
  ProcessSpec p;
  p.role = role;
  p.name = std::move(name);
  p.binary = std::move(binary);
  p.build_dir = std::move(build_dir);
  p.cpus = std::move(cpus);
  p.rt_priority = o.realtime && o.rt_sched ? DefaultRtPriority(role) : 0;
  return p;
}

ProcessSpec Recorder(const SessionOptions& o) {
  ProcessSpec p = Process(o, Role::kRecorder, "recorder", "hexa_recorder", "services/recorder",
                          o.cpus_recorder);
  p.verb = "record";
  // Real time: the periodic topics best effort, as the controllers read them, so that no
  // control writer repairs what the recorder's link drops (docs/measurements/deployment.md,
  // "The lossy recorder link").
  if (o.realtime) {
    p.periodic_reliability = "best-effort";
    p.args = {"--periodic-reliability", p.periodic_reliability};
  }
  return p;
}

ProcessSpec Leg(const SessionOptions& o, int leg, bool standby) {
  ProcessSpec p = Process(o, Role::kLeg, LegName(leg, standby), "hexa_leg_ctrl",
                          "services/leg_ctrl", standby ? o.cpus_standby : o.cpus_control);
  p.leg = leg;
  p.standby = standby;
  p.args = {"--leg", std::to_string(leg)};
  if (standby) p.args.push_back("--standby");
  // The plant reads the valve commands; with a recorder, a leg runs only once the recorder
  // has matched them too: otherwise a recorder that discovers a leg late misses its first
  // ticks.
  p.valve_readers = o.recorder ? 2 : 1;
  p.args.insert(p.args.end(), {"--valve-readers", std::to_string(p.valve_readers)});
  p.peers = {"supervisor"};
  return p;
}

}  // namespace

SessionLayout BuildSessionLayout(const SessionOptions& o) {
  // Start order: the supervisor before the legs, so that each leg knows the supervisor's
  // process id; the plant last, knowing every other control process's and the recorder's.
  SessionLayout layout;
  auto& procs = layout.processes;
  if (o.board_port > 0) {
    // First: it must listen before the plant starts (the plant's bring-up asks it to answer).
    // Off the control CPU: a real board is hardware of its own.
    ProcessSpec board = Process(o, Role::kBoard, "board", "hexa_board_emulator", "device/emulator",
                                o.cpus_recorder);
    board.args = {"--bind", "127.0.0.1", "--port", std::to_string(o.board_port), "--clock",
                  o.realtime ? "wall" : "step"};
    procs.push_back(board);
  }
  if (o.recorder) procs.push_back(Recorder(o));
  if (o.bridge) {
    procs.push_back(Process(o, Role::kBridge, "bridge", "hexa_bridge", "services/bridge",
                            o.cpus_bridge));
  }
  ProcessSpec supervisor = Process(o, Role::kSupervisor, "supervisor", "hexa_task_space",
                                   "services/task_space", o.cpus_supervisor);
  if (o.recorder) {
    supervisor.pose_readers = 1;
    supervisor.args = {"--pose-readers", "1"};
  }
  procs.push_back(supervisor);
  for (int leg = 1; leg <= 6; ++leg) {
    procs.push_back(Leg(o, leg, false));
    if (o.standby[static_cast<std::size_t>(leg - 1)]) procs.push_back(Leg(o, leg, true));
  }
  ProcessSpec plant = Process(o, Role::kPlant, "plant", "hexa_plant_sim", "services/plant_sim",
                              o.cpus_control);
  plant.args = {"--legs", "6", "--supervisor", "--stale-ticks", std::to_string(o.stale_ticks)};
  if (o.board_port > 0)
    plant.args.insert(plant.args.end(), {"--device", "board", "--board-address",
                                         "127.0.0.1:" + std::to_string(o.board_port)});
  plant.expect_recorder = o.recorder;
  if (o.recorder) plant.args.push_back("--expect-recorder");
  if (o.plant_waits_for_standbys) plant.args.push_back("--expect-standbys");
  for (const auto& p : procs)
    if (p.role != Role::kBridge && p.role != Role::kBoard) plant.peers.push_back(p.name);
  procs.push_back(plant);
  return layout;
}

}  // namespace hexa::session
