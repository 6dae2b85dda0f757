// Bad user input at system level (issue 12): a CSV trajectory of random bytes must give a clear
// rejection (FaultEvent, exit), never a recording the tools cannot read, a log line the size of
// the file, or a hang.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "hexa/recorder/recording.hpp"
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

}  // namespace
