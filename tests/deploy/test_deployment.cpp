// Deployment descriptions (proto/deployment.proto) and what hexa_deploy generates from them:
// every broken file gives its own clear error; the sample deployments are valid; the Cyclone
// configuration, permissions and systemd units say what docs/deployment.md promises; every
// generated unit passes `systemd-analyze verify` without a warning.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "deployment.hpp"
#include "generate.hpp"
#include "unit_file.hpp"
#include "scratch_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hexa::deploy;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool Shell(const std::string& cmd, std::string& out) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (p == nullptr) return false;
  char buf[512];
  out.clear();
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  return pclose(p) == 0;
}

TEST(DeploymentFile, EveryBrokenFileGivesItsOwnError) {
  int files = 0;
  for (const auto& e : fs::directory_iterator(HEXA_BROKEN_DEPLOYMENTS)) {
    if (e.path().extension() != ".textproto") continue;
    ++files;
    const std::string text = Slurp(e.path().string());
    ASSERT_EQ(text.rfind("# expect: ", 0), 0u) << e.path() << " has no '# expect:' first line";
    const std::string expect = text.substr(10, text.find('\n') - 10);
    const auto l = LoadDeployment(e.path().string());
    EXPECT_FALSE(l.ok) << e.path();
    std::string all;
    for (const auto& err : l.errors) all += err + "\n";
    EXPECT_NE(all.find(expect), std::string::npos)
        << e.path().filename() << ": expected '" << expect << "' in:\n" << all;
    // Every message names the file.
    for (const auto& err : l.errors)
      EXPECT_EQ(err.rfind(e.path().string(), 0), 0u) << err;
  }
  EXPECT_GE(files, 15);
}

TEST(DeploymentFile, SampleDeploymentsAreValid) {
  int files = 0;
  for (const auto& e : fs::directory_iterator(HEXA_SAMPLE_DEPLOYMENTS)) {
    if (e.path().extension() != ".textproto") continue;
    ++files;
    const auto l = LoadDeployment(e.path().string());
    std::string all;
    for (const auto& err : l.errors) all += err + "\n";
    EXPECT_TRUE(l.ok) << e.path() << ":\n" << all;
  }
  EXPECT_GE(files, 1);
}

TEST(DeploymentFile, MissingFileIsAnError) {
  const auto l = LoadDeployment("/nonexistent/deployment.textproto");
  ASSERT_FALSE(l.ok);
  EXPECT_NE(l.errors.at(0).find("cannot open"), std::string::npos);
}

TEST(CommandLine, JoinThenSplitGivesTheSameWords) {
  std::mt19937 rng(15);
  const std::string alphabet = "ab/._-=: \t\"'$%\\zq9";
  std::uniform_int_distribution<int> words(1, 6), len(0, 12), ch(0, static_cast<int>(alphabet.size()) - 1);
  for (int round = 0; round < 20000; ++round) {
    std::vector<std::string> argv(static_cast<std::size_t>(words(rng)));
    for (auto& w : argv) {
      const int n = len(rng);
      for (int i = 0; i < n; ++i) w += alphabet[static_cast<std::size_t>(ch(rng))];
    }
    const std::string line = JoinCommandLine(argv);
    ASSERT_EQ(SplitCommandLine(line), argv) << "line: " << line;
  }
}

class Generated : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = hexa::testing::ScratchDir("deploy_gen");
    const std::string path = std::string(HEXA_SAMPLE_DEPLOYMENTS) + "/five-hosts.textproto";
    loaded_ = LoadDeployment(path);
    ASSERT_TRUE(loaded_.ok);
    // The binaries where the units say they are (so that systemd-analyze finds them).
    bin_ = dir_ + "/bin";
    fs::create_directories(bin_);
    for (const auto& [name, target] :
         std::vector<std::pair<std::string, std::string>>{{"hexa_plant_sim", HEXA_PLANT_SIM},
                                                          {"hexa_leg_ctrl", HEXA_LEG_CTRL},
                                                          {"hexa_task_space", HEXA_TASK_SPACE},
                                                          {"hexa_recorder", HEXA_RECORDER},
                                                          {"hexa_deploy", HEXA_DEPLOY}})
      fs::create_symlink(target, bin_ + "/" + name);
    loaded_.deployment.set_bin_dir(bin_);
    const auto r = Generate(loaded_.deployment, Slurp(path), dir_ + "/out", GenerateOptions{});
    ASSERT_TRUE(r.ok) << r.error;
  }
  std::string Host(const std::string& h, const std::string& rel) const {
    return dir_ + "/out/hosts/" + h + "/" + rel;
  }
  std::string dir_, bin_;
  LoadedDeployment loaded_;
};

TEST_F(Generated, CycloneConfigPinsTheInterfaceListsEveryPeerAndIsSecured) {
  const std::string xml = Slurp(Host("legs-a", "etc/hexa/cyclonedds.xml"));
  EXPECT_NE(xml.find("<NetworkInterface name=\"eth1\" multicast=\"false\"/>"), std::string::npos);
  EXPECT_NE(xml.find("<AllowMulticast>false</AllowMulticast>"), std::string::npos);
  for (const char* peer : {"10.10.0.1", "10.10.0.2", "10.10.0.3", "10.10.0.4", "10.10.0.5"})
    EXPECT_NE(xml.find(std::string("<Peer address=\"") + peer + "\"/>"), std::string::npos) << peer;
  EXPECT_EQ(xml.find("192.168.1.20"), std::string::npos) << "the recorder's other interface leaked in";
  EXPECT_NE(xml.find("<IdentityCertificate>file:/etc/hexa/security/${HEXA_IDENTITY}/cert.pem"), std::string::npos);
  EXPECT_NE(xml.find("<Governance>file:/etc/hexa/security/governance.p7s</Governance>"), std::string::npos);
  // The recorder host's DDS interface is eth1, not its eth0.
  const std::string rec = Slurp(Host("recorder", "etc/hexa/cyclonedds.xml"));
  EXPECT_NE(rec.find("<NetworkInterface name=\"eth1\""), std::string::npos);
  EXPECT_EQ(rec.find("name=\"eth0\""), std::string::npos);
}

// Every generated Cyclone configuration, secured or not, carries every <Internal> setting of
// the repository's own DDS configuration, which the one-machine session runs with: the 10 ms
// heartbeats (the lockstep plant's recorder sync waits for acknowledgements; at Cyclone's
// default 100 ms lockstep with a recorder ran at 0.5x real time) and the 250 ms writer linger.
TEST_F(Generated, EveryCycloneConfigHasTheLoopbackConfigsInternalSettings) {
  const std::string loopback = Slurp(HEXA_LOOPBACK_CONFIG);
  const auto begin = loopback.find("<Internal>"), end = loopback.find("</Internal>");
  ASSERT_TRUE(begin != std::string::npos && end != std::string::npos) << HEXA_LOOPBACK_CONFIG;
  const std::string internal_block = loopback.substr(begin, end - begin);
  std::vector<std::string> expected;  // each element of the loopback's <Internal>
  const std::regex element("<([A-Za-z]+)[^>]*>[^<]*</\\1>");
  for (std::sregex_iterator it(internal_block.begin(), internal_block.end(), element), last; it != last; ++it)
    expected.push_back(it->str());
  ASSERT_GE(expected.size(), 2u) << internal_block;
  EXPECT_NE(internal_block.find("<HeartbeatInterval minsched=\"10 ms\">10 ms</HeartbeatInterval>"),
            std::string::npos);
  auto check_tree = [&](const std::string& hosts_dir) {
    int configs = 0;
    for (const auto& host : fs::directory_iterator(hosts_dir)) {
      const std::string xml = Slurp(host.path().string() + "/etc/hexa/cyclonedds.xml");
      ++configs;
      const auto internal = xml.find("<Internal>");
      for (const auto& e : expected) {
        EXPECT_NE(xml.find(e), std::string::npos) << host.path() << " lacks " << e;
        EXPECT_TRUE(internal != std::string::npos && xml.find(e) > internal &&
                    xml.find(e) < xml.find("</Internal>"))
            << host.path() << ": " << e << " must be inside <Internal>";
      }
    }
    return configs;
  };
  EXPECT_EQ(check_tree(dir_ + "/out/hosts"), 5);  // secured: every host keeps it
  auto plain = loaded_.deployment;
  plain.mutable_security()->set_enabled(false);
  const auto r = Generate(plain, "# unsecured copy\n", dir_ + "/plain", GenerateOptions{});
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(check_tree(dir_ + "/plain/hosts"), 5);
  EXPECT_EQ(Slurp(dir_ + "/plain/hosts/legs-a/etc/hexa/cyclonedds.xml").find("<Security>"), std::string::npos);
}

// A real-time recorder reads the periodic topics best effort (docs/measurements/deployment.md, "The lossy
// recorder link": a reliable one made the control writers repair its lossy link on the control
// CPU); a lockstep one stays reliable (the lockstep plant waits for its acknowledgements).
TEST_F(Generated, RealTimeRecorderReadsThePeriodicTopicsBestEffort) {
  UnitFile u;
  std::string err;
  ASSERT_TRUE(ParseUnitFile(Host("recorder", "lib/systemd/system/hexa-recorder.service"), u, err)) << err;
  ASSERT_EQ(loaded_.deployment.mode(), hexa::deployment::REALTIME);
  ASSERT_FALSE(u.exec_start.empty());
  EXPECT_NE(u.exec_start.back().find("--periodic-reliability best-effort"), std::string::npos) << u.exec_start.back();

  auto lockstep = loaded_.deployment;
  lockstep.set_mode(hexa::deployment::LOCKSTEP);
  lockstep.mutable_timing()->set_watchdog_s(30);
  const auto r = Generate(lockstep, "", dir_ + "/lockstep-rec", GenerateOptions{});
  ASSERT_TRUE(r.ok) << r.error;
  UnitFile l;
  ASSERT_TRUE(ParseUnitFile(dir_ + "/lockstep-rec/hosts/recorder/lib/systemd/system/hexa-recorder.service", l, err)) << err;
  ASSERT_FALSE(l.exec_start.empty());
  EXPECT_EQ(l.exec_start.back().find("--periodic-reliability"), std::string::npos) << l.exec_start.back();
}

// The loop settings the one-machine session runs with reach every control process of a
// generated deployment: the CPU wake-up latency hold and Cyclone's timed-event thread at normal
// scheduling are the services' defaults, which no generated command line overrides (nor does
// it turn real-time scheduling off); the CPU placement is the unit's CPUAffinity (the services
// are not given a --cpus of their own that could contradict it); and the service user may hold
// the latency limit (the device is root's): a udev rule on every real-time host with a
// control process.
TEST_F(Generated, ControlProcessesGetTheLoopSettings) {
  int control_units = 0;
  for (const auto& h : loaded_.deployment.host()) {
    for (const auto& e : fs::directory_iterator(Host(h.name(), "lib/systemd/system"))) {
      if (e.path().extension() != ".service") continue;
      UnitFile u;
      std::string err;
      ASSERT_TRUE(ParseUnitFile(e.path().string(), u, err)) << err;
      if (u.exec_start.at(0) == "/bin/sh") continue;  // the recorder: not a control process
      ++control_units;
      for (const char* overriding : {"--cpu-latency-us", "--rt-dds-event-thread", "--no-rt-sched", "--cpus"})
        EXPECT_EQ(std::find(u.exec_start.begin(), u.exec_start.end(), overriding), u.exec_start.end())
            << e.path() << " passes " << overriding;
      EXPECT_EQ(u.Get("Service.CPUSchedulingPolicy"), "fifo") << e.path();
    }
  }
  EXPECT_EQ(control_units, 11);  // plant, supervisor, 6 legs, 3 standbys
  // CPUAffinity from `cpu:` (io-sup: plant 1, supervisor 0), none where the file gives none.
  UnitFile u;
  std::string err;
  ASSERT_TRUE(ParseUnitFile(Host("io-sup", "lib/systemd/system/hexa-supervisor.service"), u, err)) << err;
  EXPECT_EQ(u.Get("Service.CPUAffinity"), "0");
  ASSERT_TRUE(ParseUnitFile(Host("legs-a", "lib/systemd/system/hexa-leg1.service"), u, err)) << err;
  EXPECT_EQ(u.Get("Service.CPUAffinity"), "");

  const std::string rule_rel = std::string("etc/udev/rules.d/") + kCpuLatencyUdevRuleFile;
  for (const char* host : {"io-sup", "legs-a", "legs-b", "standby-b"}) {
    const std::string rule = Slurp(Host(host, rule_rel));
    EXPECT_NE(rule.find("KERNEL==\"cpu_dma_latency\", GROUP=\"hexa\", MODE=\"0660\"\n"), std::string::npos)
        << host << ": " << rule;
  }
  EXPECT_FALSE(fs::exists(Host("recorder", rule_rel))) << "the recorder does not hold the limit";
  auto lockstep = loaded_.deployment;
  lockstep.set_mode(hexa::deployment::LOCKSTEP);
  lockstep.mutable_timing()->set_watchdog_s(30);
  ASSERT_TRUE(Generate(lockstep, "", dir_ + "/lockstep", GenerateOptions{}).ok);
  EXPECT_FALSE(fs::exists(dir_ + "/lockstep/hosts/io-sup/" + rule_rel)) << "lockstep runs as generated, unprivileged";
}

// The governance's protection kinds: data always ENCRYPT; metadata, discovery and liveliness
// from the deployment (defaults from ApplyDefaults).
TEST_F(Generated, GovernanceTakesTheProtectionKindsOfTheDeployment) {
  auto kind = [](const std::string& gov, const std::string& element) {
    const auto a = gov.find("<" + element + ">"), b = gov.find("</" + element + ">");
    return a == std::string::npos ? std::string("(missing)") : gov.substr(a + element.size() + 2, b - a - element.size() - 2);
  };
  const std::string def = Slurp(dir_ + "/out/security-src/governance.xml");
  const auto def_star = def.find("<topic_expression>*</topic_expression>");
  ASSERT_NE(def_star, std::string::npos);
  EXPECT_EQ(kind(def.substr(def_star), "metadata_protection_kind"),
            hexa::deployment::Protection_Name(kDefaultMetadataProtection));
  EXPECT_EQ(kind(def.substr(def_star), "data_protection_kind"), "ENCRYPT");
  // By default the loop topics are protected like every other topic: one "*" rule, ENCRYPT
  // (the sample deployment sets no protection kind; NONE on them is the file's explicit choice).
  EXPECT_EQ(kind(def.substr(def_star), "metadata_protection_kind"), "ENCRYPT");
  EXPECT_EQ(def.find("<topic_expression>hexa_ValveCommand</topic_expression>"), std::string::npos);
  EXPECT_EQ(kind(def, "discovery_protection_kind"), "ENCRYPT");
  EXPECT_EQ(kind(def, "liveliness_protection_kind"), "ENCRYPT");
  auto d = loaded_.deployment;
  d.mutable_security()->set_metadata_protection(hexa::deployment::NONE);
  d.mutable_security()->set_discovery_protection(hexa::deployment::SIGN);
  d.mutable_security()->set_liveliness_protection(hexa::deployment::SIGN);
  d.mutable_security()->set_loop_metadata_protection(hexa::deployment::PROTECTION_UNSPECIFIED);  // as metadata
  ASSERT_TRUE(Generate(d, "", dir_ + "/variant", GenerateOptions{}).ok);
  const std::string var = Slurp(dir_ + "/variant/security-src/governance.xml");
  EXPECT_EQ(kind(var, "metadata_protection_kind"), "NONE");
  EXPECT_EQ(kind(var, "data_protection_kind"), "ENCRYPT");
  EXPECT_EQ(kind(var, "discovery_protection_kind"), "SIGN");
  EXPECT_EQ(kind(var, "liveliness_protection_kind"), "SIGN");
  EXPECT_EQ(var.find("<topic_expression>hexa_ValveCommand"), std::string::npos) << "one rule when they agree";
  // The 1 kHz loop topics with their own metadata protection: a rule each, before "*" (the
  // first matching rule applies), data still ENCRYPT.
  d.mutable_security()->set_metadata_protection(hexa::deployment::ENCRYPT);
  d.mutable_security()->set_loop_metadata_protection(hexa::deployment::NONE);
  ASSERT_TRUE(Generate(d, "", dir_ + "/loop", GenerateOptions{}).ok);
  const std::string loop = Slurp(dir_ + "/loop/security-src/governance.xml");
  const auto star = loop.find("<topic_expression>*</topic_expression>");
  ASSERT_NE(star, std::string::npos);
  EXPECT_EQ(kind(loop.substr(star), "metadata_protection_kind"), "ENCRYPT");
  for (const char* topic : {"hexa_LegSensors", "hexa_ValveCommand", "hexa_GroundTruth"}) {
    const auto at = loop.find(std::string("<topic_expression>") + topic + "</topic_expression>");
    ASSERT_NE(at, std::string::npos) << topic;
    EXPECT_LT(at, star) << topic;
    EXPECT_EQ(kind(loop.substr(at), "metadata_protection_kind"), "NONE") << topic;
    EXPECT_EQ(kind(loop.substr(at), "data_protection_kind"), "ENCRYPT") << topic;
  }
  EXPECT_EQ(loop.find("<topic_expression>hexa_OperatorCommand"), std::string::npos);
}

TEST_F(Generated, PermissionsFollowTheIssuesAccessTable) {
  const std::string src = dir_ + "/out/security-src/permissions/";
  const std::string leg3 = Slurp(src + "leg3.xml");
  EXPECT_NE(leg3.find("<subject_name>CN=leg3,O=HexaTaar,OU=five-hosts</subject_name>"), std::string::npos);
  EXPECT_NE(leg3.find("<topic>hexa_ValveCommand</topic>\n          </topics>\n          <partitions><partition>hexa.leg3</partition>"),
            std::string::npos) << leg3;
  const auto publish_block = [](const std::string& xml) {
    std::string out;
    for (std::size_t p = xml.find("<publish>"); p != std::string::npos; p = xml.find("<publish>", p + 1))
      out += xml.substr(p, xml.find("</publish>", p) - p);
    return out;
  };
  EXPECT_EQ(publish_block(leg3).find("hexa_LegSensors"), std::string::npos);
  EXPECT_EQ(publish_block(leg3).find("leg4"), std::string::npos);
  EXPECT_EQ(publish_block(Slurp(src + "leg4_standby.xml")).find("leg3"), std::string::npos);
  EXPECT_NE(publish_block(Slurp(src + "leg4_standby.xml")).find("<partition>hexa.leg4</partition>"), std::string::npos);
  const std::string plant = publish_block(Slurp(src + "plant.xml"));
  for (const char* t : {"hexa_LegSensors", "hexa_ImuSample", "hexa_GroundTruth", "hexa_TrackerPose"})
    EXPECT_NE(plant.find(t), std::string::npos) << t;
  EXPECT_EQ(plant.find("hexa_ValveCommand"), std::string::npos);
  const std::string sup = publish_block(Slurp(src + "supervisor.xml"));
  EXPECT_NE(sup.find("hexa_LegSetpoint"), std::string::npos);
  EXPECT_EQ(sup.find("hexa_ValveCommand"), std::string::npos);
  EXPECT_EQ(sup.find("hexa_OperatorCommand"), std::string::npos);
  const std::string op = publish_block(Slurp(src + "operator.xml"));
  EXPECT_NE(op.find("hexa_OperatorCommand"), std::string::npos);
  EXPECT_EQ(op.find("hexa_ValveCommand"), std::string::npos);
  // The recorder subscribes to everything and publishes only its own status.
  const std::string rec = Slurp(src + "recorder.xml");
  EXPECT_EQ(publish_block(rec).find("hexa_LegSensors"), std::string::npos);
  EXPECT_NE(publish_block(rec).find("hexa_NodeStatus"), std::string::npos);
  for (const char* t : {"hexa_LegSensors", "hexa_ValveCommand", "hexa_GroundTruth", "hexa_PoseReport",
                        "hexa_TrackerPose"})
    EXPECT_NE(rec.find(t), std::string::npos) << t;
  const std::string gov = Slurp(dir_ + "/out/security-src/governance.xml");
  for (const char* s : {"<allow_unauthenticated_participants>false", "<discovery_protection_kind>ENCRYPT",
                        "<liveliness_protection_kind>ENCRYPT", "<data_protection_kind>ENCRYPT",
                        "<enable_write_access_control>true", "<domains><id>7</id></domains>"})
    EXPECT_NE(gov.find(s), std::string::npos) << s;
}

TEST_F(Generated, UnitsAreNotifyWithWatchdogRestartAndRealtimeResources) {
  UnitFile u;
  std::string err;
  ASSERT_TRUE(ParseUnitFile(Host("legs-b", "lib/systemd/system/hexa-leg4.service"), u, err)) << err;
  EXPECT_EQ(u.Get("Service.Type"), "notify");
  EXPECT_EQ(u.watchdog_s, 1.0);
  EXPECT_EQ(u.Get("Service.Restart"), "on-failure");
  EXPECT_EQ(u.Get("Service.CPUSchedulingPolicy"), "fifo");
  EXPECT_EQ(u.Get("Service.LimitMEMLOCK"), "infinity");
  ASSERT_FALSE(u.exec_start.empty());
  EXPECT_EQ(u.exec_start[0], bin_ + "/hexa_leg_ctrl");
  const auto has = [&](const std::vector<std::string>& v, std::vector<std::string> seq) {
    return std::search(v.begin(), v.end(), seq.begin(), seq.end()) != v.end();
  };
  EXPECT_TRUE(has(u.exec_start, {"--leg", "4"}));
  EXPECT_TRUE(has(u.exec_start, {"--mode", "realtime"}));
  EXPECT_TRUE(has(u.exec_start, {"--valve-readers", "2"}));
  EXPECT_TRUE(has(u.exec_start, {"--rt-priority", "80"}));
  EXPECT_EQ(u.Get("Service.CPUSchedulingPriority"), "80");
  ASSERT_EQ(u.exec_start_pre.size(), 1u);
  EXPECT_TRUE(has(u.exec_start_pre[0], {"verify-security"}));
  EXPECT_NE(std::find(u.environment.begin(), u.environment.end(),
                      std::pair<std::string, std::string>{"HEXA_IDENTITY", "leg4"}),
            u.environment.end());
  ASSERT_TRUE(ParseUnitFile(Host("standby-b", "lib/systemd/system/hexa-leg4-standby.service"), u, err)) << err;
  EXPECT_TRUE(has(u.exec_start, {"--standby"}));
  ASSERT_TRUE(ParseUnitFile(Host("recorder", "lib/systemd/system/hexa-recorder.service"), u, err)) << err;
  EXPECT_EQ(u.Get("Service.Restart"), "always");
  EXPECT_EQ(u.Get("Service.CPUSchedulingPriority"), "50");
  ASSERT_EQ(u.exec_start.size(), 3u);
  EXPECT_EQ(u.exec_start[0], "/bin/sh");
  EXPECT_NE(u.exec_start[2].find("$(date -u +%Y%m%d-%H%M%S)"), std::string::npos) << u.exec_start[2];
  ASSERT_TRUE(ParseUnitFile(Host("io-sup", "lib/systemd/system/hexa-plant.service"), u, err)) << err;
  EXPECT_TRUE(has(u.exec_start, {"--expect-recorder"}));
  EXPECT_EQ(u.Get("Service.CPUAffinity"), "1");
  // Below the legs that share its CPU (docs/measurements/deployment.md, "Where the lapses' milliseconds go").
  EXPECT_EQ(u.Get("Service.CPUSchedulingPriority"), "70");
  EXPECT_TRUE(has(u.exec_start, {"--rt-priority", "70"}));
  EXPECT_FALSE(fs::exists(Host("io-sup", "lib/systemd/system/hexa-operator.service")));
}

TEST_F(Generated, LockstepUnitsDoNotRestart) {
  auto d = loaded_.deployment;
  d.set_mode(hexa::deployment::LOCKSTEP);
  d.mutable_timing()->set_watchdog_s(30);
  const auto r = Generate(d, "", dir_ + "/lockstep", GenerateOptions{});
  ASSERT_TRUE(r.ok);
  UnitFile u;
  std::string err;
  ASSERT_TRUE(ParseUnitFile(dir_ + "/lockstep/hosts/legs-a/lib/systemd/system/hexa-leg1.service", u, err));
  EXPECT_EQ(u.Get("Service.Restart"), "no");
  EXPECT_EQ(u.Get("Service.CPUSchedulingPolicy"), "");
  EXPECT_EQ(u.watchdog_s, 30.0);
}

TEST_F(Generated, EveryUnitPassesSystemdAnalyzeVerify) {
  if (access("/usr/bin/systemd-analyze", X_OK) != 0) GTEST_SKIP() << "no systemd-analyze";
  int units = 0;
  for (const auto& h : loaded_.deployment.host()) {
    for (const auto& e : fs::directory_iterator(Host(h.name(), "lib/systemd/system"))) {
      std::string out;
      const bool ok = Shell("/usr/bin/systemd-analyze verify " + e.path().string(), out);
      EXPECT_TRUE(ok) << e.path() << ": " << out;
      EXPECT_EQ(out, "") << e.path();  // verify exits 0 on unknown keys: no output at all
      ++units;
    }
  }
  EXPECT_EQ(units, 17);  // 12 services + 5 targets
}

TEST(SystemdAnalyze, CatchesABrokenUnit) {
  // The check above can fail: a unit with a bad key is reported.
  if (access("/usr/bin/systemd-analyze", X_OK) != 0) GTEST_SKIP() << "no systemd-analyze";
  const std::string path = ::testing::TempDir() + "/hexa-broken-" + std::to_string(getpid()) + ".service";
  std::ofstream(path) << "[Service]\nType=notify\nWatchdogSec=soon\nExecStart=/bin/true\n";
  std::string out;
  Shell("/usr/bin/systemd-analyze verify " + path, out);
  EXPECT_NE(out.find("Failed to parse sec value"), std::string::npos) << out;
  fs::remove(path);
}

}  // namespace
