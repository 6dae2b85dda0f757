// hexa_cpu_stall_probe: tells a stall of the machine from a fault of ours.
//
// One thread per CPU, pinned, SCHED_FIFO 99 (above every service of the system), wakes every
// period on an absolute CLOCK_MONOTONIC schedule and records every wake-up that came more than
// the threshold late, with its wall-clock time (CLOCK_REALTIME, the clock of DDS source
// timestamps, so a stall can be laid beside a recording). A second, normal-priority thread
// samples each CPU's steal time from /proc/stat every 10 ms: a stall during which the steal
// counter advanced is the hypervisor's (the vCPU was not running); one without steal was
// taken inside the guest (an interrupt storm, the kernel's fair server or RT throttling,
// both of which preempt SCHED_FIFO 99).
//
// Cost: one short wake-up per CPU per period (1 ms by default). Writes one JSON file when it
// ends (SIGTERM, SIGINT or --duration-s). Used by bench/faults/fault_matrix.py --stall-probe.
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hexa/services/json.hpp"

namespace {

std::atomic<bool> g_stop{false};

void OnSignal(int) { g_stop.store(true); }

int64_t NowNs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

struct StallEvent {
  int cpu = 0;
  int64_t due_realtime_ns = 0;  // when the wake-up was due (wall clock)
  int64_t late_us = 0;
};

struct StealSample {
  int64_t realtime_ns = 0;
  std::vector<long long> steal_jiffies;  // per CPU index of the probe's CPU list
};

struct Options {
  std::vector<int> cpus;
  int64_t period_us = 1000;
  int64_t threshold_us = 2000;
  int priority = 99;
  double duration_s = 0.0;  // 0: until SIGTERM / SIGINT
  std::string out = "cpu_stall_probe.json";
};

void Usage(FILE* f) {
  std::fprintf(f,
               "usage: hexa_cpu_stall_probe [--cpus 0,1] [--period-us 1000] [--threshold-us 2000]\n"
               "                            [--priority 99] [--duration-s S] [--out FILE.json]\n"
               "Records every wake-up of a SCHED_FIFO thread per CPU that came more than the\n"
               "threshold late (a stall of that CPU), with wall-clock time and the steal time the\n"
               "hypervisor reported around it. Ends on SIGTERM/SIGINT or after --duration-s and\n"
               "writes FILE.json. Needs root for SCHED_FIFO (says so and exits 1 otherwise).\n");
}

bool ParseLong(const char* s, long long lo, long long hi, long long& v) {
  char* end = nullptr;
  errno = 0;
  v = std::strtoll(s, &end, 10);
  return errno == 0 && end != s && *end == '\0' && v >= lo && v <= hi;
}

bool ParseArgs(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      Usage(stdout);
      std::exit(0);
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "hexa_cpu_stall_probe: %s needs a value (or is unknown)\n", a.c_str());
      return false;
    }
    const char* v = argv[++i];
    long long n = 0;
    if (a == "--cpus") {
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) {
        if (!ParseLong(item.c_str(), 0, CPU_SETSIZE - 1, n)) {
          std::fprintf(stderr, "hexa_cpu_stall_probe: --cpus: '%s' is not a CPU number\n", item.c_str());
          return false;
        }
        o.cpus.push_back(static_cast<int>(n));
      }
    } else if (a == "--period-us" && ParseLong(v, 100, 100000, n)) {
      o.period_us = n;
    } else if (a == "--threshold-us" && ParseLong(v, 100, 10000000, n)) {
      o.threshold_us = n;
    } else if (a == "--priority" && ParseLong(v, 1, 99, n)) {
      o.priority = static_cast<int>(n);
    } else if (a == "--duration-s") {
      char* end = nullptr;
      o.duration_s = std::strtod(v, &end);
      if (end == v || *end != '\0' || !(o.duration_s >= 0.0 && o.duration_s <= 86400.0)) {
        std::fprintf(stderr, "hexa_cpu_stall_probe: --duration-s expects 0..86400, got '%s'\n", v);
        return false;
      }
    } else if (a == "--out") {
      o.out = v;
    } else {
      std::fprintf(stderr,
                   "hexa_cpu_stall_probe: bad option or value: %s %s (limits: --period-us "
                   "100..100000, --threshold-us 100..10000000, --priority 1..99)\n",
                   a.c_str(), v);
      return false;
    }
  }
  if (o.cpus.empty()) {
    const long n = sysconf(_SC_NPROCESSORS_ONLN);
    for (int c = 0; c < n; ++c) o.cpus.push_back(c);
  }
  return true;
}

// Steal jiffies of the listed CPUs from /proc/stat ("cpuN user nice system idle iowait irq
// softirq steal ..."); false when the file cannot be read.
bool ReadSteal(const std::vector<int>& cpus, std::vector<long long>& steal) {
  std::ifstream f("/proc/stat");
  if (!f) return false;
  steal.assign(cpus.size(), -1);
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("cpu", 0) != 0 || line.size() < 4 || line[3] == ' ') continue;
    std::istringstream ss(line);
    std::string name;
    long long fields[8] = {};
    ss >> name;
    for (auto& x : fields) ss >> x;
    const int cpu = std::atoi(name.c_str() + 3);
    for (size_t k = 0; k < cpus.size(); ++k)
      if (cpus[k] == cpu) steal[k] = fields[7];
  }
  return true;
}

void ProbeCpu(int cpu, const Options& o, std::vector<StallEvent>& events, int64_t& wakeups) {
  events.reserve(100000);  // allocated before the loop: the loop itself does not allocate
  const int64_t period_ns = o.period_us * 1000;
  int64_t due = NowNs(CLOCK_MONOTONIC) + period_ns;
  while (!g_stop.load(std::memory_order_relaxed)) {
    timespec ts{static_cast<time_t>(due / 1000000000LL), static_cast<long>(due % 1000000000LL)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    const int64_t now = NowNs(CLOCK_MONOTONIC);
    const int64_t late_us = (now - due) / 1000;
    ++wakeups;
    if (late_us > o.threshold_us && events.size() < events.capacity()) {
      const int64_t real_now = NowNs(CLOCK_REALTIME);
      events.push_back({cpu, real_now - (now - due), late_us});
    }
    due += period_ns;
    if (due < now) due = now + period_ns;  // after a stall: restart the schedule, no burst
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!ParseArgs(argc, argv, o)) {
    Usage(stderr);
    return 2;
  }
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGINT, OnSignal);
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    std::fprintf(stderr, "hexa_cpu_stall_probe: mlockall failed (%s); continuing\n", std::strerror(errno));

  const size_t n = o.cpus.size();
  std::vector<std::vector<StallEvent>> events(n);
  std::vector<int64_t> wakeups(n, 0);
  std::vector<std::thread> threads;
  std::vector<std::string> errors(n);
  for (size_t k = 0; k < n; ++k) {
    threads.emplace_back([&, k] {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(o.cpus[k], &set);
      if (pthread_setaffinity_np(pthread_self(), sizeof(set), &set) != 0) {
        errors[k] = "cannot pin to CPU " + std::to_string(o.cpus[k]);
        g_stop.store(true);
        return;
      }
      sched_param sp{};
      sp.sched_priority = o.priority;
      if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) != 0) {
        errors[k] = "SCHED_FIFO " + std::to_string(o.priority) + " refused (run as root)";
        g_stop.store(true);
        return;
      }
      ProbeCpu(o.cpus[k], o, events[k], wakeups[k]);
    });
  }
  // Steal sampler: normal priority, every 10 ms, preallocated for 2 hours.
  std::vector<StealSample> steal;
  steal.reserve(720000);
  const int64_t start_ns = NowNs(CLOCK_REALTIME);
  const int64_t end_mono = o.duration_s > 0 ? NowNs(CLOCK_MONOTONIC) + static_cast<int64_t>(o.duration_s * 1e9) : 0;
  bool steal_ok = true;
  while (!g_stop.load()) {
    StealSample s;
    s.realtime_ns = NowNs(CLOCK_REALTIME);
    if (steal_ok && !ReadSteal(o.cpus, s.steal_jiffies)) steal_ok = false;
    if (steal_ok && steal.size() < steal.capacity()) steal.push_back(std::move(s));
    if (end_mono && NowNs(CLOCK_MONOTONIC) >= end_mono) g_stop.store(true);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (auto& t : threads) t.join();
  for (size_t k = 0; k < n; ++k)
    if (!errors[k].empty()) {
      std::fprintf(stderr, "hexa_cpu_stall_probe: %s\n", errors[k].c_str());
      return 1;
    }

  // Steal jiffies each CPU accrued from 20 ms before a stall to 20 ms after its end.
  auto steal_around = [&](size_t k, const StallEvent& e) -> long long {
    const int64_t from = e.due_realtime_ns - 20000000LL;
    const int64_t to = e.due_realtime_ns + e.late_us * 1000 + 20000000LL;
    long long first = -1, last = -1;
    for (const auto& s : steal) {
      if (s.realtime_ns <= from) first = s.steal_jiffies[k];
      if (s.realtime_ns >= to) {
        last = s.steal_jiffies[k];
        break;
      }
    }
    return (first < 0 || last < 0) ? -1 : last - first;
  };
  hexa::json::Value out = {{"start_realtime_ns", static_cast<long long>(start_ns)},
                           {"end_realtime_ns", static_cast<long long>(NowNs(CLOCK_REALTIME))},
                           {"period_us", static_cast<long long>(o.period_us)},
                           {"threshold_us", static_cast<long long>(o.threshold_us)},
                           {"priority", o.priority},
                           {"steal_sampled", steal_ok},
                           {"per_cpu", hexa::json::Value::array()},
                           {"events", hexa::json::Value::array()}};
  for (size_t k = 0; k < n; ++k) {
    int64_t max_us = 0, over5 = 0, over10 = 0;
    for (const auto& e : events[k]) {
      max_us = std::max(max_us, e.late_us);
      over5 += e.late_us > 5000;
      over10 += e.late_us > 10000;
    }
    out["per_cpu"].push_back({{"cpu", o.cpus[k]},
                              {"wakeups", static_cast<long long>(wakeups[k])},
                              {"stalls", events[k].size()},
                              {"max_late_us", static_cast<long long>(max_us)},
                              {"over_5ms", static_cast<long long>(over5)},
                              {"over_10ms", static_cast<long long>(over10)}});
  }
  for (size_t k = 0; k < n; ++k)
    for (const auto& e : events[k])
      out["events"].push_back({{"cpu", e.cpu},
                               {"due_realtime_ns", static_cast<long long>(e.due_realtime_ns)},
                               {"late_us", static_cast<long long>(e.late_us)},
                               {"steal_jiffies", steal_around(k, e)}});
  std::string error;
  if (!hexa::json::WriteFile(o.out, out, 1, error)) {
    std::fprintf(stderr, "hexa_cpu_stall_probe: %s\n", error.c_str());
    return 1;
  }
  return 0;
}
