// The motion stream over real UDP on loopback: hexa_stream_send (a child process) -> the
// receiving library -> MotionStream. Bad packets are refused by reason and counted exactly;
// loss, reordering and duplicates are seen by sequence. The receiver binds port 0 (a free
// port), so runs never meet.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>

#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/motion_stream.hpp"
#include "hexa/services/udp_stream.hpp"

extern char** environ;

namespace hexa {
namespace {

pid_t Spawn(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  return pid;
}

void SleepFor(double seconds) {
  timespec ts{0, static_cast<long>(seconds * 1e9)};
  nanosleep(&ts, nullptr);
}

std::uint64_t Count(const StreamCounters& c, StreamPacketError e) {
  return c.by_reason[static_cast<std::size_t>(e)];
}

TEST(StreamUdp, SenderToReceiverCountsEveryPacketByReason) {
  udp::MotionStreamReceiver receiver({"127.0.0.1", 0}, StreamDecodeLimits{});
  MotionStreamConfig config;
  config.timeout_s = 1.0;  // the test's polling is not real time
  MotionStream stream(config);
  const pid_t child = Spawn({HEXA_STREAM_SEND, "--port", std::to_string(receiver.port()),
                             "--rate-hz", "200", "--duration-s", "1", "--bad-every", "10",
                             "--loss", "0.05", "--reorder", "0.05", "--duplicate", "0.05",
                             "--seed", "3"});
  ASSERT_GT(child, 0);
  int status = 0;
  MotionStreamOutput out;
  double t = 0.0;
  bool exited = false;
  for (int i = 0; i < 2000 && !exited; ++i) {  // at most ~10 s
    SleepFor(0.005);
    exited = waitpid(child, &status, WNOHANG) == child;
    const std::size_t n = receiver.Receive(stream);
    stream.Update({t += 0.005, receiver.packets(), n}, out);
  }
  if (!exited) {
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
    FAIL() << "hexa_stream_send did not finish";
  }
  stream.Update({t += 0.005, receiver.packets(), receiver.Receive(stream)}, out);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const StreamCounters& c = stream.counters();
  // 200 packets, a bad one after every 10th: 20 bad, 5 of each kind.
  EXPECT_EQ(Count(c, StreamPacketError::kWrongSize), 5u);
  EXPECT_EQ(Count(c, StreamPacketError::kWrongVersion), 5u);
  EXPECT_EQ(Count(c, StreamPacketError::kNotFinite), 5u);
  EXPECT_EQ(Count(c, StreamPacketError::kAbsurdValue), 5u);
  EXPECT_EQ(Count(c, StreamPacketError::kBadMagic), 0u);
  // Every good datagram is either applied, a duplicate or late; with the sequence numbers
  // 1..200, applied + missing = the newest applied.
  EXPECT_EQ(c.applied + Count(c, StreamPacketError::kDuplicate) + Count(c, StreamPacketError::kLate) + 20,
            receiver.datagrams());
  EXPECT_GT(c.applied, 150u);
  EXPECT_GT(Count(c, StreamPacketError::kDuplicate), 0u);
  EXPECT_GT(Count(c, StreamPacketError::kLate), 0u);
  EXPECT_GT(c.missing, 0u);
  EXPECT_LE(c.applied + c.missing, 200u);
  EXPECT_EQ(c.timeouts, 0u);
  EXPECT_TRUE(out.displacement.allFinite());
}

TEST(StreamUdp, APortInUseIsReportedWithAddressAndReason) {
  udp::MotionStreamReceiver first({"127.0.0.1", 0}, StreamDecodeLimits{});
  try {
    udp::MotionStreamReceiver second({"127.0.0.1", first.port()}, StreamDecodeLimits{});
    FAIL() << "bound the same port twice";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "motion stream: cannot bind 127.0.0.1:" +
                                         std::to_string(first.port()) + ": Address already in use");
  }
  EXPECT_THROW(udp::MotionStreamReceiver({"localhost", 0}, StreamDecodeLimits{}), std::runtime_error);
}

}  // namespace
}  // namespace hexa
