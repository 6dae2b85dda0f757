// hexa_multihost_bench's parts (multihost_bench.cpp: options and scenarios): one session of
// the five-host lab run to its end and reported as a row (multihost_session.cpp), and the
// operator-driven partition scenario (multihost_partition.cpp).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "lab_session.hpp"

namespace hexa::deploy::multihost {

using namespace std::chrono_literals;

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

// "0.52 0.61 0.70": the load average over 1, 5 and 15 minutes.
std::string LoadAverage();
// The whole file, "" when unreadable.
std::string Slurp(const std::string& path);

// The lab's session options: binaries of `build`, scripts and rig file of `source`, logs in
// /tmp/hx15b-<name>-<pid>.
LabSessionOptions BaseOptions(const std::string& build, const std::string& source, const std::string& name,
                              int domain);

// Runs until the supervisor exits; `during` is called every 0.5 s with the seconds since the
// plant reported READY (negative before), and once more (1e9) once every process stopped.
Row RunSession(const std::string& scenario, LabSessionOptions o,
               const std::function<void(LabSession&, double)>& during = {},
               std::chrono::seconds timeout = 600s);

// tcpdump on the loss rule's nflog group in `host`'s namespace (--capture-drops).
bool StartDropCapture(LabSession& s, const std::string& host, std::string& error);

// The row in the table, its detail lines and one machine-readable line "RUN {json}".
void Print(const Row& r);

// The partition scenario: operator-driven, no --exit-when-done.
void Partition(const LabSessionOptions& base, double partition_ms, const std::string& operator_bin);

}  // namespace hexa::deploy::multihost
