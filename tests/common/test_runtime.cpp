// The service runtime on DDS, in one process (hexa/services/runtime.hpp): the NodeStatus each
// lifecycle step publishes, with the node's figures and detail, the start-up wait's outcomes
// and exit codes, and the transitions it refuses. A reader on a second participant sees what
// a peer (the plant, the launcher, hexa_operator) would see. Domain 38, loopback.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

#include "hexa/comm/comm.hpp"
#include "hexa/comm/config.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/control_cycle.hpp"
#include "hexa/services/runtime.hpp"

namespace hexa::services {
namespace {

constexpr int kDomain = 38;

struct Seen {
  hexa_msg_NodeState state;
  std::string detail;
  std::uint64_t tick;
  std::uint64_t cycles;
  std::uint32_t deadline_missed;
  std::uint32_t liveliness_changes;
  double cycle_max_s;
};

// The newest NodeStatus of one node a peer sees (NodeStatus keeps one sample per node: a peer
// sees the current status, not every step, so the test waits for each step before the next).
// Only `node`'s: the tests of this file may run at once on the domain, each its own node.
class StatusWatcher {
 public:
  explicit StatusWatcher(std::string node)
      : node_(std::move(node)),
        participant_(kDomain),
        topic_(participant_),
        reader_(participant_, topic_, comm::EndpointRole::kControlReader, comm::QosParams{}, 64) {}

  // Waits (up to 10 s) until the newest status has `state` and `detail`; returns it (or the
  // newest seen when it never came).
  Seen WaitFor(hexa_msg_NodeState state, const std::string& detail) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < end) {
      TakeValid(reader_, [this](const hexa_msg_NodeStatus& s, std::size_t) {
        if (node_ != s.node_name) return;
        newest_ = {s.state, s.detail, s.header.tick, s.cycles_total,
                   s.deadline_missed_total, s.liveliness_changes_total, s.cycle_time_max_s};
      });
      if (newest_.state == state && newest_.detail == detail) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return newest_;
  }
  bool Matched() const { return reader_.Snapshot().subscription_matched_current >= 1; }

 private:
  std::string node_;
  comm::Participant participant_;
  comm::Topic<hexa_msg_NodeStatus> topic_;
  comm::Reader<hexa_msg_NodeStatus> reader_;
  Seen newest_{hexa_msg_NODE_FAULT, "", 0, 0, 0, 0, 0.0};
};

class ServiceRuntime : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { comm::EnsureDdsConfig(); }
  static node::CommonOptions Options() {
    node::CommonOptions o;
    o.domain_id = kDomain;
    return o;
  }
  static std::shared_ptr<spdlog::logger> Log() {
    auto log = spdlog::get("runtime_test");
    return log ? log : spdlog::default_logger()->clone("runtime_test");
  }
  // Waits until the watcher's reader has matched the runtime's status writer, so that the
  // volatile samples (transient-local keeps only the newest) all arrive.
  static void WaitMatched(Runtime& runtime, StatusWatcher& watcher) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while ((!watcher.Matched() ||
            runtime.status_writer().Snapshot().publication_matched_current < 1) &&
           std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(watcher.Matched());
  }
};

TEST_F(ServiceRuntime, PublishesEachLifecycleStepWithTheNodesFigures) {
  StatusWatcher watcher("leg4");
  Runtime runtime(Options(), "leg4", Log());
  WaitMatched(runtime, watcher);
  StatusFigures f;
  f.tick = 17;
  f.cycles = 42;
  f.deadline_missed = 3;
  f.liveliness_changes = 2;
  f.cycle_max_s = 0.25e-3;
  EXPECT_EQ(runtime.phase(), Phase::kStarting);
  runtime.Start(f, "waiting for the plant");
  Seen s = watcher.WaitFor(hexa_msg_NODE_STARTING, "waiting for the plant");
  EXPECT_EQ(s.state, hexa_msg_NODE_STARTING);
  EXPECT_EQ(s.detail, "waiting for the plant");
  EXPECT_EQ(s.tick, 17u);
  EXPECT_EQ(s.cycles, 42u);
  EXPECT_EQ(s.deadline_missed, 3u);
  EXPECT_EQ(s.liveliness_changes, 2u);
  EXPECT_DOUBLE_EQ(s.cycle_max_s, 0.25e-3);

  PeerWait wait;
  int looks = 0;
  wait.matched = [&looks](std::string& missing) {
    missing = "the plant";
    return ++looks >= 3;  // matched at the third look
  };
  EXPECT_EQ(runtime.WaitForPeers(wait), PeerWaitResult::kMatched);
  EXPECT_EQ(looks, 3);
  EXPECT_EQ(runtime.phase(), Phase::kPeersMatched);

  runtime.Running(f, "primary", "primary");
  EXPECT_EQ(runtime.phase(), Phase::kRunning);
  s = watcher.WaitFor(hexa_msg_NODE_RUNNING, "primary");
  EXPECT_EQ(s.state, hexa_msg_NODE_RUNNING);
  EXPECT_EQ(s.detail, "primary");

  f.cycles = 43;
  EXPECT_TRUE(runtime.Publish(hexa_msg_NODE_HOLD, f, "command #7 reset: refused: why"));
  s = watcher.WaitFor(hexa_msg_NODE_HOLD, "command #7 reset: refused: why");
  EXPECT_EQ(s.state, hexa_msg_NODE_HOLD);
  EXPECT_EQ(s.detail, "command #7 reset: refused: why");
  EXPECT_EQ(s.cycles, 43u);
  // STARTING is not a running node's state: nothing is published.
  EXPECT_FALSE(runtime.Publish(hexa_msg_NODE_STARTING, f, "not while running"));

  runtime.Stop(f, "stopped");
  EXPECT_EQ(runtime.phase(), Phase::kStopping);
  s = watcher.WaitFor(hexa_msg_NODE_STOPPING, "stopped");
  EXPECT_EQ(s.state, hexa_msg_NODE_STOPPING);
  EXPECT_EQ(s.detail, "stopped");
  EXPECT_THROW(runtime.Stop(f, "stopped"), std::logic_error);
}

TEST_F(ServiceRuntime, PeersNotMatchedInTimeIsAFaultWithItsExitCode) {
  StatusWatcher watcher("supervisor");
  Runtime runtime(Options(), "supervisor", Log());
  WaitMatched(runtime, watcher);
  runtime.Start({}, "waiting for peers");
  PeerWait wait;
  wait.rule.timeout_s = 0.2;
  wait.matched = [](std::string& missing) {
    missing = "imu false";
    return false;
  };
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(runtime.WaitForPeers(wait), PeerWaitResult::kTimedOut);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(200));
  EXPECT_EQ(runtime.FailStart({}, "peers not matched", exit_code::kPeersNotMatched),
            exit_code::kPeersNotMatched);
  EXPECT_EQ(runtime.phase(), Phase::kFailed);
  const Seen s = watcher.WaitFor(hexa_msg_NODE_FAULT, "peers not matched");
  EXPECT_EQ(s.state, hexa_msg_NODE_FAULT);
  EXPECT_EQ(s.detail, "peers not matched");
  // A failed node never runs.
  EXPECT_THROW(runtime.Running({}, "idle", "idle"), std::logic_error);
}

TEST_F(ServiceRuntime, ShutdownWhileWaitingEndsTheWaitAndExitsZero) {
  Runtime runtime(Options(), "leg1", Log());
  runtime.Start({}, "waiting for the plant");
  PeerWait wait;
  wait.matched = [&runtime](std::string&) {
    runtime.shutdown().RequestShutdown();  // as SIGTERM would
    return false;
  };
  EXPECT_EQ(runtime.WaitForPeers(wait), PeerWaitResult::kShutdown);
  EXPECT_EQ(runtime.FailStart({}, "no plant", exit_code::kPeersNotMatched), exit_code::kOk);
}

TEST_F(ServiceRuntime, RefusesToRunBeforeItsPeersMatched) {
  Runtime runtime(Options(), "leg2", Log());
  runtime.Start({}, "waiting for the plant");
  EXPECT_THROW(runtime.Running({}, "primary", "primary"), std::logic_error);
  EXPECT_FALSE(runtime.Publish(hexa_msg_NODE_RUNNING, {}, "not yet"));
}

TEST_F(ServiceRuntime, APeerProcessThatEndedFailsTheWaitAtOnceWhenAsked) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  ASSERT_EQ(waitpid(child, nullptr, 0), child);  // ended and reaped: its pid names no process
  node::CommonOptions o = Options();
  o.peer_pids = {"recorder=" + std::to_string(child)};
  Runtime runtime(o, "plant_ended_peer", Log());
  runtime.Start({}, "waiting for peers");
  PeerWait wait;
  wait.rule.timeout_s = 0.3;
  wait.processes = {"recorder"};
  wait.matched = [](std::string& missing) {
    missing = "recorder";
    return false;
  };
  // Not asked: the wait lasts its timeout.
  EXPECT_EQ(runtime.WaitForPeers(wait), PeerWaitResult::kTimedOut);
  // Asked (the plant): at the first look, well within a long timeout.
  wait.rule.timeout_s = 30.0;
  wait.fail_when_a_process_ends = true;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(runtime.WaitForPeers(wait), PeerWaitResult::kProcessEnded);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  EXPECT_EQ(runtime.FailStart({}, "peers not ready", exit_code::kPeersNotMatched),
            exit_code::kPeersNotMatched);
}

TEST_F(ServiceRuntime, AMalformedPeerPidIsRefusedAtConstruction) {
  node::CommonOptions o = Options();
  o.peer_pids = {"supervisor"};  // no "=pid"
  EXPECT_THROW(Runtime(o, "leg3", Log()), std::invalid_argument);
}

}  // namespace
}  // namespace hexa::services
