// Lockstep judges progress, not the wall clock (docs/liveliness.md, "Liveliness in lockstep"): a
// process of the session stopped with SIGSTOP while the session starts or runs is a process
// that does not run for a while, as on a loaded machine, not a dead one. The session waits for
// it and completes, bit-identical to the in-process simulation. A process that ends is dead at
// once, named by the plant. Nothing here depends on the machine's speed: the stops are far
// longer than the liveliness lease (0.2 s) on any machine.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <dds/dds.h>
#include <gtest/gtest.h>

#include "session_util.hpp"

namespace {

using hexa::testing::Slurp;

// The pid of the session's child `name` (leg3, supervisor, recorder), or -1.
pid_t FindChild(pid_t session, const std::string& name) {
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string dir = entry.path().filename();
    if (dir.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = Slurp("/proc/" + dir + "/stat");
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    std::string state;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid != session) continue;
    std::string cmdline = Slurp("/proc/" + dir + "/cmdline");
    std::vector<std::string> argv;
    for (std::size_t at = 0; at < cmdline.size();) {
      const auto end = cmdline.find('\0', at);
      argv.push_back(cmdline.substr(at, end - at));
      at = end == std::string::npos ? cmdline.size() : end + 1;
    }
    if (argv.empty()) continue;
    const std::string exe = std::filesystem::path(argv[0]).filename();
    bool match = false;
    if (name == "supervisor") match = exe == "hexa_task_space";
    if (name == "recorder") match = exe == "hexa_recorder";
    if (name.rfind("leg", 0) == 0 && exe == "hexa_leg_ctrl") {
      for (std::size_t k = 0; k + 1 < argv.size(); ++k)
        if (argv[k] == "--leg" && argv[k + 1] == name.substr(3, 1)) match = true;
      for (const auto& a : argv)
        if (a == "--standby") match = false;
    }
    if (match) return static_cast<pid_t>(std::stol(dir));
  }
  return -1;
}

enum class When { kStartUp, kRunning, kMidRun };

// Runs hexa_session with `args`; stops its child `process` with SIGSTOP for `stop_s` (at
// start-up: as soon as it exists; running: as soon as it logs "<process> running", its DDS
// entities matched and the plant perhaps not ticking yet; mid-run: 0.5 s after the plant
// logged its first tick), then continues it, and waits for the session. `stopped` says
// whether the stop happened.
hexa::testing::SessionRun RunWithStop(const std::string& name, int domain,
                                      std::vector<std::string> args, const std::string& process,
                                      When when, double stop_s, bool& stopped) {
  using Clock = std::chrono::steady_clock;
  hexa::testing::SessionRun run;
  run.dir = hexa::testing::ScratchDir(name);
  stopped = false;
  hexa::deploy::ProcessGroup group;
  hexa::deploy::ChildSpec s{"session", {HEXA_SESSION}, {}, run.dir + "/launcher.console.log"};
  s.argv.insert(s.argv.end(), args.begin(), args.end());
  s.argv.insert(s.argv.end(), {"--domain", std::to_string(domain), "--out", run.dir,
                               "--timeout", "240"});
  std::string err;
  const pid_t session = group.Start(s, err);
  if (session < 0) {
    ADD_FAILURE() << err;
    return run;
  }
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  pid_t pid = -1;
  while (pid < 0 && Clock::now() < deadline && group.Running("session")) {
    pid = FindChild(session, process);
    if (pid < 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (pid > 0 && when == When::kRunning) {
    while (Clock::now() < deadline && Slurp(run.dir + "/" + process + ".log")
                                              .find(process + " running") == std::string::npos)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (pid > 0 && when == When::kMidRun) {
    while (Clock::now() < deadline &&
           Slurp(run.dir + "/plant.log").find("ticking in") == std::string::npos)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  if (pid > 0 && group.Running("session") && kill(pid, SIGSTOP) == 0) {
    stopped = true;
    std::this_thread::sleep_for(std::chrono::duration<double>(stop_s));
    kill(pid, SIGCONT);
  }
  const auto ev = group.WaitEvent(std::chrono::seconds(300));
  if (ev.kind != hexa::deploy::ProcessGroup::Event::kChildExited) {
    ADD_FAILURE() << "session did not end in time";
    return run;
  }
  run.exit_code = ev.exit.signal == 0 ? ev.exit.exit_code : 128 + ev.exit.signal;
  if (std::filesystem::exists(run.dir + "/session.mcap")) {
    run.report = hexa::recorder::ComputeSessionReport(run.dir + "/session.mcap");
    run.has_report = true;
  }
  return run;
}

std::string Logs(const hexa::testing::SessionRun& run) {
  return Slurp(run.dir + "/session.log") + "\n--- plant.log (tail)\n" +
         [&] {
           const std::string p = Slurp(run.dir + "/plant.log");
           return p.size() > 4000 ? p.substr(p.size() - 4000) : p;
         }();
}

// The session completed, recorded every sample and equals the in-process simulation.
void ExpectCompletedBitIdentical(const hexa::testing::SessionRun& run, std::uint64_t seed) {
  ASSERT_EQ(run.exit_code, 0) << Logs(run);
  ASSERT_TRUE(run.has_report);
  EXPECT_TRUE(run.report.faults.empty()) << run.report.faults.front();
  for (const auto& [topic, missing] : run.report.missing) EXPECT_EQ(missing, 0u) << topic;
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, seed);
}

const std::vector<std::string> kCombined{"--trajectory", "combined", "--periods", "1", "--seed", "4"};

// A leg controller stopped for 0.6 s (three leases) mid-run: its lease lapses, the plant waits
// for it. Before, the plant judged the leg dead (FAULT_LIVELINESS_LOST) and the session ended
// in HOLD.
TEST(LockstepStalls, LegStoppedMidRunIsWaitedForAndTheRunIsBitIdentical) {
  bool stopped = false;
  const auto run = RunWithStop("stall_leg_midrun", 93, kCombined, "leg3", When::kMidRun, 0.6, stopped);
  ASSERT_TRUE(stopped);
  ExpectCompletedBitIdentical(run, 4);
  EXPECT_NE(Slurp(run.dir + "/plant.log").find("leg 3's lease lapsed"), std::string::npos)
      << "the stop was not seen: it did not test anything";
}

// The supervisor stopped for 3 s mid-run: every leg waits for its setpoint; nothing is stale
// in lockstep. Before, the legs took its lapsed lease for a crash and held on
// FAULT_SETPOINT_STALE ("the supervisor's writer is gone").
TEST(LockstepStalls, SupervisorStoppedMidRunIsWaitedForAndTheRunIsBitIdentical) {
  bool stopped = false;
  const auto run = RunWithStop("stall_sup_midrun", 94, kCombined, "supervisor", When::kMidRun, 3.0, stopped);
  ASSERT_TRUE(stopped);
  ExpectCompletedBitIdentical(run, 4);
}

// A leg controller stopped for 3 s as soon as it says it runs (its writer exists, it has not
// written yet; the plant may still be waiting for the others): the session starts, or goes on,
// when it runs again. Before, a writer whose lease lapsed before its first write was never seen
// alive again: the plant gave up after 30 s ("peers not ready", exit 4), or, if it was ticking
// already, dropped the leg (FAULT_LIVELINESS_LOST at tick 0).
TEST(LockstepStalls, LegStoppedDuringStartUpStartsAndTheRunIsBitIdentical) {
  bool stopped = false;
  const auto run = RunWithStop("stall_leg_startup", 95, kCombined, "leg2", When::kRunning, 3.0, stopped);
  ASSERT_TRUE(stopped);
  ExpectCompletedBitIdentical(run, 4);
}

// The recorder stopped for 3 s mid-run: the plant's recorder sync waits for it (it exists), so
// that the loop does not outrun the writers' history and the recording loses nothing.
TEST(LockstepStalls, RecorderStoppedMidRunLosesNothing) {
  bool stopped = false;
  const auto run = RunWithStop("stall_rec_midrun", 96, kCombined, "recorder", When::kMidRun, 3.0, stopped);
  ASSERT_TRUE(stopped);
  ExpectCompletedBitIdentical(run, 4);
}

// A leg controller that dies in lockstep (SIGKILL, no standby) is dead at once: the launcher
// gave the plant its process id, and the plant names the ended process at the tick it did not
// answer, without waiting for a lease or the participant's 10 s.
TEST(LockstepStalls, CrashedLegIsAnEndedProcessNamedAtTheTickItDidNotAnswer) {
  auto args = kCombined;
  args.insert(args.end(), {"--fault", "3:crash:1.0"});
  const auto run = hexa::testing::RunSession("stall_crash", 97, args);
  EXPECT_EQ(run.exit_code, 3) << Logs(run);
  ASSERT_TRUE(run.has_report) << Logs(run);
  std::string first;
  for (const auto& f : run.report.faults)
    if (f.rfind("plant: leg 3", 0) == 0) {
      first = f;
      break;
    }
  EXPECT_NE(first.find("FAULT_WRITER_GONE"), std::string::npos) << first;
  EXPECT_NE(first.find("process ended"), std::string::npos) << first;
  EXPECT_NE(first.find(" tick 1000 "), std::string::npos) << first;
  EXPECT_EQ(run.report.final_supervisor_state, "HOLD");
  // Identical to the in-process simulation up to the crash.
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 4,
                                       hexa::LegControllerKind::kBsSmc, 1000);
}

// Another session on the domain (here: one participant of this test) is refused before any
// process starts: two sessions on one domain would read and command each other.
TEST(SessionDomain, ADomainInUseIsRefusedWithAMessage) {
  setenv("CYCLONEDDS_URI", (std::string("file://") + HEXA_LOOPBACK_CONFIG).c_str(), 1);
  const dds_entity_t other = dds_create_participant(98, nullptr, nullptr);
  ASSERT_GT(other, 0) << dds_strretcode(other);
  const auto run = hexa::testing::RunSession("domain_in_use", 98, kCombined);
  dds_delete(DDS_CYCLONEDDS_HANDLE);
  EXPECT_EQ(run.exit_code, 2) << Slurp(run.dir + "/session.log");
  const std::string log = Slurp(run.dir + "/session.log");
  EXPECT_NE(log.find("DDS domain 98 is in use"), std::string::npos) << log;
  EXPECT_EQ(log.find("started plant"), std::string::npos) << "no process may start: " << log;
}

// A session whose participants discover by unicast only, with fixed participant indices (every
// secured session, docs/security.md), never answers the probe's multicast discovery: the ports
// its participants bound show it, and the session is refused naming the process holding them.
TEST(SessionDomain, AUnicastOnlySessionOnTheDomainIsRefusedNamingItsProcess) {
  const char* unicast_only =
      "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\" "
      "multicast=\"false\"/></Interfaces><AllowMulticast>false</AllowMulticast></General>"
      "<Discovery><ParticipantIndex>auto</ParticipantIndex><Peers><Peer address=\"127.0.0.1\"/>"
      "</Peers></Discovery></Domain></CycloneDDS>";
  const dds_entity_t domain = dds_create_domain(98, unicast_only);
  ASSERT_GT(domain, 0) << dds_strretcode(domain);
  const dds_entity_t other = dds_create_participant(98, nullptr, nullptr);
  ASSERT_GT(other, 0) << dds_strretcode(other);
  const auto run = hexa::testing::RunSession("domain_in_use_unicast", 98, kCombined);
  dds_delete(DDS_CYCLONEDDS_HANDLE);
  EXPECT_EQ(run.exit_code, 2) << Slurp(run.dir + "/session.log");
  const std::string log = Slurp(run.dir + "/session.log");
  EXPECT_NE(log.find("DDS domain 98 is in use (0 participant(s) discovered, 2 of its participant ports bound by "),
            std::string::npos) << log;
  EXPECT_NE(log.find("(pid " + std::to_string(getpid()) + ")"), std::string::npos) << log;
  EXPECT_EQ(log.find("started plant"), std::string::npos) << "no process may start: " << log;
}

}  // namespace
