// Whole lockstep sessions on the remote-board device with the emulator's injected link faults
// (hexa_board_emulator --link-fault, stepped once per command: deterministic). Lost datagrams
// (1 % and 5 % either way) are ticks without a sample: the session completes and tracks within
// 1.5x of the clean run. Frames with a bad CRC, an old protocol version, out of order, or a
// value out of its calibrated range are refused, each counted under its name as often as the
// emulator injected it (but for the frame after the plant's last read), the first logged with
// its cause; the session completes. The
// same fault on every frame is a lost board: FAULT_BOARD_LINK names the cause, the supervisor
// holds. Nothing is lost in the recording. In real time, the plant killed: the board's watchdog
// fires six ticks after the last command it took.
#include <signal.h>

#include <chrono>
#include <cmath>
#include <regex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

std::vector<std::string> Args(const std::vector<std::string>& link_faults) {
  std::vector<std::string> a = {"--device", "board", "--trajectory", "combined", "--periods", "1", "--seed", "3"};
  for (const std::string& f : link_faults) a.insert(a.end(), {"--board-arg", "--link-fault", "--board-arg", f});
  return a;
}

// The plant's count of what the emulator injected `injected` times: equal, but for the frame
// answering the plant's last command (the safe state it sends as it closes), which it no
// longer reads.
void ExpectCountedAsInjected(long long counted, long long injected, const std::string& what) {
  EXPECT_LE(counted, injected) << what;
  EXPECT_GE(counted, injected - 1) << what;
}

// A count in "name N" of a line matching `line_re` (-1: not found).
long long Count(const std::string& text, const std::string& line_re, const std::string& name) {
  std::smatch line;
  if (!std::regex_search(text, line, std::regex(line_re))) return -1;
  const std::string l = line[0];
  std::smatch m;
  if (!std::regex_search(l, m, std::regex("[ :]" + name + " ([0-9]+)"))) return 0;
  return std::stoll(m[1]);
}
// The plant's link counters (its end-of-run line) and the emulator's injections.
long long PlantCount(const hexa::testing::SessionRun& r, const std::string& verdict) {
  return Count(Slurp(r.dir + "/plant.log"), "board link: received [^;]*;", verdict);
}
long long InjectedCount(const hexa::testing::SessionRun& r, const std::string& what) {
  return Count(Slurp(r.dir + "/board.console.log"), "link faults injected: .*", what);
}

double PositionRmse(const hexa::recorder::SessionReport& r) {
  return std::sqrt(r.rmse_vs_measured[0] * r.rmse_vs_measured[0] + r.rmse_vs_measured[1] * r.rmse_vs_measured[1] +
                   r.rmse_vs_measured[2] * r.rmse_vs_measured[2]);
}
double LegRmse(const hexa::recorder::SessionReport& r) {
  double sum = 0.0;
  for (double e : r.leg_length_rmse_m) sum += e;
  return sum / 6.0;
}

void ExpectCompleteRecording(const hexa::recorder::SessionReport& r) {
  EXPECT_TRUE(r.complete_file);
  for (const auto& [topic, missing] : r.missing) EXPECT_EQ(missing, 0u) << topic;
}

TEST(BoardLinkFaultSession, LossOfOneAndFivePercentTracksWithinOneAndAHalfOfTheCleanRun) {
  const auto clean = RunSession("board_loss_0", 140, Args({}));
  ASSERT_EQ(clean.exit_code, 0) << Slurp(clean.dir + "/session.log");
  ASSERT_TRUE(clean.has_report);
  const double clean_position_m = PositionRmse(clean.report), clean_leg_m = LegRmse(clean.report);
  for (const auto& [percent, domain] : {std::pair{"1", 141}, std::pair{"5", 142}}) {
    SCOPED_TRACE(std::string(percent) + " % loss");
    const auto run = RunSession(std::string("board_loss_") + percent, domain, Args({std::string("drop:") + percent}));
    ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
    ASSERT_TRUE(run.has_report);
    const auto& r = run.report;
    EXPECT_EQ(r.final_supervisor_state, "IDLE");
    EXPECT_TRUE(r.faults.empty()) << r.faults.front();
    ExpectCompleteRecording(r);
    // Each frame the link lost is one tick without a sample (an empty datagram in step mode:
    // `short`); each lost command a tick the board took without one.
    const long long frames_dropped = InjectedCount(run, "frames dropped");
    const long long commands_dropped = InjectedCount(run, "commands dropped");
    EXPECT_GT(frames_dropped, 0);
    EXPECT_GT(commands_dropped, 0);
    ExpectCountedAsInjected(PlantCount(run, "short"), frames_dropped, "frames dropped");
    // Every one of them a tick without a sample, but for those of the bring-up (before tick 0)
    // and the answer to the closing command.
    const std::string plant_json = Slurp(run.dir + "/plant.json"), plant_log = Slurp(run.dir + "/plant.log");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(plant_json, m, std::regex("\"ticks_without_sample\": ([0-9]+)"))) << plant_json;
    const long long without_sample = std::stoll(m[1]);
    ASSERT_TRUE(std::regex_search(plant_log, m, std::regex("latch reset after ([0-9]+) safe-state commands")));
    const long long bring_up_commands = std::stoll(m[1]);
    EXPECT_LE(without_sample, frames_dropped);
    EXPECT_GE(without_sample, frames_dropped - bring_up_commands - 1);  // and the closing command's
    const double position_ratio = PositionRmse(r) / clean_position_m, leg_ratio = LegRmse(r) / clean_leg_m;
    std::printf("loss %s %%: frames dropped %lld, commands dropped %lld; position RMSE %.3f mm (clean %.3f mm, "
                "ratio %.3f); mean leg RMSE %.3f mm (clean %.3f mm, ratio %.3f)\n",
                percent, frames_dropped, commands_dropped, PositionRmse(r) * 1e3, clean_position_m * 1e3,
                position_ratio, LegRmse(r) * 1e3, clean_leg_m * 1e3, leg_ratio);
    EXPECT_LE(position_ratio, 1.5);
    EXPECT_LE(leg_ratio, 1.5);
  }
}

TEST(BoardLinkFaultSession, BadFramesAreRefusedCountedAndNamedAndTheSessionCompletes) {
  // Coprime periods: the faults fall on different ticks (the first due wins where they meet).
  const auto run = RunSession("board_bad_frames", 143,
                              Args({"bad-crc:97", "old-version:101", "reorder:103", "out-of-range:107"}));
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  EXPECT_EQ(run.report.final_supervisor_state, "IDLE");
  EXPECT_TRUE(run.report.faults.empty()) << run.report.faults.front();
  ExpectCompleteRecording(run.report);
  const std::string plant = Slurp(run.dir + "/plant.log");
  for (const auto& [injected, verdict] : {std::pair{"bad_crc", "bad_crc"}, std::pair{"old_version", "bad_version"},
                                          std::pair{"reordered", "old_sequence"},
                                          std::pair{"out_of_range", "out_of_range"}}) {
    const long long n = InjectedCount(run, injected);
    EXPECT_GT(n, 20) << injected;
    ExpectCountedAsInjected(PlantCount(run, verdict), n, verdict);
    EXPECT_NE(plant.find(std::string("a datagram from the board refused: ") + verdict), std::string::npos) << verdict;
  }
  // A held frame's tick is answered by an empty datagram: `short`, one per reordered frame.
  ExpectCountedAsInjected(PlantCount(run, "short"), InjectedCount(run, "reordered"), "short");
  EXPECT_NE(plant.find("refused: out_of_range (leg 1 potentiometer_m = 0.3734 out of its range; )"),
            std::string::npos) << plant;
  EXPECT_EQ(plant.find("FAULT_BOARD_LINK"), std::string::npos);
}

// The same fault on every frame from board tick 2000: after 20 ticks without an intact frame
// the board is lost, FAULT_BOARD_LINK names the refusal, the supervisor holds (exit 3), the
// plant exits 7, and the recording is complete.
TEST(BoardLinkFaultSession, EveryFrameRefusedIsALostBoardNamingItsCause) {
  struct Case {
    std::string fault, verdict, cause;
    int domain;
  };
  const std::vector<Case> cases = {
      {"old-version:1:2000", "bad_version", "bad_version 20", 144},
      {"out-of-range:1:2000", "out_of_range", "leg 1 potentiometer_m = 0.3734 out of its range", 145},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.fault);
    const auto run = RunSession("board_lost_" + c.verdict, c.domain, Args({c.fault}));
    EXPECT_EQ(run.exit_code, 3) << Slurp(run.dir + "/session.log");
    ASSERT_TRUE(run.has_report);
    const auto& r = run.report;
    std::string link_fault;
    for (const auto& f : r.faults)
      if (f.find("FAULT_BOARD_LINK") != std::string::npos && link_fault.empty()) link_fault = f;
    ASSERT_FALSE(link_fault.empty()) << ::testing::PrintToString(r.faults);
    EXPECT_NE(link_fault.find("no intact sensor frame for 20 ticks"), std::string::npos) << link_fault;
    EXPECT_NE(link_fault.find(c.cause), std::string::npos) << link_fault;
    EXPECT_EQ(r.final_supervisor_state, "HOLD");
    ExpectCompleteRecording(r);
    const std::string plant_json = Slurp(run.dir + "/plant.json");
    EXPECT_NE(plant_json.find("\"exit_code\": 7"), std::string::npos) << plant_json;
  }
}

// Real time: the plant process killed mid-trajectory (SIGKILL). The board, on its own clock,
// drives every valve to its safe value six ticks ("more than 5 ms") after the last command it
// took, and says so in its log; counted in board ticks, not on the host's clock.
TEST(BoardLinkFaultSession, PlantKilledTheBoardsWatchdogFiresSixTicksAfterItsLastCommand) {
  const std::string dir = hexa::testing::ScratchDir("board_plant_killed");
  hexa::deploy::ProcessGroup session;
  std::vector<std::string> argv = {HEXA_SESSION, "--mode", "realtime", "--hold-timeout", "1", "--domain", "146",
                                   "--out", dir, "--timeout", "240"};
  for (const auto& a : Args({})) argv.push_back(a);
  std::string err;
  ASSERT_GT(session.Start({"session", argv, {}, dir + "/launcher.console.log"}, err), 0) << err;
  pid_t plant = 0;
  for (int k = 0; k < 600 && plant == 0; ++k) {
    std::smatch m;
    const std::string plant_log = Slurp(dir + "/plant.log"), log = Slurp(dir + "/session.log");
    if (plant_log.find("all peers ready") != std::string::npos &&
        std::regex_search(log, m, std::regex("started plant \\(pid ([0-9]+)\\)")))
      plant = static_cast<pid_t>(std::stol(m[1]));
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_GT(plant, 0) << Slurp(dir + "/session.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(kill(plant, SIGKILL), 0);
  const auto ev = session.WaitEvent(std::chrono::seconds(300));
  ASSERT_EQ(ev.kind, hexa::deploy::ProcessGroup::Event::kChildExited);
  EXPECT_EQ(ev.exit.exit_code, 1) << Slurp(dir + "/session.log");  // a process of the session died
  const std::string board = Slurp(dir + "/board.console.log");
  std::smatch last;
  ASSERT_TRUE(std::regex_search(board, last, std::regex("last valid command at board tick ([0-9]+)"))) << board;
  const std::uint64_t last_command = std::stoull(last[1]);
  // The last firing: the one after the plant's last command.
  std::uint64_t fired = 0, since = 0, ticks = 0;
  const std::regex firing("board tick ([0-9]+): watchdog fired: no valid command for ([0-9]+) ticks \\(the last at "
                          "board tick ([0-9]+)");
  for (auto it = std::sregex_iterator(board.begin(), board.end(), firing); it != std::sregex_iterator(); ++it) {
    fired = std::stoull((*it)[1]);
    ticks = std::stoull((*it)[2]);
    since = std::stoull((*it)[3]);
  }
  ASSERT_GT(fired, 0u) << board;
  EXPECT_EQ(since, last_command) << board;
  EXPECT_EQ(ticks, 6u) << board;
  EXPECT_EQ(fired, last_command + 6) << board;
}

}  // namespace
