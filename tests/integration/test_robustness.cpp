// Robustness at system level: a CSV trajectory of random bytes gives a clear
// rejection (FaultEvent, exit), never a recording the tools cannot read, a log line the size of
// the file, or a hang; a recorder killed mid-session leaves a recording the launcher recovers
// and reports on.
#include <dirent.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "hexa/recording/recording.hpp"
#include "process_group.hpp"
#include "scratch_dir.hpp"
#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

// Before the fix: the parser echoed the bytes into FaultEvent.detail, the recorder wrote them
// into a proto3 string, and `info`, `export` and `report` then failed on the recording.
TEST(BadInputs, RandomBytesCsvIsRejectedAndTheRecordingStaysReadable) {
  const std::string csv = ::testing::TempDir() + "/random_" + std::to_string(getpid()) + ".csv";
  {
    std::mt19937_64 rng(2024);
    std::string bytes = "\xff\xfe\xc0\xaf";
    for (int i = 0; i < 200000; ++i) bytes += static_cast<char>(rng() & 0xff);
    std::ofstream(csv, std::ios::binary) << bytes;
  }
  const auto run = RunSession("bad_csv", 77, {"--trajectory", csv});
  std::filesystem::remove(csv);
  EXPECT_NE(run.exit_code, 0) << "a rejected trajectory is not a completed session";
  ASSERT_TRUE(run.has_report) << Slurp(run.dir + "/session.log");
  // Nothing was tracked: the report says so instead of an RMSE of 0.000 in every cell.
  const std::string md = Slurp(run.dir + "/report.md");
  EXPECT_NE(md.find("Not tracked: the supervisor never reached TRACKING (final state HOLD)"),
            std::string::npos) << md.substr(0, 1500);
  EXPECT_EQ(md.find("| RMSE vs ground truth"), std::string::npos);
  const auto& r = run.report;
  EXPECT_TRUE(r.warnings.empty()) << "the recorder wrote strings that needed repair: "
                                  << r.warnings.front();
  bool rejected = false;
  for (const auto& f : r.faults) {
    if (f.find("supervisor") != std::string::npos &&
        f.find("FAULT_TRAJECTORY_REJECTED") != std::string::npos &&
        f.find("bad header") != std::string::npos) {
      rejected = true;
    }
    EXPECT_EQ(f.find("plant"), std::string::npos) << "the plant blamed a leg: " << f;
  }
  EXPECT_TRUE(rejected) << "no rejection FaultEvent";
  EXPECT_EQ(r.final_supervisor_state, "HOLD");
  // The launcher's own report step read the file too, and the recording is complete.
  EXPECT_TRUE(std::filesystem::exists(run.dir + "/report.md"));
  const auto info = hexa::recorder::Inspect(run.dir + "/session.mcap");
  EXPECT_TRUE(info.complete);
  EXPECT_TRUE(info.problems.empty()) << info.problems.front();
  // No log line echoes the 200 kB file.
  for (const char* log : {"supervisor.log", "session.log", "plant.log"}) {
    std::ifstream in(run.dir + "/" + log);
    for (std::string line; std::getline(in, line);) {
      EXPECT_LT(line.size(), 20000u) << log;
    }
  }
}

// pid of the running process whose command line contains `needle` (0 if none).
pid_t FindProcess(const std::string& needle) {
  DIR* proc = opendir("/proc");
  if (proc == nullptr) return 0;
  pid_t found = 0;
  while (dirent* e = readdir(proc)) {
    const pid_t pid = static_cast<pid_t>(std::atoi(e->d_name));
    if (pid <= 0) continue;
    std::string cmd = Slurp("/proc/" + std::string(e->d_name) + "/cmdline");
    for (char& c : cmd) if (c == '\0') c = ' ';
    if (cmd.find(needle) != std::string::npos) found = pid;
  }
  closedir(proc);
  return found;
}

// Before the fix the launcher's report step failed on the truncated file ("the file is
// truncated ... `hexa_recorder recover` rewrites it") and the others took ~10 s to stop one by
// one. Now it stops them together, recovers the recording and reports from the recovered copy.
TEST(Robustness, RecorderKilledMidSessionIsRecoveredAndReported) {
  const std::string dir = hexa::testing::ScratchDir("recorder_killed");
  hexa::deploy::ProcessGroup group;
  hexa::deploy::ChildSpec s{"session", {HEXA_SESSION}, {}, dir + "/launcher.console.log"};
  s.argv.insert(s.argv.end(), {"--trajectory", "combined", "--periods", "2", "--domain", "78",
                               "--out", dir, "--timeout", "240"});
  std::string err;
  ASSERT_GE(group.Start(s, err), 0) << err;
  const std::string mcap = dir + "/session.mcap";
  pid_t recorder = 0;
  for (int i = 0; i < 1200 && recorder == 0; ++i) {  // up to 120 s for the session to record
    std::error_code ec;
    if (std::filesystem::exists(mcap) && std::filesystem::file_size(mcap, ec) > 2'000'000) {
      recorder = FindProcess("hexa_recorder record --output " + mcap);
    }
    if (recorder == 0) usleep(100'000);
  }
  ASSERT_NE(recorder, 0) << "the recorder never wrote 2 MB\n" << Slurp(dir + "/session.log");
  ASSERT_EQ(kill(recorder, SIGKILL), 0);
  const auto ev = group.WaitEvent(std::chrono::seconds(300));
  ASSERT_EQ(ev.kind, hexa::deploy::ProcessGroup::Event::kChildExited);
  EXPECT_NE(ev.exit.exit_code, 0) << "a session that lost its recorder did not complete";
  const std::string log = Slurp(dir + "/session.log");
  EXPECT_NE(log.find("the recorder is gone: stopping the other processes together"), std::string::npos) << log;
  EXPECT_NE(log.find("recovered into"), std::string::npos) << log;
  EXPECT_EQ(log.find("report failed"), std::string::npos) << log;
  const auto recovered = hexa::recorder::Inspect(dir + "/session.recovered.mcap");
  EXPECT_TRUE(recovered.complete);
  EXPECT_GT(recovered.messages, 1000u);
  const std::string report = Slurp(dir + "/report.md");
  EXPECT_NE(report.find("recording: recovered"), std::string::npos) << report.substr(0, 400);
  std::filesystem::remove_all(dir);
}

}  // namespace
