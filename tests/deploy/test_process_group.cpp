// The process supervision used by the launcher and the integration tests: children are
// reaped, stopped in order, and never outlive their parent.
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "process_group.hpp"

using hexa::deploy::ChildSpec;
using hexa::deploy::ProcessGroup;
using namespace std::chrono_literals;

namespace {

bool Alive(pid_t pid) { return kill(pid, 0) == 0; }

// Waits (bounded) until `pid` no longer exists as a live process (zombies of other
// parents count as gone once reaped by init).
bool GoneWithin(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (!Alive(pid)) return true;
    std::this_thread::sleep_for(10ms);
  }
  return !Alive(pid);
}

ChildSpec Sleeper(const std::string& name) {
  return ChildSpec{name, {"/bin/sleep", "30"}, {}, ""};
}

}  // namespace

TEST(ProcessGroup, ReportsExitCodeAndSignal) {
  ProcessGroup group;
  std::string err;
  ASSERT_GT(group.Start(ChildSpec{"ok", {"/bin/sh", "-c", "exit 3"}, {}, ""}, err), 0) << err;
  auto ev = group.WaitEvent(5000ms);
  ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited);
  EXPECT_EQ(ev.exit.name, "ok");
  EXPECT_EQ(ev.exit.exit_code, 3);
  EXPECT_EQ(ev.exit.signal, 0);
}

TEST(ProcessGroup, PassesEnvironmentAndRedirectsOutput) {
  ProcessGroup group;
  const std::string log = ::testing::TempDir() + "/pg_env.log";
  std::string err;
  ASSERT_GT(group.Start(ChildSpec{"env", {"/bin/sh", "-c", "echo value=$HEXA_TEST_VAR"},
                                  {{"HEXA_TEST_VAR", "42"}}, log}, err), 0) << err;
  auto ev = group.WaitEvent(5000ms);
  ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited);
  FILE* f = std::fopen(log.c_str(), "r");
  ASSERT_NE(f, nullptr);
  char buf[64] = {};
  ASSERT_NE(std::fgets(buf, sizeof buf, f), nullptr);
  std::fclose(f);
  EXPECT_STREQ(buf, "value=42\n");
}

TEST(ProcessGroup, RejectsMissingExecutable) {
  ProcessGroup group;
  std::string err;
  EXPECT_LT(group.Start(ChildSpec{"none", {"/nonexistent/binary"}, {}, ""}, err), 0);
  EXPECT_NE(err.find("/nonexistent/binary"), std::string::npos) << err;
}

TEST(ProcessGroup, StopAllTerminatesEveryChild) {
  ProcessGroup group;
  std::string err;
  const pid_t a = group.Start(Sleeper("a"), err);
  const pid_t b = group.Start(Sleeper("b"), err);
  ASSERT_GT(a, 0);
  ASSERT_GT(b, 0);
  EXPECT_TRUE(group.Running("a"));
  auto exits = group.StopAll(2000ms);
  ASSERT_EQ(exits.size(), 2u);
  EXPECT_EQ(exits[0].name, "b");  // reverse start order
  EXPECT_EQ(exits[0].signal, SIGTERM);
  EXPECT_FALSE(Alive(a));
  EXPECT_FALSE(Alive(b));
  EXPECT_TRUE(group.RunningNames().empty());
}

TEST(ProcessGroup, StopEscalatesToSigkill) {
  ProcessGroup group;
  std::string err;
  const pid_t p = group.Start(
      ChildSpec{"stubborn", {"/bin/sh", "-c", "trap '' TERM; sleep 30 & wait; sleep 30"}, {}, ""},
      err);
  ASSERT_GT(p, 0);
  std::this_thread::sleep_for(200ms);  // let the shell install its trap
  auto e = group.Stop("stubborn", 300ms);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->signal, SIGKILL);
  EXPECT_FALSE(Alive(p));
}

TEST(ProcessGroup, ChildrenDieWhenTheParentIsKilled) {
  // A middle process owns a ProcessGroup with a sleeping child, reports the child's pid
  // through a pipe, and is then SIGKILLed: the grandchild must not survive it.
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t middle = fork();
  ASSERT_GE(middle, 0);
  if (middle == 0) {
    close(fds[0]);
    ProcessGroup group;
    std::string err;
    pid_t child = group.Start(Sleeper("orphan-candidate"), err);
    if (write(fds[1], &child, sizeof child) != sizeof child) _exit(1);
    pause();
    _exit(0);
  }
  close(fds[1]);
  pid_t grandchild = -1;
  ASSERT_EQ(read(fds[0], &grandchild, sizeof grandchild), static_cast<ssize_t>(sizeof grandchild));
  close(fds[0]);
  ASSERT_GT(grandchild, 0);
  EXPECT_TRUE(Alive(grandchild));
  kill(middle, SIGKILL);
  waitpid(middle, nullptr, 0);
  EXPECT_TRUE(GoneWithin(grandchild, 3000ms)) << "grandchild " << grandchild << " survived";
  if (Alive(grandchild)) kill(grandchild, SIGKILL);
}

// CPUAffinity= of a unit (the multi-host lab plays systemd): set in the child before exec.
TEST(ProcessGroup, PinsTheChildToItsCpus) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  int last = -1;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) last = c;
  ASSERT_GE(last, 0);
  ProcessGroup group;
  const std::string log = ::testing::TempDir() + "/pg_cpus.log";
  std::string err;
  ChildSpec spec{"pinned", {"/bin/sh", "-c", "grep Cpus_allowed_list /proc/self/status"}, {}, log};
  spec.cpus = {last};
  ASSERT_GT(group.Start(spec, err), 0) << err;
  auto ev = group.WaitEvent(5000ms);
  ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited);
  EXPECT_EQ(ev.exit.exit_code, 0);
  std::ifstream in(log);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.substr(line.find_first_not_of(" \t", line.find(':') + 1)), std::to_string(last)) << line;

  // A CPU the machine does not have: the child fails before exec (as systemd fails the unit).
  spec.name = "nowhere";
  spec.cpus = {CPU_SETSIZE - 1};
  spec.log_path = ::testing::TempDir() + "/pg_cpus_bad.log";
  ASSERT_GT(group.Start(spec, err), 0) << err;
  ev = group.WaitEvent(5000ms);
  ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited);
  EXPECT_EQ(ev.exit.exit_code, 126);
}
