// The service lifecycle as plain units (hexa/services/lifecycle.hpp, control_cycle.hpp):
// transitions, the state each phase publishes, the start-up wait's timing, the sample queue
// and the control cycle's trigger and sequence. No DDS, no clock.
#include <gtest/gtest.h>

#include <mutex>
#include <thread>

#include "hexa/services/control_cycle.hpp"
#include "hexa/services/lifecycle.hpp"

namespace hexa::services {
namespace {

constexpr Phase kAll[] = {Phase::kStarting, Phase::kPeersMatched, Phase::kRunning,
                          Phase::kStopping, Phase::kFailed};

TEST(Lifecycle, OnlyTheDocumentedTransitionsAreLegal) {
  int legal = 0;
  for (Phase from : kAll)
    for (Phase to : kAll) legal += CanEnter(from, to) ? 1 : 0;
  EXPECT_EQ(legal, 6);
  EXPECT_TRUE(CanEnter(Phase::kStarting, Phase::kPeersMatched));
  EXPECT_TRUE(CanEnter(Phase::kStarting, Phase::kFailed));
  EXPECT_TRUE(CanEnter(Phase::kStarting, Phase::kStopping));
  EXPECT_TRUE(CanEnter(Phase::kPeersMatched, Phase::kRunning));
  EXPECT_TRUE(CanEnter(Phase::kPeersMatched, Phase::kStopping));
  EXPECT_TRUE(CanEnter(Phase::kRunning, Phase::kStopping));
  // Running needs matched peers first; nothing comes back from stopping or failed.
  EXPECT_FALSE(CanEnter(Phase::kStarting, Phase::kRunning));
  EXPECT_FALSE(CanEnter(Phase::kRunning, Phase::kStarting));
  EXPECT_FALSE(CanEnter(Phase::kRunning, Phase::kFailed));
  for (Phase to : kAll) {
    EXPECT_FALSE(CanEnter(Phase::kStopping, to)) << ToString(to);
    EXPECT_FALSE(CanEnter(Phase::kFailed, to)) << ToString(to);
  }
}

TEST(Lifecycle, EachPhasePublishesItsNodeState) {
  EXPECT_EQ(StateOf(Phase::kStarting), hexa_msg_NODE_STARTING);
  EXPECT_EQ(StateOf(Phase::kPeersMatched), hexa_msg_NODE_STARTING);
  EXPECT_EQ(StateOf(Phase::kRunning), hexa_msg_NODE_RUNNING);
  EXPECT_EQ(StateOf(Phase::kStopping), hexa_msg_NODE_STOPPING);
  EXPECT_EQ(StateOf(Phase::kFailed), hexa_msg_NODE_FAULT);
}

TEST(Lifecycle, HoldAndFaultOnlyWhileRunning) {
  EXPECT_TRUE(MayPublish(Phase::kRunning, hexa_msg_NODE_RUNNING));
  EXPECT_TRUE(MayPublish(Phase::kRunning, hexa_msg_NODE_HOLD));
  EXPECT_TRUE(MayPublish(Phase::kRunning, hexa_msg_NODE_FAULT));
  EXPECT_FALSE(MayPublish(Phase::kRunning, hexa_msg_NODE_STARTING));
  EXPECT_FALSE(MayPublish(Phase::kStarting, hexa_msg_NODE_RUNNING));
  EXPECT_FALSE(MayPublish(Phase::kStarting, hexa_msg_NODE_HOLD));
  EXPECT_TRUE(MayPublish(Phase::kPeersMatched, hexa_msg_NODE_STARTING));
  EXPECT_FALSE(MayPublish(Phase::kStopping, hexa_msg_NODE_RUNNING));
  EXPECT_TRUE(MayPublish(Phase::kStopping, hexa_msg_NODE_STOPPING));
  EXPECT_TRUE(MayPublish(Phase::kFailed, hexa_msg_NODE_FAULT));
  EXPECT_FALSE(MayPublish(Phase::kFailed, hexa_msg_NODE_RUNNING));
}

constexpr std::int64_t kS = 1'000'000'000;

TEST(PeerWaitRule, MatchedAtOnceNeverReports) {
  PeerWaitRule rule({}, 5 * kS);
  EXPECT_EQ(rule.Look(5 * kS, true), PeerWaitRule::Verdict::kMatched);
}

TEST(PeerWaitRule, ReportsAfterThreeSecondsThenEverySecondAndTimesOut) {
  PeerWaitRule::Params p;
  p.timeout_s = 10.0;
  PeerWaitRule rule(p, 100 * kS);
  int reports = 0;
  std::int64_t first_report = -1;
  std::int64_t timed_out_at = -1;
  // Looks every 20 ms, as the services do.
  for (std::int64_t t = 100 * kS; t <= 112 * kS; t += 20'000'000) {
    const auto v = rule.Look(t, false);
    if (v == PeerWaitRule::Verdict::kReport) {
      if (reports++ == 0) first_report = t;
    } else if (v == PeerWaitRule::Verdict::kTimedOut) {
      timed_out_at = t;
      break;
    } else {
      EXPECT_EQ(v, PeerWaitRule::Verdict::kWait);
    }
  }
  EXPECT_EQ(first_report, 103 * kS);
  // At 3, 4, ..., 10 s: eight reports, then the timeout just after 10 s.
  EXPECT_EQ(reports, 8);
  EXPECT_EQ(timed_out_at, 110 * kS + 20'000'000);
  EXPECT_NEAR(rule.waited_s(), 10.02, 1e-9);
}

TEST(PeerWaitRule, AMatchAfterReportsEndsTheWait) {
  PeerWaitRule rule({}, 0);
  EXPECT_EQ(rule.Look(4 * kS, false), PeerWaitRule::Verdict::kReport);
  EXPECT_EQ(rule.Look(4 * kS + 1, false), PeerWaitRule::Verdict::kWait);
  EXPECT_EQ(rule.Look(4 * kS + 2, true), PeerWaitRule::Verdict::kMatched);
}

struct Tick {
  struct {
    std::uint64_t tick = 0;
  } header;
};

TEST(SampleQueue, KeepsOrderAndDropsTheOldestWhenFull) {
  SampleQueue<Tick, 3> q;
  EXPECT_TRUE(q.empty());
  Tick dropped;
  for (std::uint64_t t = 1; t <= 3; ++t) EXPECT_FALSE(q.Push(Tick{{t}}, &dropped));
  EXPECT_TRUE(q.full());
  EXPECT_EQ(q.front().header.tick, 1u);
  EXPECT_EQ(q.back().header.tick, 3u);
  EXPECT_TRUE(q.Push(Tick{{4}}, &dropped));
  EXPECT_EQ(dropped.header.tick, 1u);
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.Pop().header.tick, 2u);
  EXPECT_EQ(q.Pop().header.tick, 3u);
  EXPECT_FALSE(q.Push(Tick{{5}}));  // wraps around the ring
  EXPECT_EQ(q.Pop().header.tick, 4u);
  EXPECT_EQ(q.Pop().header.tick, 5u);
  EXPECT_TRUE(q.empty());
}

class CountingNode {
 public:
  explicit CountingNode(ControlCycle& cycle) : cycle_(cycle) {}
  void Cycle() {
    ++runs;
    sequence_inside = cycle_.sequence();
    lock_held = !cycle_.mutex().try_lock();
    if (!lock_held) cycle_.mutex().unlock();
  }
  int runs = 0;
  std::uint64_t sequence_inside = 0;
  bool lock_held = false;

 private:
  ControlCycle& cycle_;
};

TEST(ControlCycle, RunsTheBoundMethodUnderItsMutexWithAnOddSequence) {
  ControlCycle cycle;
  CountingNode node(cycle);
  cycle.Bind<&CountingNode::Cycle>(node);
  EXPECT_EQ(cycle.sequence(), 0u);
  // From another thread, so that try_lock on the (non-recursive) mutex tells a held lock.
  std::thread([&] { cycle.Run(); }).join();
  EXPECT_EQ(node.runs, 1);
  EXPECT_EQ(node.sequence_inside % 2, 1u);
  EXPECT_TRUE(node.lock_held);
  EXPECT_EQ(cycle.sequence(), 2u);
  {
    std::lock_guard<std::mutex> lock(cycle.mutex());
    cycle.RunHoldingLock();
  }
  EXPECT_EQ(node.runs, 2);
  EXPECT_EQ(cycle.sequence(), 4u);
}

// A stand-in for comm::Reader: records the callback the cycle installs.
struct FakeReader {
  void OnDataAvailable(void (*callback)(void*), void* arg) {
    this->callback = callback;
    this->arg = arg;
  }
  void Deliver() { if (callback != nullptr) callback(arg); }
  void (*callback)(void*) = nullptr;
  void* arg = nullptr;
};

TEST(ControlCycle, DataOnATriggerRunsTheCycleUntilTriggersStop) {
  ControlCycle cycle;
  CountingNode node(cycle);
  cycle.Bind<&CountingNode::Cycle>(node);
  FakeReader a, b;
  EXPECT_TRUE(cycle.TriggerOn(a));
  EXPECT_TRUE(cycle.TriggerOn(b));
  a.Deliver();
  b.Deliver();
  EXPECT_EQ(node.runs, 2);
  cycle.StopTriggers();
  EXPECT_EQ(a.callback, nullptr);
  EXPECT_EQ(b.callback, nullptr);
  a.Deliver();
  EXPECT_EQ(node.runs, 2);
  EXPECT_EQ(cycle.triggers(), 0u);
}

TEST(ControlCycle, RefusesMoreTriggersThanItsCapacity) {
  ControlCycle cycle;
  std::array<FakeReader, ControlCycle::kMaxTriggers + 1> readers;
  for (std::size_t i = 0; i < ControlCycle::kMaxTriggers; ++i) EXPECT_TRUE(cycle.TriggerOn(readers[i]));
  EXPECT_FALSE(cycle.TriggerOn(readers.back()));
  EXPECT_EQ(readers.back().callback, nullptr);
  cycle.StopTriggers();
}

}  // namespace
}  // namespace hexa::services
