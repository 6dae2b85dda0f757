// One session layout (deploy/session) for both ways of running a session: hexa_session's
// children and hexa_deploy generate's systemd units, for the same options, run the same
// processes with the same binaries, role arguments, reader counts, recorder QoS, stale-tick
// limit and SCHED_FIFO priorities.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "deployment.hpp"
#include "generate.hpp"
#include "launcher.hpp"
#include "hexa/services/scheduling.hpp"
#include "session_layout.hpp"

namespace {

using hexa::deploy::ChildSpec;
using hexa::session::ProcessSpec;
using Argv = std::vector<std::string>;

struct Case {
  bool realtime, recorder, standby;
};

std::string Name(const Case& c) {
  return std::string(c.realtime ? "realtime" : "lockstep") + (c.recorder ? "+recorder" : "") +
         (c.standby ? "+standbys" : "");
}

hexa::launcher::Options LauncherOptions(const Case& c) {
  hexa::launcher::Options o;
  o.mode = c.realtime ? "realtime" : "lockstep";
  o.recorder = c.recorder;
  o.standby = c.standby;
  o.trajectory = "combined";
  o.controller = "bssmc";
  o.profile = "realistic";
  o.rig = "/etc/hexa/rig.textproto";
  o.out_dir = "/tmp/session";
  o.domain = 7;
  o.stale_ticks = 9;
  o.rt_lease = "0.01";
  o.lockstep_lease = "0.2";
  o.cpu_latency_us = "0";
  o.rt_dds_event_thread = "normal";
  o.hold_timeout_text = "30";
  return o;
}

// The same session as a deployment: one host, and the standbys on a second (a standby must
// survive its primary's board).
std::string DeploymentText(const Case& c) {
  std::ostringstream os;
  os << "name: \"layout\"\ndomain_id: 7\nmode: " << (c.realtime ? "REALTIME" : "LOCKSTEP")
     << "\nrig_file: \"/etc/hexa/rig.textproto\"\ntiming { stale_ticks: 9"
     << (c.realtime ? "" : " watchdog_s: 30") << " }\n"
     << "host {\n  name: \"one\"\n  interface { name: \"eth1\" address: \"10.10.0.1/24\" }\n"
     << "  dds_interface: \"eth1\"\n  process { role: PLANT }\n  process { role: SUPERVISOR }\n";
  for (int leg = 1; leg <= 6; ++leg) os << "  process { role: LEG leg: " << leg << " }\n";
  if (c.recorder) os << "  process { role: RECORDER }\n";
  os << "}\n";
  if (c.standby) {
    os << "host {\n  name: \"two\"\n  interface { name: \"eth1\" address: \"10.10.0.2/24\" }\n"
       << "  dds_interface: \"eth1\"\n";
    for (int leg = 1; leg <= 6; ++leg) os << "  process { role: LEG leg: " << leg << " standby: true }\n";
    os << "}\n";
  }
  return os.str();
}

// The words of a unit's command: the recorder's runs through `/bin/sh -c "exec ..."`.
Argv Words(const Argv& exec_start) {
  if (exec_start.size() == 3 && exec_start[0] == "/bin/sh") {
    Argv words;
    std::istringstream in(exec_start[2]);
    for (std::string w; in >> w;)
      if (w != "exec") words.push_back(w);
    return words;
  }
  return exec_start;
}

std::string Basename(const std::string& path) { return path.substr(path.rfind('/') + 1); }

bool Contains(const Argv& argv, const Argv& run) {
  return run.empty() || std::search(argv.begin(), argv.end(), run.begin(), run.end()) != argv.end();
}

// The value after `option`, "(absent)" without it, "(flag)" when nothing follows.
std::string Value(const Argv& argv, const std::string& option) {
  const auto it = std::find(argv.begin(), argv.end(), option);
  if (it == argv.end()) return "(absent)";
  return it + 1 == argv.end() ? "(flag)" : *(it + 1);
}

std::string UnitKey(const std::string& unit_text, const std::string& key) {
  std::istringstream in(unit_text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key + "=", 0) == 0) return line.substr(key.size() + 1);
  return "";
}

class SessionLayoutTest : public ::testing::TestWithParam<Case> {};

TEST_P(SessionLayoutTest, LauncherAndGeneratedUnitsRunTheSameProcesses) {
  const Case c = GetParam();
  const hexa::launcher::Options o = LauncherOptions(c);
  hexa::launcher::Launch launch;
  launch.layout = hexa::session::BuildSessionLayout(hexa::launcher::LayoutOptionsOf(o));
  launch.mcap = o.out_dir + "/session.mcap";
  const std::vector<ChildSpec> children = hexa::launcher::BuildChildren(o, launch);

  const auto loaded = hexa::deploy::ParseDeployment(DeploymentText(c), "layout.textproto");
  ASSERT_TRUE(loaded.ok) << (loaded.errors.empty() ? "" : loaded.errors.front());
  const hexa::deploy::HostPaths paths{"/etc/hexa"};
  std::map<std::string, Argv> units;
  std::map<std::string, std::string> unit_texts;
  for (const auto& plan : hexa::deploy::PlanProcesses(loaded.deployment)) {
    if (!plan.has_unit) continue;
    units[plan.node] = Words(hexa::deploy::CommandLine(loaded.deployment, plan, paths));
    unit_texts[plan.node] = hexa::deploy::UnitFileText(loaded.deployment, plan, paths);
  }

  // The same processes: 1 plant, 1 supervisor, 6 legs, 6 standbys or none, the recorder.
  std::set<std::string> launched;
  for (const auto& child : children) launched.insert(child.name);
  std::set<std::string> generated;
  for (const auto& [node, argv] : units) generated.insert(node);
  EXPECT_EQ(launched, generated);
  EXPECT_EQ(launched.size(), 8u + (c.standby ? 6u : 0u) + (c.recorder ? 1u : 0u));

  for (const auto& child : children) {
    SCOPED_TRACE(child.name);
    const ProcessSpec* spec = launch.layout.Find(child.name);
    ASSERT_NE(spec, nullptr);
    ASSERT_EQ(units.count(child.name), 1u);
    const Argv& unit = units[child.name];
    ASSERT_FALSE(unit.empty());
    EXPECT_EQ(Basename(child.argv[0]), spec->binary);
    EXPECT_EQ(Basename(unit[0]), spec->binary);
    // The layout's role arguments, word for word, in both; with a standby on every leg the
    // plant waits for them before tick 0 in both.
    EXPECT_TRUE(Contains(child.argv, spec->args));
    EXPECT_TRUE(Contains(unit, spec->args));
    if (spec->role == hexa::session::Role::kPlant) {
      EXPECT_EQ(Contains(child.argv, {"--expect-standbys"}), c.standby);
      EXPECT_EQ(Contains(unit, {"--expect-standbys"}), c.standby);
    }
    if (!spec->verb.empty()) {
      EXPECT_EQ(child.argv.at(1), spec->verb);
      EXPECT_EQ(unit.at(1), spec->verb);
    }
    // Reader counts, QoS, role and the stale-tick limit: the same values (or absent in both).
    for (const char* option : {"--leg", "--valve-readers", "--pose-readers", "--legs",
                               "--stale-ticks", "--periodic-reliability"})
      EXPECT_EQ(Value(child.argv, option), Value(unit, option)) << option;
    for (const char* flag : {"--standby", "--expect-recorder", "--supervisor"})
      EXPECT_EQ(Contains(child.argv, {flag}), Contains(unit, {flag})) << flag;
    // Real time: the unit's SCHED_FIFO priority is the layout's; the launcher asks it for the
    // recorder (the control processes' own default is the same number).
    const std::string unit_priority = UnitKey(unit_texts[child.name], "CPUSchedulingPriority");
    if (c.realtime) {
      EXPECT_EQ(unit_priority, std::to_string(spec->rt_priority));
      EXPECT_EQ(Value(unit, "--rt-priority"), std::to_string(spec->rt_priority));
      if (spec->role == hexa::session::Role::kRecorder) {
        EXPECT_EQ(Value(child.argv, "--rt-priority"), unit_priority);
      }
    } else {
      EXPECT_EQ(unit_priority, "");
      EXPECT_EQ(spec->rt_priority, 0);
      EXPECT_EQ(Value(child.argv, "--rt-priority"), "(absent)");
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Modes, SessionLayoutTest,
                         ::testing::Values(Case{false, true, false}, Case{true, true, false},
                                           Case{true, true, true}, Case{false, false, true},
                                           Case{true, false, false}),
                         [](const auto& info) {
                           std::string n = Name(info.param);
                           std::replace(n.begin(), n.end(), '+', '_');
                           return n;
                         });

// The layout itself: start order (the supervisor before the legs, the plant last, knowing
// every other control process and the recorder) and the priorities of docs/performance.md.
TEST(SessionLayout, StartOrderPeersAndPriorities) {
  hexa::session::SessionOptions o;
  o.realtime = true;
  o.recorder = true;
  o.bridge = true;
  o.standby[2] = true;
  const auto layout = hexa::session::BuildSessionLayout(o);
  const std::vector<std::string> expected{"recorder", "bridge", "supervisor", "leg1", "leg2",
                                          "leg3", "leg3_standby", "leg4", "leg5", "leg6", "plant"};
  EXPECT_EQ(layout.Names(), expected);
  const auto* plant = layout.Find("plant");
  ASSERT_NE(plant, nullptr);
  const std::vector<std::string> plant_peers{"recorder", "supervisor", "leg1", "leg2", "leg3",
                                             "leg3_standby", "leg4", "leg5", "leg6"};
  EXPECT_EQ(plant->peers, plant_peers);  // not the bridge: a viewer
  EXPECT_EQ(layout.Find("leg3_standby")->peers, std::vector<std::string>{"supervisor"});
  EXPECT_EQ(layout.Find("leg3")->rt_priority, 80);
  EXPECT_EQ(layout.Find("supervisor")->rt_priority, 75);
  EXPECT_EQ(plant->rt_priority, 70);
  EXPECT_EQ(layout.Find("recorder")->rt_priority, 50);
  EXPECT_EQ(layout.Find("bridge")->rt_priority, 0);
  o.rt_sched = false;  // --no-rt-sched: SCHED_OTHER everywhere
  for (const auto& p : hexa::session::BuildSessionLayout(o).processes) EXPECT_EQ(p.rt_priority, 0) << p.name;
}

// The plant's --expect-standbys waits for a standby of every leg: a deployment (either
// mode) with a standby on each of the six legs writes it into the plant's unit; one with
// standbys on legs 4-6 only (the plant could never see leg 1's) does not.
TEST(SessionLayout, ThePlantUnitWaitsForStandbysOnlyWhenEveryLegHasOne) {
  for (const bool realtime : {false, true}) {
    for (const int first_standby : {1, 4}) {
      SCOPED_TRACE(std::string(realtime ? "realtime" : "lockstep") + ", standbys of legs " +
                   std::to_string(first_standby) + "-6");
      std::ostringstream os;
      os << "name: \"standbys\"\ndomain_id: 7\nmode: " << (realtime ? "REALTIME" : "LOCKSTEP")
         << "\nrig_file: \"/etc/hexa/rig.textproto\"\n"
         << "host { name: \"a\" interface { name: \"eth1\" address: \"10.10.0.1/24\" }"
         << " dds_interface: \"eth1\" process { role: PLANT } process { role: SUPERVISOR }";
      for (int leg = 1; leg <= 6; ++leg) os << " process { role: LEG leg: " << leg << " }";
      os << " }\nhost { name: \"b\" interface { name: \"eth1\" address: \"10.10.0.2/24\" }"
         << " dds_interface: \"eth1\"";
      for (int leg = first_standby; leg <= 6; ++leg)
        os << " process { role: LEG leg: " << leg << " standby: true }";
      os << " }\n";
      const auto loaded = hexa::deploy::ParseDeployment(os.str(), "standbys.textproto");
      ASSERT_TRUE(loaded.ok) << (loaded.errors.empty() ? "" : loaded.errors.front());
      bool found = false;
      for (const auto& plan : hexa::deploy::PlanProcesses(loaded.deployment)) {
        if (plan.node != "plant") continue;
        found = true;
        const Argv argv =
            hexa::deploy::CommandLine(loaded.deployment, plan, hexa::deploy::HostPaths{"/etc/hexa"});
        EXPECT_EQ(Contains(argv, {"--expect-standbys"}), first_standby == 1);
      }
      EXPECT_TRUE(found);
    }
  }
}

// --cpus-* auto: real time pins the control processes to the last CPU (the loop's wake-ups stay
// on one CPU) and the rest to the others; lockstep pins nothing, so that its normal-priority
// processes can leave a CPU that real-time loops take (docs/measurements/faults_under_load.md).
hexa::launcher::Options ParseSession(const std::string& mode) {
  const std::string out = ::testing::TempDir() + "/cpus_" + mode;
  std::vector<std::string> args = {"hexa_session", "--mode", mode, "--out", out};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  hexa::launcher::Options o;
  EXPECT_EQ(hexa::launcher::ParseOptions(static_cast<int>(argv.size()), argv.data(), o), -1);
  return o;
}

TEST(SessionCpus, AutoPinsRealTimeOnlyAndLockstepRunsOnEveryCpu) {
  const std::vector<int> cpus = hexa::sched::AllowedCpus();
  if (cpus.size() < 2) GTEST_SKIP() << "one CPU: auto pins nothing in either mode";
  const hexa::launcher::Options lockstep = ParseSession("lockstep");
  EXPECT_EQ(lockstep.cpus_control, "");
  EXPECT_EQ(lockstep.cpus_supervisor, "");
  EXPECT_EQ(lockstep.cpus_recorder, "");
  EXPECT_EQ(lockstep.cpus_standby, "");
  const hexa::launcher::Options realtime = ParseSession("realtime");
  EXPECT_EQ(realtime.cpus_control, std::to_string(cpus.back()));
  EXPECT_NE(realtime.cpus_recorder, "");
  EXPECT_EQ(realtime.cpus_supervisor, realtime.cpus_recorder);
}

}  // namespace
