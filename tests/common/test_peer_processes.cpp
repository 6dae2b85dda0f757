// A session's processes by their ids (peer_processes.hpp): running, stopped by a signal, ended
// (a zombie, a reaped process, or an id that was never started) - what the plant and the legs
// judge lockstep deaths by (docs/faults.md).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "hexa/services/peer_processes.hpp"

namespace hexa::node {
namespace {

// The state after the kernel has applied a signal (it is asynchronous): polled up to 2 s.
PeerProcessState WaitFor(const PeerProcesses& p, PeerProcessState want) {
  for (int k = 0; k < 200 && p.State("child") != want; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return p.State("child");
}

TEST(PeerProcesses, RunningStoppedAndEndedAreToldApart) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    for (;;) pause();
  }
  PeerProcesses p;
  std::string error;
  ASSERT_TRUE(p.Add("child=" + std::to_string(child), error)) << error;
  EXPECT_TRUE(p.Known("child"));
  EXPECT_EQ(p.State("child"), PeerProcessState::kRunning);
  kill(child, SIGSTOP);
  EXPECT_EQ(WaitFor(p, PeerProcessState::kStopped), PeerProcessState::kStopped);
  kill(child, SIGCONT);
  EXPECT_EQ(WaitFor(p, PeerProcessState::kRunning), PeerProcessState::kRunning);
  kill(child, SIGKILL);
  // Not reaped yet: a zombie has ended.
  EXPECT_EQ(WaitFor(p, PeerProcessState::kEnded), PeerProcessState::kEnded);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_EQ(p.State("child"), PeerProcessState::kEnded);  // reaped: gone
  EXPECT_NE(p.Describe("child").find("ended"), std::string::npos) << p.Describe("child");
  // A name without a process id is unknown, not dead.
  EXPECT_EQ(p.State("other"), PeerProcessState::kUnknown);
  EXPECT_FALSE(p.Known("other"));
}

TEST(PeerProcesses, AnIdThatNoLongerExistsHasEndedAndBadSpecsAreRefused) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  PeerProcesses p;
  std::string error;
  ASSERT_TRUE(p.Add("gone=" + std::to_string(child), error)) << error;
  EXPECT_EQ(p.State("gone"), PeerProcessState::kEnded);
  for (const char* bad : {"leg3", "=12", "leg3=", "leg3=12x", "leg3=-4", "leg3=0"}) {
    error.clear();
    EXPECT_FALSE(p.Add(bad, error)) << bad;
    EXPECT_NE(error.find("NAME=PID"), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace hexa::node
