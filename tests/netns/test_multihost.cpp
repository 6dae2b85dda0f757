// Networked controllers for real (docs/deployment.md): five hosts in network namespaces made
// by the test (plant + supervisor, legs 1-3, legs 4-6, standbys of legs 4-6, recorder), one
// deployment description, `hexa_deploy generate`, `deploy/make_security.sh`, and every process
// started from its generated systemd unit (Environment, ExecStartPre, ExecStart; systemd's
// side of sd_notify played by the test). DDS Security on: authentication, access control,
// encryption. Needs root (skips otherwise).
#include <sched.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/recording/recording.hpp"
#include "hexa/recording/report.hpp"
#include "lab_session.hpp"
#include "session_util.hpp"

namespace {

namespace fs = std::filesystem;
using hexa::deploy::LabSession;
using hexa::deploy::LabSessionOptions;
using hexa::deploy::ProcessGroup;
using namespace std::chrono_literals;

constexpr double kRogueVolts = 9.8765432;  // no controller writes this

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

LabSessionOptions Options(const std::string& name) {
  LabSessionOptions o;
  o.work_dir = hexa::testing::ScratchDir("hx15-" + name);  // removed when the test passes
  o.binaries = {{"hexa_plant_sim", HEXA_PLANT_SIM},   {"hexa_leg_ctrl", HEXA_LEG_CTRL},
                {"hexa_task_space", HEXA_TASK_SPACE}, {"hexa_recorder", HEXA_RECORDER},
                {"hexa_deploy", HEXA_DEPLOY},         {"hexa_operator", HEXA_OPERATOR}};
  o.make_security = HEXA_MAKE_SECURITY;
  o.rig_file = HEXA_RIG_FILE;
  o.domain = 40 + getpid() % 50;
  o.supervisor_args = {"--trajectory", "z", "--periods", "1", "--autostart", "--exit-when-done"};
  // Lockstep: a tick may wait up to the lockstep timeout; the watchdog must be longer. Short
  // enough that several pings are due during the session (every half interval).
  o.lockstep_timeout_s = 10;
  o.watchdog_s = 12;
  return o;
}

// Runs the session until the supervisor finishes the trajectory; stops everything else.
// Returns the supervisor's exit (name empty on timeout).
hexa::deploy::ChildExit RunToEnd(LabSession& s, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  hexa::deploy::ChildExit sup;
  while (std::chrono::steady_clock::now() < end) {
    const auto ev = s.Wait(500ms);
    s.units().Poll();
    if (ev.kind == ProcessGroup::Event::kChildExited) {
      if (ev.exit.name == "hexa-supervisor") {
        sup = ev.exit;
        break;
      }
      ADD_FAILURE() << ev.exit.Describe() << " before the supervisor finished; logs in "
                    << s.work_dir() << "/run";
    }
    if (ev.kind == ProcessGroup::Event::kInterrupted) break;
  }
  for (const char* name : {"hexa-plant", "hexa-leg1", "hexa-leg2", "hexa-leg3", "hexa-leg4",
                           "hexa-leg5", "hexa-leg6", "hexa-leg4-standby", "hexa-leg5-standby",
                           "hexa-leg6-standby", "hexa-recorder"}) {
    s.Stop(name);
  }
  s.units().Poll();
  return sup;
}

// A lockstep recording of the z trajectory (one period): complete, nothing missing in any
// periodic stream, and bit-identical to the in-process simulation.
void ExpectLosslessAndSameAsInProcess(const std::string& mcap) {
  const auto info = hexa::recorder::Inspect(mcap);
  EXPECT_TRUE(info.complete);
  for (const auto& ch : info.channels) {
    if (ch.loss_analysed) {
      EXPECT_EQ(ch.missing, 0u) << ch.topic;
    }
  }
  hexa::testing::ExpectSameAsInProcess(hexa::recorder::ComputeSessionReport(mcap), hexa::PaperMotion::kZ, 1, 1);
}

class SecuredFiveHosts : public ::testing::Test {
 protected:
  void SetUp() override {
    if (geteuid() != 0) GTEST_SKIP() << "needs root to create network namespaces";
  }
};

// The secured multi-host session completes the z trajectory in
// lockstep with nothing lost, bit-identical to the in-process simulation (hence the same RMSE
// as the one-machine session, which tests/integration proves bit-identical too).
TEST_F(SecuredFiveHosts, LockstepSessionFromGeneratedUnitsIsLosslessAndBitIdentical) {
  std::string err;
  auto s = LabSession::Create(Options("ls"), err);
  ASSERT_TRUE(s) << err;
  // Every generated unit passes systemd-analyze verify (no warning at all), where available.
  if (access("/usr/bin/systemd-analyze", X_OK) == 0) {
    for (const auto& [host, units] : s->Plan()) {
      for (const auto& u : units) {
        const std::string path = s->generated_dir() + "/hosts/" + host + "/lib/systemd/system/" + u;
        std::string out;
        EXPECT_TRUE(hexa::deploy::RunShell("/usr/bin/systemd-analyze verify " + path, &out)) << out;
        EXPECT_EQ(out, "") << path;
      }
    }
  }
  // The generated configuration really is secured and pinned to the lab interface.
  const std::string xml = Slurp(s->DdsConfigOf("legs-a"));
  EXPECT_NE(xml.find("<Security>"), std::string::npos);
  EXPECT_NE(xml.find("name=\"" + s->lab().host("legs-a").veth + "\""), std::string::npos);

  ASSERT_TRUE(s->StartAll(err)) << err;
  const auto t0 = std::chrono::steady_clock::now();
  // The loop settings of the one-machine session, as the running processes got them from
  // their units: each process on its unit's CPUAffinity (the lab places them as hexa_session
  // does: plant and primary legs on the last CPU, supervisor, standbys and recorder on the
  // first), and every control process holding the CPU wake-up latency limit.
  while (!s->units().Seen("hexa-plant").ready && std::chrono::steady_clock::now() - t0 < 300s) {
    const auto ev = s->Wait(200ms);
    s->units().Poll();
    ASSERT_NE(ev.kind, ProcessGroup::Event::kChildExited) << ev.exit.Describe() << "; logs in " << s->work_dir();
  }
  ASSERT_TRUE(s->units().Seen("hexa-plant").ready) << "logs in " << s->work_dir();
  int pinned = 0;
  for (const auto& name : s->units().Names()) {
    const std::string affinity = s->units().Unit(name).Get("Service.CPUAffinity");
    if (!affinity.empty()) {
      ++pinned;
      EXPECT_EQ(s->units().AllowedCpus(name), affinity) << name;
    }
    if (name != "hexa-recorder") {
      EXPECT_NE(Slurp(s->units().LogOf(name)).find("CPU wake-up latency held at 0 us"), std::string::npos)
          << name << ": " << s->units().LogOf(name);
    }
  }
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  if (CPU_COUNT(&allowed) >= 2) {
    EXPECT_EQ(pinned, 12);  // every process of the lab
    EXPECT_NE(s->units().AllowedCpus("hexa-plant"), s->units().AllowedCpus("hexa-supervisor"));
    EXPECT_EQ(s->units().AllowedCpus("hexa-plant"), s->units().AllowedCpus("hexa-leg1"));
    EXPECT_EQ(s->units().AllowedCpus("hexa-supervisor"), s->units().AllowedCpus("hexa-leg4-standby"));
  }
  const auto sup = RunToEnd(*s, 400s);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(sup.name, "hexa-supervisor") << "timeout; logs in " << s->work_dir();
  EXPECT_EQ(sup.exit_code, 0) << sup.Describe() << "; logs in " << s->work_dir();

  // systemd's view: every unit reported READY when RUNNING, fed its watchdog from the loop
  // at least every half interval (+ margin), and said STOPPING when stopped.
  for (const auto& name : s->units().Names()) {
    const auto& seen = s->units().Seen(name);
    EXPECT_TRUE(seen.ready) << name;
    EXPECT_GE(seen.watchdog, static_cast<int>(wall_s / 6.0) - 2) << name << " over " << wall_s << " s";
    EXPECT_LT(seen.max_watchdog_gap_ns, static_cast<int64_t>(12e9)) << name;
    EXPECT_TRUE(seen.stopping) << name;
  }

  const std::string mcap = s->Recording();
  ASSERT_FALSE(mcap.empty()) << "no recording in " << s->work_dir() << "/rec";
  ExpectLosslessAndSameAsInProcess(mcap);
  // The recorder matched the six primaries' and three standbys' ValveCommand writers (reliable:
  // lockstep; SHARED ownership: the standbys' commands are recorded too) and refused nothing.
  const std::string rec_log = Slurp(s->units().LogOf("hexa-recorder"));
  // The trailing newline is a lookahead: consecutive lines each match.
  const std::regex valve_writer("\nmatched writer hexa_ValveCommand [0-9a-f]{32} reliable(?=\n)");
  EXPECT_EQ(std::distance(std::sregex_iterator(rec_log.begin(), rec_log.end(), valve_writer), std::sregex_iterator()), 9)
      << rec_log;
  EXPECT_EQ(rec_log.find("refused hexa_ValveCommand"), std::string::npos) << rec_log;
  std::printf("secured five-host lockstep session: %.1f s wall, recording %s\n", wall_s, mcap.c_str());
}

// The four-host layout (no standbys), from the sample deployment file
// deploy/deployments/four-hosts.textproto (its hosts and processes; the lab gives the
// interfaces, addresses and CPU placement): plant + supervisor, legs 1-3, legs 4-6,
// recorder. Secured lockstep: the z trajectory completes, nothing lost, bit-identical to the
// in-process simulation.
class SecuredFourHosts : public SecuredFiveHosts {};

TEST_F(SecuredFourHosts, LockstepSessionFromTheFourHostFileIsLosslessAndBitIdentical) {
  std::string err;
  LabSessionOptions o = Options("ls4");
  o.layout_file = HEXA_FOUR_HOSTS;
  auto s = LabSession::Create(o, err);
  ASSERT_TRUE(s) << err;
  std::vector<std::string> hosts;
  std::size_t units = 0;
  for (const auto& [host, u] : s->Plan()) {
    hosts.push_back(host);
    units += u.size();
  }
  EXPECT_EQ(hosts, (std::vector<std::string>{"recorder", "io-sup", "legs-a", "legs-b"}));
  EXPECT_EQ(units, 9u);  // plant, supervisor, 6 legs, recorder: no standby
  ASSERT_TRUE(s->StartAll(err)) << err;
  const auto t0 = std::chrono::steady_clock::now();
  const auto sup = RunToEnd(*s, 400s);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(sup.name, "hexa-supervisor") << "timeout; logs in " << s->work_dir();
  EXPECT_EQ(sup.exit_code, 0) << sup.Describe() << "; logs in " << s->work_dir();
  const std::string mcap = s->Recording();
  ASSERT_FALSE(mcap.empty()) << "no recording in " << s->work_dir() << "/rec";
  ExpectLosslessAndSameAsInProcess(mcap);
  std::printf("secured four-host lockstep session: %.1f s wall, recording %s\n", wall_s, mcap.c_str());
}

// A rogue participant on the control network, three kinds at once, during a secured
// lockstep session: without certificates, with a certificate from another CA, and with a
// valid leg-3 identity writing leg 4's ValveCommand (in leg 4's partition, and in its own)
// and LegSensors. None of its samples reaches the plant: the session stays bit-identical to
// the in-process simulation, the plant applied no rogue value (GroundTruth), and every
// attempt is logged (the rogue's own log, the plant's FAULT_COMMAND_REFUSED, Cyclone's refusals).
TEST_F(SecuredFiveHosts, RogueParticipantsReachNothing) {
  std::string err;
  auto o = Options("rg");
  // Two periods (~23 s simulated): the session outlasts the rogues' attempts.
  o.supervisor_args = {"--trajectory", "z", "--periods", "2", "--autostart", "--exit-when-done"};
  o.extra_hosts = {"intruder"};
  o.audit = true;
  o.standbys = false;
  auto s = LabSession::Create(o, err);
  ASSERT_TRUE(s) << err;
  const auto& intruder = s->lab().host("intruder");
  const std::string dir = s->work_dir();

  // The intruder's configurations: the legs-a configuration moved to its interface, with
  // (a) no Security section, (b) the security files of a deployment with its own CA, (c)
  // legs-a's own files (a stolen leg-3 identity).
  std::string xml = Slurp(s->DdsConfigOf("legs-a"));
  const std::string legs_a_veth = s->lab().host("legs-a").veth;
  xml = std::regex_replace(xml, std::regex("name=\"" + legs_a_veth + "\""), "name=\"" + intruder.veth + "\"");
  // The rogues keep no audit trace (it would share legs-a's trace file of leg 3).
  const std::regex tracing("    <Tracing>[^]*?</Tracing>\n");
  xml = std::regex_replace(xml, tracing, "");
  std::ofstream(dir + "/rogue_stolen.xml") << xml;
  const auto sec_begin = xml.find("    <!-- DDS Security"), sec_end = xml.find("</Security>");
  ASSERT_NE(sec_begin, std::string::npos);
  std::ofstream(dir + "/rogue_plain.xml")
      << xml.substr(0, sec_begin) + xml.substr(sec_end + std::string("</Security>\n").size());
  // Another CA: generate the same deployment again and sign it with a fresh CA.
  const std::string other = dir + "/other";
  {
    std::ofstream(dir + "/other.textproto") << s->deployment_text();
    ProcessGroup g;
    ASSERT_EQ(hexa::deploy::RunToCompletion(g, "gen", {HEXA_DEPLOY, "generate", dir + "/other.textproto", "--out", other, "--in-place"},
                                            dir + "/other_gen.log", 60s), 0);
    ASSERT_EQ(hexa::deploy::RunToCompletion(g, "sec", {HEXA_MAKE_SECURITY, other}, dir + "/other_sec.log", 120s), 0);
  }
  std::string foreign = Slurp(other + "/hosts/legs-a/etc/hexa/cyclonedds.xml");
  foreign = std::regex_replace(foreign, std::regex("name=\"" + legs_a_veth + "\""), "name=\"" + intruder.veth + "\"");
  foreign = std::regex_replace(foreign, tracing, "");
  std::ofstream(dir + "/rogue_foreign.xml") << foreign;

  ASSERT_TRUE(s->StartAll(err)) << err;
  // The rogues start once the plant has found its peers and write into the run. Not before:
  // the plant's unicast discovery lists only the deployment's hosts, so a rogue that starts
  // first is found only at its next periodic SPDP (about 8 s later, Cyclone's default
  // interval for a 10 s lease), after it has stopped writing.
  {
    const auto ready_by = std::chrono::steady_clock::now() + 120s;
    while (Slurp(s->units().LogOf("hexa-plant")).find("all peers ready") == std::string::npos) {
      ASSERT_LT(std::chrono::steady_clock::now(), ready_by) << "the plant never found its peers; logs in " << dir;
      const auto ev = s->Wait(100ms);
      ASSERT_NE(ev.kind, ProcessGroup::Event::kChildExited) << ev.exit.Describe() << "; logs in " << dir;
    }
  }
  const std::string domain = std::to_string(o.domain);
  const std::vector<std::string> rogue{HEXA_ROGUE, "--domain", domain, "--duration", "4", "--match-wait", "5"};
  auto start_rogue = [&](const std::string& name, const std::string& config, std::vector<std::string> extra) {
    hexa::deploy::ChildSpec c;
    c.name = name;
    c.argv = s->lab().InHost("intruder", rogue);
    c.argv.insert(c.argv.end(), extra.begin(), extra.end());
    c.env = {{"CYCLONEDDS_URI", "file://" + dir + "/" + config}, {"HEXA_IDENTITY", "leg3"}};
    c.log_path = dir + "/" + name + ".log";
    ASSERT_GT(s->group().Start(c, err), 0) << err;
  };
  start_rogue("rogue-plain", "rogue_plain.xml", {"--valve", "4:4,3:3"});
  start_rogue("rogue-foreign", "rogue_foreign.xml", {"--valve", "3:3,3:4"});
  start_rogue("rogue-leg3", "rogue_stolen.xml", {"--valve", "4:4,3:4", "--sensors"});

  // The session: rogue exits are expected, anything else failing is not.
  const auto end = std::chrono::steady_clock::now() + 400s;
  hexa::deploy::ChildExit sup;
  int rogues_done = 0;
  while (std::chrono::steady_clock::now() < end && sup.name.empty()) {
    const auto ev = s->Wait(500ms);
    if (ev.kind != ProcessGroup::Event::kChildExited) continue;
    if (ev.exit.name.rfind("rogue", 0) == 0) {
      EXPECT_EQ(ev.exit.exit_code, 0) << ev.exit.Describe();
      ++rogues_done;
    } else if (ev.exit.name == "hexa-supervisor") {
      sup = ev.exit;
    } else {
      ADD_FAILURE() << ev.exit.Describe() << "; logs in " << dir;
    }
  }
  // A rogue still writing when the trajectory ended: let it finish (its log has the totals).
  const auto rogue_end = std::chrono::steady_clock::now() + 30s;
  while (rogues_done < 3 && std::chrono::steady_clock::now() < rogue_end) {
    const auto ev = s->Wait(500ms);
    if (ev.kind == ProcessGroup::Event::kChildExited && ev.exit.name.rfind("rogue", 0) == 0) ++rogues_done;
  }
  s->StopAll();
  ASSERT_EQ(sup.name, "hexa-supervisor") << "timeout; logs in " << dir;
  EXPECT_EQ(sup.exit_code, 0) << sup.Describe();
  EXPECT_EQ(rogues_done, 3) << "a rogue did not finish before the session";

  // Each attempt is logged by the rogue with its outcome.
  const std::string plain = Slurp(dir + "/rogue-plain.log");
  const std::string foreign_log = Slurp(dir + "/rogue-foreign.log");
  const std::string leg3 = Slurp(dir + "/rogue-leg3.log");
  EXPECT_NE(plain.find("partition hexa.leg4 key leg 4: matched 0 readers"), std::string::npos) << plain;
  EXPECT_NE(foreign_log.find("partition hexa.leg3 key leg 3: matched 0 readers"), std::string::npos) << foreign_log;
  EXPECT_NE(foreign_log.find("partition hexa.leg3 key leg 4: matched 0 readers"), std::string::npos) << foreign_log;
  EXPECT_NE(leg3.find("ValveCommand writer in partition hexa.leg4 for leg 4: REFUSED"), std::string::npos) << leg3;
  EXPECT_NE(leg3.find("LegSensors writer: REFUSED"), std::string::npos) << leg3;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(leg3, m, std::regex("partition hexa.leg3 key leg 4: matched ([0-9]+) readers, wrote ([0-9]+)")))
      << leg3;
  EXPECT_GE(std::stoi(m[1]), 1) << "the stolen identity's writer in its own partition matched no reader";
  EXPECT_GT(std::stoll(m[2]), 1000);
  // ... by the plant (samples of leg 4 from leg 3's partition, by a participant without the
  // deployment's session key: refused, reported, counted) ...
  const std::string plant = Slurp(s->units().LogOf("hexa-plant"));
  EXPECT_NE(plant.find("FAULT_COMMAND_REFUSED: ValveCommand for leg 3 from a writer not of this session"),
            std::string::npos) << plant;
  EXPECT_NE(plant.find("partition 'hexa.leg3'"), std::string::npos) << plant;
  ASSERT_TRUE(std::regex_search(plant, m, std::regex("refused commands ([0-9]+)"))) << plant;
  EXPECT_GT(std::stoll(m[1]), 0);
  // ... and by Cyclone DDS in the secured processes: the foreign CA's handshake refused (in
  // every process log), the unauthenticated participant's endpoints refused (in the audit
  // trace, security.audit_dir).
  const std::string plant_log = Slurp(s->units().LogOf("hexa-plant"));
  EXPECT_NE(plant_log.find("handshake reply failed: Certificate not valid: error: certificate "
                           "signature failure; subject: /CN=leg3/O=HexaTaar/OU=lab"),
            std::string::npos)
      << "the plant's log does not show the foreign-CA participant refused";
  const std::string audit = Slurp(dir + "/audit/dds-plant.log");
  EXPECT_NE(audit.find("Non secure remote writer"), std::string::npos)
      << "the plant's DDS audit trace does not show the unauthenticated writer refused";

  // Nothing reached the plant: bit-identical to the in-process simulation, and no tick ever
  // applied the rogue's voltage.
  const std::string mcap = s->Recording();
  ASSERT_FALSE(mcap.empty());
  const auto report = hexa::recorder::ComputeSessionReport(mcap);
  for (const auto& applied : report.applied_valve_v)
    for (double v : applied) ASSERT_NE(v, kRogueVolts);
  hexa::testing::ExpectSameAsInProcess(report, hexa::PaperMotion::kZ, 2, 1);
}

}  // namespace
