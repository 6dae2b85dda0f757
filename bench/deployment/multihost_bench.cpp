// hexa_multihost_bench: the networked deployment's figures (docs/measurements/deployment.md):
// five hosts in network namespaces, every process from its generated unit, DDS Security on
// (or off for the side-by-side cost), z trajectory. Scenarios:
//   lockstep        secured lockstep session: speed, RMSE, round trip, loss, bit-identity
//   lockstep-plain  the same without DDS Security (cost of security, same run)
//   realtime        secured real-time session: RMSE, round trip, loss, faults
//   realtime-plain  the same without DDS Security
//   loss            real time with nftables `numgen random` drops on the input of legs-a
//                   (sensors and setpoints of legs 1-3), for each --loss percentage
//   recorder-loss   real time with drops on the recorder host's input: the recorder's loss
//                   count beside the packets nftables dropped
//   partition       real time, operator-driven: start, cut legs-a off for --partition-ms,
//                   heal, reset, start again; detection delay, HOLD, resumption
// Needs root (network namespaces, nftables). Timing figures depend on the machine's load:
// the bench prints the load average with each row. Not a test: nothing is asserted.
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/json.hpp"
#include "lab_session.hpp"
#include "recording.pb.h"

namespace {

using namespace hexa::deploy;
using namespace std::chrono_literals;
namespace rec = hexa::rec;

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// nflog group of the loss rule's log when --capture-drops (per namespace: no clash between
// labs), and the capture's name in the session's process group.
constexpr int kDropLogGroup = 15;
constexpr const char* kDropCaptureName = "drop-capture";

struct Row {
  std::string scenario;
  bool completed = false;
  double wall_s = 0, sim_s = 0;
  std::array<double, 3> rmse_mm{};
  double rtt_median_us = 0, rtt_p99_us = 0;
  std::uint64_t missing = 0;
  std::size_t faults = 0;
  long long dropped = -1;  // nftables counter
  long long input_packets = -1;  // packets the loss rule saw (dropped or not)
  double cpu_s = 0;        // CPU time of all control processes and the recorder
  // From the plant's READY to the supervisor's end (the loop without start-up and its
  // security handshakes): per role (plant, supervisor, legs, standbys, recorder) and per
  // role and thread name ("legs/recvUC").
  double cpu_loop_s = 0;
  std::map<std::string, double> cpu_loop_by_role, cpu_loop_by_thread;
  std::string placement;  // per unit at the plant's READY: CPUs, policies, latency hold
  std::string note;
  std::string load;
  // Wall clock (CLOCK_REALTIME, the clock of DDS source times) of the plant's READY and of
  // the session's end as the bench saw them, and of the first FaultEvent in the recording
  // (0: none): bench/deployment/cpu_utilisation.py lays the per-CPU samples beside them.
  std::int64_t ready_ns = 0, end_ns = 0, first_fault_ns = 0;
  std::string first_fault;
  std::string work_dir;
  // Recorder's own count: samples of the periodic topics that reached it / that Cyclone
  // counted lost (best-effort readers: sequence-number gaps), from its summary.
  std::string recorder_summary;
  // The recorder's loss events (producer x tick with samples missing: one per lost batch).
  std::string recorder_loss_events;
  // UDP datagrams the recorder host's kernel dropped (receive buffer full): loss on the host,
  // not on its link.
  long long recorder_rcvbuf_errors = -1;
};

std::int64_t WallNow_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

LabSessionOptions BaseOptions(const std::string& build, const std::string& source, const std::string& name,
                              int domain) {
  LabSessionOptions o;
  o.work_dir = "/tmp/hx15b-" + name + "-" + std::to_string(getpid());
  o.binaries = {{"hexa_plant_sim", build + "/services/plant_sim/hexa_plant_sim"},
                {"hexa_leg_ctrl", build + "/services/leg_ctrl/hexa_leg_ctrl"},
                {"hexa_task_space", build + "/services/task_space/hexa_task_space"},
                {"hexa_recorder", build + "/services/recorder/hexa_recorder"},
                {"hexa_deploy", build + "/deploy/hexa_deploy"},
                {"hexa_operator", build + "/services/task_space/hexa_operator"}};
  o.make_security = source + "/deploy/make_security.sh";
  o.rig_file = source + "/deploy/rigs/hexataar_r.textproto";
  o.domain = domain;
  o.tag = "hx5b";
  o.subnet = "10.16.0";
  o.lockstep_timeout_s = 10;
  o.watchdog_s = 30;
  return o;
}

// Fills the report columns of `row` from the session's recording.
void FromRecording(LabSession& s, Row& row) {
  const std::string mcap = s.Recording();
  if (mcap.empty()) {
    row.note += " no recording;";
    return;
  }
  try {
    const auto r = hexa::recorder::ComputeSessionReport(mcap);
    for (int i = 0; i < 3; ++i) row.rmse_mm[static_cast<std::size_t>(i)] = r.rmse_vs_truth[static_cast<std::size_t>(i)] * 1e3;
    row.rtt_median_us = r.latency_s.median * 1e6;
    row.rtt_p99_us = r.latency_s.p99 * 1e6;
    for (const auto& [t, m] : r.missing) row.missing += m;
    row.faults = r.faults.size();
    row.sim_s = r.sim_time_s;
    // The first fault, with its wall-clock time.
    hexa::recorder::ReadRecording(mcap, [&](const hexa::recorder::McapChannel& ch,
                                            const hexa::recorder::McapMessageView&,
                                            const google::protobuf::Message& msg) {
      if (ch.topic != "hexa_FaultEvent") return;
      rec::FaultEvent f;
      f.ParseFromString(msg.SerializeAsString());
      if (row.first_fault_ns != 0 && f.source_time_ns() >= row.first_fault_ns) return;
      row.first_fault_ns = f.source_time_ns();
      row.first_fault = f.source_node() + " leg " + std::to_string(f.leg_id()) + " tick " +
                        std::to_string(f.tick()) + " " + rec::FaultReason_Name(f.reason());
    });
  } catch (const std::exception& e) {
    row.note += std::string(" report failed: ") + e.what() + ";";
  }
}

// The role of a unit, for the CPU breakdown.
std::string RoleOf(const std::string& unit) {
  if (unit.find("standby") != std::string::npos) return "standbys";
  if (unit.rfind("hexa-leg", 0) == 0) return "legs";
  if (unit.rfind("hexa-", 0) == 0) return unit.substr(5);
  return unit;
}

// CPU seconds so far: per role and per role/thread, of every unit still running.
struct CpuSnapshot {
  std::map<std::string, double> role, thread;
  std::map<std::string, double> unit;  // unit -> process total
};
CpuSnapshot TakeCpuSnapshot(const UnitLauncher& units) {
  CpuSnapshot snap;
  for (const auto& name : units.Names()) {
    const double c = units.CpuSeconds(name);
    if (c < 0) continue;
    snap.unit[name] = c;
    snap.role[RoleOf(name)] += c;
    for (const auto& [thread, t] : units.ThreadCpuSeconds(name))
      snap.thread[RoleOf(name) + "/" + thread] += t;
  }
  return snap;
}

// What each unit got of the loop settings, read from the running processes at the plant's
// READY: its CPUs, its threads' policies (F = SCHED_FIFO, O = SCHED_OTHER; "tev" should be O
// in real time, the rest F) and whether its log says the CPU wake-up latency is held.
std::string DescribePlacement(const UnitLauncher& units) {
  std::string out;
  std::map<std::string, std::string> groups;  // description -> units
  for (const auto& name : units.Names()) {
    int fifo = 0, other = 0;
    std::string others;
    for (const auto& [thread, policy] : units.ThreadPolicies(name)) {
      if (policy == 1) {
        ++fifo;
      } else {
        ++other;
        others += (others.empty() ? "" : ",") + thread;
      }
    }
    const std::string log = Slurp(units.LogOf(name));
    const bool hold = log.find("CPU wake-up latency held") != std::string::npos;
    char buf[256];
    std::snprintf(buf, sizeof buf, "cpus %s FIFO %d OTHER %d%s%s%s hold %s", units.AllowedCpus(name).c_str(), fifo,
                  other, others.empty() ? "" : " (", others.c_str(), others.empty() ? "" : ")", hold ? "yes" : "no");
    groups[buf] += (groups[buf].empty() ? "" : ",") + name.substr(5);
  }
  for (const auto& [what, names] : groups) out += (out.empty() ? "" : "; ") + names + ": " + what;
  return out;
}

// Runs until the supervisor exits; `during` is called every 0.5 s with the seconds since the
// plant reported READY (negative before).
Row RunSession(const std::string& scenario, LabSessionOptions o,
               const std::function<void(LabSession&, double)>& during = {},
               std::chrono::seconds timeout = 600s) {
  Row row;
  row.scenario = scenario;
  row.load = LoadAverage();
  static int run = 0;
  o.work_dir += "-" + std::to_string(run++);  // every run keeps its logs
  std::string err;
  auto s = LabSession::Create(o, err);
  if (!s) {
    row.note = "setup failed: " + err;
    return row;
  }
  if (!s->StartAll(err)) {
    row.note = "start failed: " + err;
    return row;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point ready{};
  CpuSnapshot at_ready, latest;
  while (std::chrono::steady_clock::now() - t0 < timeout) {
    const auto ev = s->Wait(500ms);
    s->units().Poll();
    if (ready == std::chrono::steady_clock::time_point{} && s->units().Seen("hexa-plant").ready) {
      ready = std::chrono::steady_clock::now();
      row.ready_ns = WallNow_ns();
      at_ready = TakeCpuSnapshot(s->units());
      row.placement = DescribePlacement(s->units());
    }
    // Every unit's CPU while the supervisor still runs (an exited process is gone from /proc).
    if (ready != std::chrono::steady_clock::time_point{} &&
        !(ev.kind == ProcessGroup::Event::kChildExited && ev.exit.name == "hexa-supervisor"))
      latest = TakeCpuSnapshot(s->units());
    if (during) {
      const double since = ready == std::chrono::steady_clock::time_point{}
                               ? -1.0
                               : std::chrono::duration<double>(std::chrono::steady_clock::now() - ready).count();
      during(*s, since);
    }
    // CPU time so far of every unit (read while they run: an exited one is gone).
    double cpu = 0;
    for (const auto& name : s->units().Names()) {
      const double c = s->units().CpuSeconds(name);
      if (c > 0) cpu += c;
    }
    if (cpu > row.cpu_s) row.cpu_s = cpu;
    if (ev.kind == ProcessGroup::Event::kChildExited) {
      if (ev.exit.name == "hexa-supervisor") {
        row.completed = ev.exit.signal == 0 && ev.exit.exit_code == 0;
        if (!row.completed) row.note += " supervisor: " + ev.exit.Describe() + ";";
        break;
      }
      if (ev.exit.name.rfind("hexa-", 0) == 0) {
        row.note += " " + ev.exit.Describe() + ";";
        // A control process died: the session cannot complete; give the supervisor a moment
        // to notice (it holds), then stop.
        if (ev.exit.exit_code != 0 || ev.exit.signal != 0) {
          s->Wait(3000ms);
          break;
        }
      }
    }
  }
  for (const auto& [role, c] : latest.role) {
    const double d = c - at_ready.role[role];
    row.cpu_loop_by_role[role] = d;
    row.cpu_loop_s += d;
  }
  for (const auto& [thread, c] : latest.thread) row.cpu_loop_by_thread[thread] = c - at_ready.thread[thread];
  row.end_ns = WallNow_ns();
  row.recorder_rcvbuf_errors = s->lab().UdpReceiveBufferErrors("recorder");
  row.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                             (ready == std::chrono::steady_clock::time_point{} ? t0 : ready))
                   .count();
  // A drop capture (--capture-drops) stops last: it must see what the loss rule drops until
  // every process of the session is gone. The others in reverse start order, as StopAll.
  if (s->group().Running(kDropCaptureName)) {
    std::vector<std::string> names = s->group().RunningNames();
    for (auto it = names.rbegin(); it != names.rend(); ++it)
      if (*it != kDropCaptureName) s->group().Stop(*it, 8000ms);
  }
  s->StopAll();
  // Once more with every process stopped: the counters of a loss rule then hold everything
  // dropped while the session's processes ran, not only until the last 0.5 s poll.
  if (during) during(*s, 1e9);
  FromRecording(*s, row);
  row.work_dir = o.work_dir;
  row.note += " logs " + o.work_dir + ";";
  // The recorder's summary (stdout at its stop): per topic received, missing, dds_lost.
  {
    const std::string rec_log = Slurp(s->units().LogOf("hexa-recorder"));
    std::smatch rm;
    std::string summary;
    for (const char* topic : {"hexa_LegSensors", "hexa_ValveCommand", "hexa_GroundTruth", "hexa_ImuSample",
                              "hexa_LegSetpoint", "hexa_PoseReport"}) {
      if (std::regex_search(rec_log, rm, std::regex(std::string(topic) + " +([0-9]+) +([0-9-]+) +([0-9-]+) +([0-9]+)")))
        summary += std::string(summary.empty() ? "" : ", ") + (topic + 5) + " received " + rm[1].str() +
                   " missing " + rm[2].str() + " dds_lost " + rm[4].str();
    }
    row.recorder_summary = summary;
    if (std::regex_search(rec_log, rm, std::regex("loss events [^:]*: ([^\n]*)"))) row.recorder_loss_events = rm[1].str();
  }
  const std::string plant = Slurp(s->units().LogOf("hexa-plant"));
  std::smatch m;
  if (std::regex_search(plant, m, std::regex("command faults ([0-9]+)"))) row.note += " plant command faults " + m[1].str() + ";";
  return row;
}

// tcpdump on the loss rule's nflog group in `host`'s namespace, writing
// <work_dir>/dropped.pcap packet by packet (-U); a child of the session, stopped with it.
bool StartDropCapture(LabSession& s, const std::string& host, std::string& error) {
  const std::string log = s.work_dir() + "/drop-capture.log";
  ChildSpec spec{kDropCaptureName,
                 s.lab().InHost(host, {"tcpdump", "-i", "nflog:" + std::to_string(kDropLogGroup), "-w",
                                       s.work_dir() + "/dropped.pcap", "-U", "-q", "-Z", "root"}),
                 {},
                 log};
  if (s.group().Start(spec, error) < 0) return false;
  // Listening once it says so (a second at most here); the rule goes in after that.
  for (int i = 0; i < 50; ++i) {
    if (Slurp(log).find("listening on") != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  error = "tcpdump on nflog:" + std::to_string(kDropLogGroup) + " in " + host + " did not start: " + Slurp(log);
  return false;
}

// The loop's CPU per simulated second by role, and the costliest threads (>= 2 % of it).
void PrintCpuDetail(const Row& r) {
  if (r.sim_s <= 0 || r.cpu_loop_s <= 0) return;
  std::printf("    CPU s per sim s from the plant's READY: %.3f =", r.cpu_loop_s / r.sim_s);
  for (const auto& [role, c] : r.cpu_loop_by_role) std::printf(" %s %.3f", role.c_str(), c / r.sim_s);
  std::vector<std::pair<double, std::string>> threads;
  for (const auto& [t, c] : r.cpu_loop_by_thread)
    if (c >= 0.02 * r.cpu_loop_s) threads.emplace_back(c, t);
  std::sort(threads.rbegin(), threads.rend());
  std::printf("\n    threads:");
  for (const auto& [c, t] : threads) std::printf(" %s %.3f", t.c_str(), c / r.sim_s);
  std::printf("\n");
}

void Print(const Row& r) {
  std::printf("| %-22s | %-3s | %6.1f | %5.2f | %5.2f %5.2f | %5.2f %5.2f %5.2f | %7.0f | %7.0f | %6llu | %3zu | %7lld | %s | %s\n",
              r.scenario.c_str(), r.completed ? "yes" : "NO", r.wall_s, r.wall_s > 0 ? r.sim_s / r.wall_s : 0.0,
              r.sim_s > 0 ? r.cpu_s / r.sim_s : 0.0, r.sim_s > 0 ? r.cpu_loop_s / r.sim_s : 0.0,
              r.rmse_mm[0], r.rmse_mm[1], r.rmse_mm[2], r.rtt_median_us, r.rtt_p99_us,
              static_cast<unsigned long long>(r.missing), r.faults, r.dropped, r.load.c_str(),
              r.note.c_str());
  PrintCpuDetail(r);
  if (!r.placement.empty()) std::printf("    placement: %s\n", r.placement.c_str());
  if (!r.first_fault.empty())
    std::printf("    first fault: %s, %.3f s after the plant's READY\n", r.first_fault.c_str(),
                r.ready_ns > 0 ? static_cast<double>(r.first_fault_ns - r.ready_ns) * 1e-9 : 0.0);
  if (!r.recorder_summary.empty())
    std::printf("    recorder: %s; its host's kernel dropped %lld datagrams (receive buffer full)\n",
                r.recorder_summary.c_str(), r.recorder_rcvbuf_errors);
  if (!r.recorder_loss_events.empty())
    std::printf("    recorder loss events (producer x tick, one per lost batch): %s\n", r.recorder_loss_events.c_str());
  if (r.dropped >= 0)
    std::printf("    nftables: %lld of %lld packets dropped on the lossy host's input (%.2f %%)\n", r.dropped,
                r.input_packets, r.input_packets > 0 ? 100.0 * static_cast<double>(r.dropped) / static_cast<double>(r.input_packets) : 0.0);
  // One machine-readable line per run (bench/deployment/cpu_utilisation.py).
  const hexa::json::Value run = {{"scenario", r.scenario},
                                 {"completed", r.completed},
                                 {"ready_ns", static_cast<long long>(r.ready_ns)},
                                 {"end_ns", static_cast<long long>(r.end_ns)},
                                 {"first_fault_ns", static_cast<long long>(r.first_fault_ns)},
                                 {"first_fault", r.first_fault},
                                 {"dropped", r.dropped},
                                 {"missing", static_cast<unsigned long long>(r.missing)},
                                 {"logs", r.work_dir}};
  std::printf("RUN %s\n", hexa::json::Dump(run).c_str());
  std::fflush(stdout);
}

// The partition scenario: operator-driven, no --exit-when-done.
void Partition(const LabSessionOptions& base, double partition_ms, const std::string& operator_bin) {
  LabSessionOptions o = base;
  o.realtime = true;
  o.supervisor_args = {"--trajectory", "z", "--periods", "1"};
  std::string err;
  auto s = LabSession::Create(o, err);
  if (!s) {
    std::printf("partition: setup failed: %s\n", err.c_str());
    return;
  }
  if (!s->StartAll(err)) {
    std::printf("partition: start failed: %s\n", err.c_str());
    return;
  }
  const std::string load = LoadAverage();
  for (int i = 0; i < 600 && !s->units().Seen("hexa-plant").ready; ++i) {
    s->Wait(200ms);
    s->units().Poll();
  }
  const std::string config = s->DdsConfigOf("io-sup");
  auto op = [&](const std::string& what) {
    // The deployment's session key lies beside its DDS configuration (hexa_deploy generate).
    std::map<std::string, std::string> env{
        {"HEXA_IDENTITY", "operator"},
        {"HEXA_SESSION_KEY", config.substr(0, config.rfind('/')) + "/session.key"}};
    const int rc = RunToCompletion(s->group(), "operator-" + what,
                                   s->lab().InHost("io-sup", {operator_bin, "--domain", std::to_string(o.domain),
                                                              "--dds-config", config, "--trajectory", "z",
                                                              "--wait", "20", what}),
                                   s->work_dir() + "/operator-" + what + ".log", 30s, env);
    std::printf("partition: operator %s -> exit %d\n", what.c_str(), rc);
  };
  auto sleep_for = [&](double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      s->Wait(100ms);
      s->units().Poll();
    }
  };
  sleep_for(2.0);  // the pose estimate settles
  op("start");
  sleep_for(5.0);  // blending, then tracking
  const long long before = s->lab().DroppedByPartition("legs-a");
  (void)before;
  if (!s->lab().Partition("legs-a", err)) std::printf("partition: %s\n", err.c_str());
  std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(partition_ms));
  const long long dropped = s->lab().DroppedByPartition("legs-a");
  if (!s->lab().Heal("legs-a", err)) std::printf("heal: %s\n", err.c_str());
  sleep_for(1.5);
  op("reset");
  sleep_for(1.0);
  op("start");
  sleep_for(16.0);  // blend + one 10 s period + stop
  s->StopAll();

  // What the recording says: the plant's first fault after the cut, the last command of
  // legs 1-3 before it, the supervisor's states.
  const std::string mcap = s->Recording();
  struct Fault {
    std::uint64_t tick;
    std::uint32_t leg;
    std::string source, reason;
  };
  std::vector<Fault> faults;
  std::vector<std::pair<std::uint64_t, int>> states;  // tick, state (changes only)
  hexa::recorder::ReadRecording(mcap, [&](const hexa::recorder::McapChannel& ch,
                                          const hexa::recorder::McapMessageView&,
                                          const google::protobuf::Message& msg) {
    // The decoded messages are dynamic (built from the recording's schema): re-parse them
    // into the generated types.
    if (ch.topic == "hexa_FaultEvent") {
      rec::FaultEvent f;
      f.ParseFromString(msg.SerializeAsString());
      faults.push_back({f.tick(), f.leg_id(), f.source_node(), rec::FaultReason_Name(f.reason())});
    } else if (ch.topic == "hexa_PoseReport") {
      rec::PoseReport p;
      p.ParseFromString(msg.SerializeAsString());
      if (states.empty() || states.back().second != static_cast<int>(p.state()))
        states.emplace_back(p.header().tick(), static_cast<int>(p.state()));
    }
  });
  std::printf("partition of legs-a for %.0f ms (%s, load %s): %lld packets dropped by the cut\n", partition_ms,
              o.secure ? "secured" : "plain", load.c_str(), dropped);
  // Detection: the plant's first stale-command fault of a leg on the cut host, and the tick
  // its last command answered (from the plant's log: the recording on another host also got
  // retransmissions after the heal, so it cannot say what reached the plant when).
  const std::string plant_log = Slurp(s->units().LogOf("hexa-plant"));
  std::smatch m;
  // Either the command ages past the tolerance ("stale", answers tick N) or, first since the
  // 10 ms valve lease, its writer lapses ("liveliness lost", last answer: tick N).
  if (std::regex_search(plant_log, m, std::regex("leg ([123]) tick ([0-9]+): (?:valve command stale \\([^,]*, answers|liveliness lost: [^(]*\\(last answer:) tick ([0-9]+)\\)"))) {
    const long long at = std::stoll(m[2]), answered = std::stoll(m[3]);
    std::printf("  plant: leg %s stale or lapsed at tick %lld, its newest command answered tick %lld: detected %lld ticks "
                "(ms) after the last command that arrived (tolerance --stale-ticks %d: a command older than "
                "that is stale)\n",
                m[1].str().c_str(), at, answered, at - answered, o.stale_ticks > 0 ? o.stale_ticks : 15);
  } else {
    std::printf("  no stale-command or liveliness fault of legs 1-3 in the plant's log\n");
  }
  if (std::regex_search(plant_log, m, std::regex("leg ([123]) tick ([0-9]+): valve command valid again")))
    std::printf("  plant: leg %s valid again at tick %s\n", m[1].str().c_str(), m[2].str().c_str());
  static const char* kNames[] = {"IDLE", "BLENDING", "TRACKING", "STOPPING", "HOLD"};
  std::printf("  supervisor states (tick: state; a HOLD after the last IDLE comes from stopping the processes):");
  for (const auto& [t, st] : states) std::printf(" %llu:%s", static_cast<unsigned long long>(t), kNames[st]);
  std::printf("\n  faults recorded: %zu (first few:", faults.size());
  for (std::size_t i = 0; i < std::min<std::size_t>(faults.size(), 6); ++i)
    std::printf(" [%s leg %u tick %llu %s]", faults[i].source.c_str(), faults[i].leg,
                static_cast<unsigned long long>(faults[i].tick), faults[i].reason.c_str());
  std::printf(")\n  logs: %s\n", s->work_dir().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_multihost_bench",
                        "Networked deployment figures: four or five hosts in network namespaces (root).");
  cli.AddOption("scenarios", "list", "comma list: lockstep lockstep-plain realtime realtime-plain loss recorder-loss partition",
                "lockstep,lockstep-plain,realtime,loss,recorder-loss,partition");
  cli.AddOption("runs", "N", "runs of each session scenario", "1");
  cli.AddOption("loss", "list", "loss percentages of the loss scenarios", "1,5");
  cli.AddOption("partition-ms", "ms", "length of the partition", "300");
  cli.AddOption("build", "dir", "build directory", HEXA_BUILD_DIR);
  cli.AddOption("stale-ticks", "N", "real time: the plant's stale-command tolerance (0 = default 15)", "0");
  cli.AddChoice("metadata-protection", {"default", "ENCRYPT", "SIGN", "NONE"},
                "secured scenarios: the governance's metadata protection (data stay ENCRYPTED)",
                "default");
  cli.AddChoice("loop-metadata-protection", {"default", "ENCRYPT", "SIGN", "NONE"},
                "secured scenarios: the metadata protection of the 1 kHz loop topics (LegSensors, "
                "ValveCommand, GroundTruth; default: the deployment's default, as the metadata: ENCRYPT)",
                "default");
  cli.AddOption("plant-delay-s", "s",
                "start the plant this long after every other process (their discovery and "
                "security handshakes with each other done before the clock starts)", "0");
  cli.AddFlag("no-cpu-placement",
              "leave every process unpinned (default: the one-machine session's CPU placement)");
  cli.AddFlag("split-legs-b",
              "with the CPU placement: the primary legs of host legs-b on the first CPU (with the "
              "supervisor and the recorder) instead of beside the plant on the last");
  cli.AddFlag("faults-plain", "run the loss / recorder-loss / partition scenarios without DDS Security");
  cli.AddFlag("capture-drops",
              "loss / recorder-loss: capture every packet the loss rule drops (nftables log to an "
              "nflog group, tcpdump in the lossy host's namespace) to <logs>/dropped.pcap, for "
              "bench/deployment/dropped_datagrams.py");
  cli.AddOption("deployment", "name|file",
                "the hosts and processes: five-hosts (default: the built-in five-host layout, the same "
                "as deploy/deployments/five-hosts.textproto), four-hosts "
                "(deploy/deployments/four-hosts.textproto: no standbys) or a deployment file",
                "five-hosts");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto runs = cli.GetInt("runs", 1, 100);
  const auto partition_ms = cli.GetDouble("partition-ms", 1, 100000);
  const auto stale = cli.GetInt("stale-ticks", 0, 1000);
  if (!runs || !partition_ms || !stale) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  if (geteuid() != 0) {
    std::fprintf(stderr, "error: needs root (network namespaces, nftables)\n");
    return 1;
  }
  const std::string build = cli.Get("build");
  const std::string scenarios = "," + cli.Get("scenarios") + ",";
  auto want = [&](const char* s) { return scenarios.find(std::string(",") + s + ",") != std::string::npos; };
  std::vector<int> losses;
  {
    std::stringstream ss(cli.Get("loss"));
    for (std::string x; std::getline(ss, x, ',');) losses.push_back(std::stoi(x));
  }
  const int domain = 60 + getpid() % 40;
  LabSessionOptions base = BaseOptions(build, HEXA_SOURCE_DIR, "b", domain);
  base.stale_ticks = static_cast<int>(*stale);
  if (cli.Get("metadata-protection") != "default") base.metadata_protection = cli.Get("metadata-protection");
  if (cli.Get("loop-metadata-protection") != "default")
    base.loop_metadata_protection = cli.Get("loop-metadata-protection");
  base.cpu_placement = !cli.Flag("no-cpu-placement");
  base.split_legs_b = cli.Flag("split-legs-b");
  const auto plant_delay = cli.GetDouble("plant-delay-s", 0, 300);
  if (!plant_delay) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  base.plant_start_delay_s = *plant_delay;
  const std::string deployment = cli.Get("deployment");
  if (deployment != "five-hosts") {
    base.layout_file = deployment.find('/') == std::string::npos && deployment.find('.') == std::string::npos
                           ? std::string(HEXA_SOURCE_DIR) + "/deploy/deployments/" + deployment + ".textproto"
                           : deployment;
  }
  const std::vector<std::string> auto_args{"--trajectory", "z", "--periods", "1", "--autostart", "--exit-when-done"};

  std::printf("deployment %s in network namespaces, z trajectory (1 period, 13 s simulated), DDS Security on "
              "unless '-plain' (metadata protection %s, loop topics %s); real-time stale tolerance %d ticks; CPU placement %s; "
              "plant started %.1f s after the others; "
              "machine shared (load average per row)\n\n",
              base.layout_file.empty() ? "five-hosts (built-in layout)" : base.layout_file.c_str(),
              cli.Get("metadata-protection").c_str(), cli.Get("loop-metadata-protection").c_str(), base.stale_ticks > 0 ? base.stale_ticks : 15,
              !base.cpu_placement ? "none"
              : base.split_legs_b ? "as the one-machine session but legs-b's legs on the first CPU"
                                  : "as the one-machine session",
              base.plant_start_delay_s);
  std::printf("| scenario | done | wall s | sim/wall | CPU s per sim s: all, loop | RMSE x y z mm | rtt med us | rtt p99 us | missing | faults | dropped pkts | load | notes\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (long long k = 0; k < *runs; ++k) {
    if (want("lockstep")) {
      auto o = base;
      o.supervisor_args = auto_args;
      Print(RunSession("lockstep secured", o));
    }
    if (want("lockstep-plain")) {
      auto o = base;
      o.secure = false;
      o.supervisor_args = auto_args;
      Print(RunSession("lockstep plain", o));
    }
    if (want("realtime")) {
      auto o = base;
      o.realtime = true;
      o.supervisor_args = auto_args;
      o.watchdog_s = 0;
      Print(RunSession("realtime secured", o));
    }
    if (want("realtime-plain")) {
      auto o = base;
      o.realtime = true;
      o.secure = false;
      o.supervisor_args = auto_args;
      o.watchdog_s = 0;
      Print(RunSession("realtime plain", o));
    }
    for (int p : losses) {
      for (const char* host : {"legs-a", "recorder"}) {
        const bool rec_link = std::string(host) == "recorder";
        if (!want(rec_link ? "recorder-loss" : "loss")) continue;
        auto o = base;
        o.realtime = true;
        o.secure = !cli.Flag("faults-plain");
        o.supervisor_args = auto_args;
        bool applied = false, failed = false;
        long long dropped = -1, input = -1;
        const bool capture = cli.Flag("capture-drops");
        Row row = RunSession(std::string(o.secure ? "rt secured " : "rt plain ") + std::to_string(p) + "% loss " + host, o,
                             [&](LabSession& s, double since_ready) {
                               std::string err;
                               if (!applied && !failed && since_ready >= 0) {
                                 // The capture listens before the rule logs to its group: a
                                 // packet logged to a group nobody reads is not kept.
                                 if (capture && !StartDropCapture(s, host, err)) {
                                   failed = true;
                                   std::fprintf(stderr, "%s\n", err.c_str());
                                   return;
                                 }
                                 applied = s.lab().SetInputLoss(host, p, err, "", capture ? kDropLogGroup : 0);
                                 failed = !applied;
                                 if (failed) std::fprintf(stderr, "%s\n", err.c_str());
                               }
                               if (applied) {
                                 dropped = std::max(dropped, s.lab().DroppedInput(host));
                                 input = std::max(input, s.lab().InputPackets(host));
                               }
                             });
        row.dropped = dropped;
        row.input_packets = input;
        Print(row);
      }
    }
  }
  if (want("partition")) {
    LabSessionOptions o = base;
    o.secure = !cli.Flag("faults-plain");
    Partition(o, *partition_ms, build + "/services/task_space/hexa_operator");
  }
  return 0;
}
