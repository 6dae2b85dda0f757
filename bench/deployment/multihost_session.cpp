// One session of hexa_multihost_bench (multihost_session.hpp): run to its end, its CPU per
// role and thread, what its recording and logs say, printed as a row.
#include "multihost_session.hpp"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "hexa/services/json.hpp"
#include "recording.pb.h"

namespace hexa::deploy::multihost {

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

namespace {

std::int64_t WallNow_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
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

}  // namespace

// Runs until the supervisor exits; `during` is called every 0.5 s with the seconds since the
// plant reported READY (negative before).
Row RunSession(const std::string& scenario, LabSessionOptions o,
               const std::function<void(LabSession&, double)>& during, std::chrono::seconds timeout) {
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

}  // namespace hexa::deploy::multihost
