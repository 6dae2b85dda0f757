// Process scheduling for the services and the recorder: CPU affinity and SCHED_FIFO. Applied
// before the DDS participant exists, so that Cyclone's threads inherit them. Each call says
// what it did in `message` (for the log) and never throws: a host that refuses (not root, a
// CPU that is not there) leaves the process running with normal scheduling.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hexa::sched {

// "1", "0,1", "0-1" -> CPU numbers; false on a malformed list.
bool ParseCpuList(const std::string& text, std::vector<int>& cpus);

// The CPUs this process may run on (sched_getaffinity), ascending; empty on error.
std::vector<int> AllowedCpus();

// How a session splits the CPUs this process may use when nothing says otherwise
// (hexa_session --cpus-control auto): the control loop on the last one, everything else
// (recorder, supervisor, standbys, bridge) on the others; with one CPU, no split (both empty).
struct CpuSplit {
  std::vector<int> control;
  std::vector<int> others;
};
CpuSplit AutoCpuSplit();

// "0,1" text of a CPU list.
std::string FormatCpuList(const std::vector<int>& cpus);

// Pins every thread of the process (and those it creates later) to `cpus`.
bool SetCpuAffinity(const std::vector<int>& cpus, std::string& message);

// SCHED_FIFO at `priority` (1..98) and mlockall.
bool SetRealtime(int priority, std::string& message);

// Back to SCHED_OTHER for every thread of the process (/proc/self/task: the policy is per
// thread, and Cyclone's threads inherited SCHED_FIFO) and munlockall. For a service whose
// loop has ended: tearing down its DDS entities and its locked memory at SCHED_FIFO on the
// control CPU starves the processes still running there (a supervisor finishing in real time
// held the six legs off the CPU for ~10 ms; docs/performance.md). Counts the threads changed.
bool LeaveRealtime(std::string& message);

// This thread's kernel id (gettid), cached per thread: no system call after the first.
int CurrentThreadId();

// The scheduler's statistics of thread `tid` of this process (/proc/self/task/TID/schedstat):
// the time it ran and the time it waited for a CPU while runnable, since it started. False
// when the thread is gone or the kernel keeps no such statistics.
bool ReadThreadSchedStat(int tid, std::uint64_t& run_ns, std::uint64_t& wait_ns);

// A limit on how long the kernel may take to wake an idle CPU (PM QoS, /dev/cpu_dma_latency),
// held while the object lives: the request is the int32 written to the device and lasts while
// its file stays open (the kernel drops it when the file is closed, also when the process
// dies). With 0 us an idle CPU polls instead of halting. On this machine's kind of VM a halted
// vCPU costs a VM exit and an interrupt to wake (docs/performance.md): a 1 kHz loop of nine
// processes pays that several times a tick. Costs: the CPUs this host gives the process never
// sleep while the hold lasts (power, and a hypervisor sees them busy).
// The largest limit a service accepts (--cpu-latency-us): 100 ms, far beyond any idle state's
// exit latency; the kernel's own ceiling is 2000 s.
constexpr int kMaxCpuLatencyUs = 100000;

class CpuLatencyHold {
 public:
  CpuLatencyHold() = default;
  // Opens `device` and writes `latency_us` (>= 0). Never throws: on failure the object holds
  // nothing and `message` says why.
  CpuLatencyHold(int latency_us, std::string& message,
                 const std::string& device = "/dev/cpu_dma_latency");
  ~CpuLatencyHold();
  CpuLatencyHold(CpuLatencyHold&& other) noexcept;
  CpuLatencyHold& operator=(CpuLatencyHold&& other) noexcept;
  CpuLatencyHold(const CpuLatencyHold&) = delete;
  CpuLatencyHold& operator=(const CpuLatencyHold&) = delete;

  bool held() const { return fd_ >= 0; }
  // Drops the request now (closes the device).
  void Release();

 private:
  int fd_ = -1;
};

}  // namespace hexa::sched
