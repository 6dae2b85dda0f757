// sched::LeaveRealtime: a service leaving its loop returns every thread (its own and Cyclone's,
// which inherited SCHED_FIFO) to normal scheduling, so that its teardown does not starve the
// control processes still running on the same CPU (docs/faults.md).
// sched::CpuLatencyHold and node::ApplyScheduling: the CPU wake-up latency limit a service holds
// while its loop runs, and Cyclone's timed-event thread at normal scheduling in real time
// (docs/performance.md).
#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <spdlog/sinks/null_sink.h>

#include "hexa/comm/config.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/scheduling.hpp"

namespace {

// The kernel's view (glibc's pthread_getschedparam may answer from its own cache).
int PolicyOf(pid_t tid) { return sched_getscheduler(tid); }

TEST(Scheduling, LeaveRealtimeReturnsEveryThreadOfTheProcessToNormalScheduling) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root for SCHED_FIFO";
  std::string message;
  if (!hexa::sched::SetRealtime(5, message)) GTEST_SKIP() << message;
  ASSERT_EQ(PolicyOf(gettid()), SCHED_FIFO);
  // A thread created now inherits SCHED_FIFO, as Cyclone's threads do.
  std::mutex m;
  std::condition_variable cv;
  bool release = false;
  pid_t worker_tid = 0;
  std::thread worker([&] {
    std::unique_lock<std::mutex> lock(m);
    worker_tid = gettid();
    cv.notify_all();
    cv.wait(lock, [&] { return release; });
  });
  {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return worker_tid != 0; });
  }
  EXPECT_EQ(PolicyOf(worker_tid), SCHED_FIFO);

  EXPECT_TRUE(hexa::sched::LeaveRealtime(message)) << message;
  EXPECT_NE(message.find("2 threads back to normal"), std::string::npos) << message;
  EXPECT_EQ(PolicyOf(gettid()), SCHED_OTHER);
  EXPECT_EQ(PolicyOf(worker_tid), SCHED_OTHER);

  // Nothing left to change: a second call changes no thread.
  EXPECT_TRUE(hexa::sched::LeaveRealtime(message)) << message;
  EXPECT_NE(message.find("0 threads back to normal"), std::string::npos) << message;
  {
    std::lock_guard<std::mutex> lock(m);
    release = true;
  }
  cv.notify_all();
  worker.join();
}

// Does this process have `path` open (a link in /proc/self/fd)?
bool ProcessHasOpen(const std::string& path) {
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    if (std::filesystem::read_symlink(e.path(), ec) == path) return true;
  }
  return false;
}

TEST(Scheduling, CpuLatencyHoldWritesTheRequestAndKeepsTheDeviceOpenUntilReleased) {
  const std::string device = ::testing::TempDir() + "cpu_latency_device_" + std::to_string(getpid());
  { std::ofstream(device).put('\0'); }  // exists, like the device
  std::string message;
  hexa::sched::CpuLatencyHold hold(7, message, device);
  ASSERT_TRUE(hold.held()) << message;
  EXPECT_NE(message.find("held at 7 us"), std::string::npos) << message;
  std::int32_t value = -1;
  std::ifstream(device, std::ios::binary).read(reinterpret_cast<char*>(&value), sizeof value);
  EXPECT_EQ(value, 7);  // the kernel's ABI: a binary int32, in microseconds
  // The request lasts while the file is open: the kernel drops it on close.
  EXPECT_TRUE(ProcessHasOpen(std::filesystem::canonical(device)));
  hexa::sched::CpuLatencyHold moved = std::move(hold);
  EXPECT_FALSE(hold.held());
  EXPECT_TRUE(moved.held());
  moved.Release();
  EXPECT_FALSE(moved.held());
  EXPECT_FALSE(ProcessHasOpen(std::filesystem::canonical(device)));
  std::filesystem::remove(device);
}

TEST(Scheduling, CpuLatencyHoldOnAMissingDeviceHoldsNothingAndSaysWhy) {
  std::string message;
  hexa::sched::CpuLatencyHold hold(0, message, "/nonexistent/cpu_dma_latency");
  EXPECT_FALSE(hold.held());
  EXPECT_NE(message.find("/nonexistent/cpu_dma_latency"), std::string::npos) << message;
  EXPECT_NE(message.find("not limited"), std::string::npos) << message;
}

// The kernel's current limit (the smallest request held by anyone), in microseconds.
std::int32_t KernelCpuLatencyLimit_us() {
  const int fd = open("/dev/cpu_dma_latency", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  std::int32_t value = -1;
  if (read(fd, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) value = -1;
  close(fd);
  return value;
}

std::map<std::string, int> ThreadPolicies() {  // thread name -> policy (last one of a name)
  std::map<std::string, int> out;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream comm(e.path() / "comm");
    std::string name;
    std::getline(comm, name);
    out[name] = sched_getscheduler(static_cast<pid_t>(std::stol(e.path().filename())));
  }
  return out;
}

// What a real-time service gets from ApplyScheduling, with a participant created after it.
void CheckRealtimeSetup(bool event_thread_normal) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root for SCHED_FIFO and /dev/cpu_dma_latency";
  if (KernelCpuLatencyLimit_us() < 0) GTEST_SKIP() << "no readable /dev/cpu_dma_latency";
  const char* uri_before = std::getenv("CYCLONEDDS_URI");
  const std::string saved = uri_before != nullptr ? uri_before : "";
  hexa::comm::EnsureDdsConfig();
  hexa::node::CommonOptions o;
  o.mode = hexa::node::TimeMode::kRealtime;
  o.realtime_priority = 5;
  o.cpu_latency_us = 7;  // not 0: another process may hold 0, the limit is the smallest request
  o.realtime_dds_event_thread_normal = event_thread_normal;
  spdlog::logger log("test", std::make_shared<spdlog::sinks::null_sink_mt>());
  hexa::sched::CpuLatencyHold hold = hexa::node::ApplyScheduling(o, 5, log);
  if (sched_getscheduler(0) != SCHED_FIFO) GTEST_SKIP() << "SCHED_FIFO refused here";
  ASSERT_TRUE(hold.held());
  EXPECT_LE(KernelCpuLatencyLimit_us(), 7);
  {
    hexa::comm::Participant participant(static_cast<dds_domainid_t>(100 + getpid() % 20));
    // Cyclone's threads name themselves once they run: wait for the names (not for a time).
    auto policies = ThreadPolicies();
    for (int i = 0; i < 500 && (policies.count("tev") == 0 || policies.count("recvUC") == 0 ||
                                policies.count("gc") == 0); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      policies = ThreadPolicies();
    }
    ASSERT_EQ(policies.count("tev"), 1u) << "Cyclone's timed-event thread is not named tev";
    ASSERT_EQ(policies.count("recvUC"), 1u);
    ASSERT_EQ(policies.count("gc"), 1u);
    EXPECT_EQ(policies.at("tev"), event_thread_normal ? SCHED_OTHER : SCHED_FIFO);
    EXPECT_EQ(policies.at("recvUC"), SCHED_FIFO);  // the data path keeps the loop's priority
    EXPECT_EQ(policies.at("gc"), SCHED_FIFO);      // so does lease expiry (liveliness)
    hexa::node::LeaveRealtimeScheduling(o, hold, log);
    EXPECT_FALSE(hold.held());
    for (const auto& [name, policy] : ThreadPolicies()) EXPECT_EQ(policy, SCHED_OTHER) << name;
  }
  setenv("CYCLONEDDS_URI", saved.c_str(), 1);
}

TEST(Scheduling, RealtimeServiceRunsCyclonesTimedEventThreadAtNormalSchedulingAndHoldsTheCpuLatency) {
  CheckRealtimeSetup(true);
}

TEST(Scheduling, RealtimeServiceKeepsTheTimedEventThreadAtFifoWhenAsked) {
  CheckRealtimeSetup(false);
}

}  // namespace
