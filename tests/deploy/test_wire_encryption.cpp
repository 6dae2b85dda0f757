// Encryption on the wire (docs/security.md, "DDS Security"): an operator command carrying a
// marker string is sent to a recorder over loopback, once without and once with DDS Security,
// while tcpdump captures every UDP packet. Without security the marker is on the wire; with
// it, the command still arrives (the recording has it) but the marker appears in no packet.
// Needs root and tcpdump (skips otherwise); ctest runs it inside `unshare -n`.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "deployment.hpp"
#include "generate.hpp"
#include "hexa/recording/recording.hpp"
#include "process_group.hpp"
#include "scratch_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hexa::deploy;
using namespace std::chrono_literals;

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::size_t Count(const std::string& hay, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t p = hay.find(needle); p != std::string::npos; p = hay.find(needle, p + 1)) ++n;
  return n;
}

struct Exchange {
  std::size_t marker_on_wire = 0;
  std::uint64_t commands_recorded = 0;
  std::uint64_t packets_bytes = 0;
};

// Records OperatorCommand while hexa_operator sends one with `marker` in its CSV path.
Exchange SendMarkedCommand(const std::string& dir, const std::string& dds_config, int domain,
             const std::string& marker) {
  Exchange x;
  ProcessGroup g;
  std::string err;
  const std::string pcap = dir + "/wire.pcap";
  ChildSpec dump{"tcpdump", {"/usr/bin/tcpdump", "-i", "lo", "-s", "0", "-U", "--immediate-mode", "-w", pcap, "udp"}, {},
                 dir + "/tcpdump.log"};
  EXPECT_GT(g.Start(dump, err), 0) << err;
  for (int i = 0; i < 100 && Slurp(dir + "/tcpdump.log").find("listening on") == std::string::npos; ++i)
    std::this_thread::sleep_for(50ms);
  const std::map<std::string, std::string> env{{"CYCLONEDDS_URI", "file://" + dds_config}};
  ChildSpec rec{"recorder",
                {HEXA_RECORDER, "record", "--output", dir + "/ops.mcap", "--domain",
                 std::to_string(domain), "--topics", "hexa_OperatorCommand"},
                env, dir + "/recorder.log"};
  rec.env["HEXA_IDENTITY"] = "recorder";
  EXPECT_GT(g.Start(rec, err), 0) << err;
  ChildSpec op{"operator",
               {HEXA_OPERATOR, "--domain", std::to_string(domain), "--trajectory", "/" + marker + ".csv",
                "--wait", "30", "--to", "any-reader", "start"},
               env, dir + "/operator.log"};
  op.env["HEXA_IDENTITY"] = "operator";
  EXPECT_GT(g.Start(op, err), 0) << err;
  const auto ev = g.WaitEvent(60s);
  EXPECT_EQ(ev.kind, ProcessGroup::Event::kChildExited);
  EXPECT_EQ(ev.exit.name, "operator");
  EXPECT_EQ(ev.exit.exit_code, 0) << Slurp(dir + "/operator.log");
  std::this_thread::sleep_for(300ms);
  g.Stop("recorder", 5000ms);
  std::this_thread::sleep_for(1000ms);  // tcpdump writes what it has read; give it time to read
  g.Stop("tcpdump", 5000ms);
  const std::string wire = Slurp(pcap);
  x.packets_bytes = wire.size();
  x.marker_on_wire = Count(wire, marker);
  const auto info = hexa::recorder::Inspect(dir + "/ops.mcap");
  for (const auto& ch : info.channels)
    if (ch.topic == "hexa_OperatorCommand") x.commands_recorded = ch.count;
  return x;
}

TEST(WireEncryption, OperatorCommandIsReadableOnlyWithoutSecurity) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root (tcpdump)";
  if (access("/usr/bin/tcpdump", X_OK) != 0) GTEST_SKIP() << "no tcpdump (Debian package tcpdump)";
  const std::string dir = hexa::testing::ScratchDir("wire");
  fs::create_directories(dir + "/plain");
  fs::create_directories(dir + "/secure");
  const int domain = 206 + getpid() % 24;

  // One host on loopback with a recorder and an operator identity.
  hexa::deployment::Deployment d;
  d.set_name("wire-test");
  d.set_domain_id(static_cast<unsigned>(domain));
  d.set_mode(hexa::deployment::LOCKSTEP);
  d.mutable_security()->set_enabled(true);
  auto* h = d.add_host();
  h->set_name("one");
  auto* i = h->add_interface();
  i->set_name("lo");
  i->set_address("127.0.0.1/8");
  h->set_dds_interface("lo");
  h->add_process()->set_role(hexa::deployment::RECORDER);
  h->add_process()->set_role(hexa::deployment::OPERATOR);
  ApplyDefaults(d);
  GenerateOptions o;
  o.in_place = true;
  const auto r = Generate(d, "", dir + "/gen", o);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(std::system((std::string(HEXA_MAKE_SECURITY) + " " + dir + "/gen > " + dir + "/sec.log 2>&1").c_str()), 0)
      << Slurp(dir + "/sec.log");

  const std::string marker = "MARKER_wire_" + std::to_string(getpid());
  const Exchange plain = SendMarkedCommand(dir + "/plain", HEXA_LOOPBACK_CONFIG, domain, marker);
  const Exchange secure = SendMarkedCommand(dir + "/secure", dir + "/gen/hosts/one/etc/hexa/cyclonedds.xml", domain, marker);
  EXPECT_EQ(plain.commands_recorded, 1u);
  EXPECT_GE(plain.marker_on_wire, 1u) << "the capture missed the plain exchange (" << plain.packets_bytes << " bytes)";
  EXPECT_EQ(secure.commands_recorded, 1u) << "the secured command did not arrive";
  EXPECT_EQ(secure.marker_on_wire, 0u) << "the secured payload is readable on the wire";
  EXPECT_GT(secure.packets_bytes, 1000u);
  std::printf("marker on the wire: without security %zu, with security %zu (capture %llu bytes)\n",
              plain.marker_on_wire, secure.marker_on_wire,
              static_cast<unsigned long long>(secure.packets_bytes));
}

}  // namespace
