// The domain check's port scan (deploy/launcher/domain_probe.cpp): a port in a domain's
// participant range held by a process started for another domain is not that domain's
// participant; held by a process of that domain (or one without --domain) it is.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "domain_probe.hpp"
#include "hexa/comm/config.hpp"
#include "udp_ports.hpp"

namespace {

// The probe creates a DDS participant: on the loopback configuration only, whoever runs this.
const bool kLoopback = [] {
  hexa::comm::EnsureDdsConfig(std::nullopt);
  return true;
}();

// A child that binds 127.0.0.1:port and sleeps, with `--domain domain_arg` on its command line.
pid_t HoldPort(int port, const std::string& domain_arg) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string code = "import socket, time\ns = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
                             "s.bind(('127.0.0.1', " + std::to_string(port) + "))\ntime.sleep(30)\n";
    execl("/usr/bin/python3", "python3", "-c", code.c_str(), "--domain", domain_arg.c_str(), nullptr);
    _exit(127);
  }
  for (int i = 0; i < 100 && !hexa::deploy::UdpLoopbackPortBound(port); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return pid;
}

void Stop(pid_t pid) {
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
}

// Domains of this test: 231-232 (tests/CMakeLists.txt lists the suite's domains). Index 60's
// user port, in the middle of the scanned range.
TEST(DomainPorts, APortHeldByAProcessOfAnotherDomainIsNotCounted) {
  const int domain = 231;
  const int port = hexa::deploy::UserUnicastPort(domain, 60);
  const pid_t other = HoldPort(port, "232");
  ASSERT_TRUE(hexa::deploy::UdpLoopbackPortBound(port));
  EXPECT_EQ(hexa::deploy::DomainArgumentOf(other), 232);
  EXPECT_EQ(hexa::deploy::ProbeDomain(domain, 0.1).fixed_index_ports, 0);
  Stop(other);
}

TEST(DomainPorts, APortHeldByAProcessOfTheDomainIsCountedAndNamed) {
  const int domain = 231;
  const int port = hexa::deploy::UserUnicastPort(domain, 60);
  const pid_t same = HoldPort(port, "231");
  ASSERT_TRUE(hexa::deploy::UdpLoopbackPortBound(port));
  const auto probe = hexa::deploy::ProbeDomain(domain, 0.1);
  EXPECT_EQ(probe.fixed_index_ports, 1);
  ASSERT_EQ(probe.port_owners.size(), 1u);
  EXPECT_NE(probe.port_owners[0].find("(pid " + std::to_string(same) + ")"), std::string::npos);
  Stop(same);
  EXPECT_EQ(hexa::deploy::DomainArgumentOf(getpid()), -1);
}

}  // namespace
