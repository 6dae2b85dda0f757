// sched::LeaveRealtime: a service leaving its loop returns every thread (its own and Cyclone's,
// which inherited SCHED_FIFO) to normal scheduling, so that its teardown does not starve the
// control processes still running on the same CPU (docs/faults.md).
#include <sched.h>
#include <unistd.h>

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

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

}  // namespace
