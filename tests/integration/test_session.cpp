// Issue "One command runs a whole session": a short session end to end in lockstep, through
// the launcher (nine processes + recorder over DDS), checked against fixed bounds, and
// checked bit for bit against the in-process lockstep simulation of the same configuration.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/recorder/report.hpp"
#include "process_group.hpp"

namespace {

using hexa::deploy::ChildSpec;
using hexa::deploy::ProcessGroup;
using namespace std::chrono_literals;

constexpr int kDomain = 72;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// One session, three checks (one process: a second session on the same domain id would
// meet this one).
TEST(Session, CombinedLockstepEndToEnd) {
  const std::string dir_ = ::testing::TempDir() + "/session_" + std::to_string(getpid());
  std::filesystem::create_directories(dir_);
  int exit_code_ = -1;
  {
    ProcessGroup group;
    std::string err;
    ChildSpec s{"session",
                {HEXA_SESSION, "--trajectory", "combined", "--periods", "1", "--seed", "3",
                 "--domain", std::to_string(kDomain), "--out", dir_, "--timeout", "240"},
                {},
                dir_ + "/launcher.console.log"};
    ASSERT_GT(group.Start(s, err), 0) << err;
    auto ev = group.WaitEvent(300s);
    ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited) << "session did not end";
    exit_code_ = ev.exit.signal == 0 ? ev.exit.exit_code : 128 + ev.exit.signal;
  }
  ASSERT_EQ(exit_code_, 0) << Slurp(dir_ + "/session.log");
  const auto report_ = hexa::recorder::ComputeSessionReport(dir_ + "/session.mcap");
  {
    SCOPED_TRACE("every output is written");
    for (const char* f :
         {"session.mcap", "report.md", "report.json", "pose.csv", "legs.csv", "pose_tracking.png",
          "pose_error.png", "leg_lengths.png", "valve_voltages.png", "path_3d.png", "plant.log",
          "leg1.log", "supervisor.log", "session.log"}) {
      EXPECT_TRUE(std::filesystem::exists(dir_ + "/" + f)) << f;
    }
    const std::string json = Slurp(dir_ + "/report.json");
    for (const char* key :
         {"\"rmse_vs_ground_truth\"", "\"rmse_vs_measured_pose\"", "\"leg_length_rmse_m\"",
          "\"deadline_misses\"", "\"control_round_trip_latency_s\"", "\"wall_time_s\"",
          "\"sim_time_s\""}) {
      EXPECT_NE(json.find(key), std::string::npos) << key;
    }
  }
  {
    SCOPED_TRACE("report figures within bounds");
    const auto& r = report_;
    EXPECT_TRUE(r.complete_file);
    EXPECT_EQ(r.final_supervisor_state, "IDLE");
    // One 1 s period of eq 49 at 5 ms: 200 tracking samples.
    EXPECT_EQ(r.pose_samples_tracking, 200u);
    // Bounds: a working loop tracks the 8 cm circle to about a centimetre (docs/results.md has
    // the measured figures); a broken one is off by the full amplitude.
    for (int i = 0; i < 3; ++i) EXPECT_LT(r.rmse_vs_truth[i], 0.025) << "axis " << i;
    for (int i = 3; i < 6; ++i) EXPECT_LT(r.rmse_vs_truth[i], 0.06) << "axis " << i;
    for (int i = 0; i < 6; ++i) EXPECT_LT(r.leg_length_rmse_m[i], 0.03) << "leg " << i + 1;
    for (const auto& [topic, missing] : r.missing) EXPECT_EQ(missing, 0u) << topic;
    EXPECT_TRUE(r.faults.empty()) << r.faults.front();
    EXPECT_GT(r.latency_pairs, 6u * 3000u);
    EXPECT_GT(r.sim_time_s, 3.5);
  }
  SCOPED_TRACE("the DDS session equals the in-process lockstep simulation bit for bit");
  const auto cfg = hexa::config::LoadSystemConfigOrThrow(hexa::config::DefaultRigFile());
  hexa::LockstepConfig lc;
  lc.rig = cfg.rig;
  lc.leg_controller = cfg.leg_controller;
  lc.supervisor = cfg.supervisor;
  lc.disturbance = cfg.profiles.at("realistic");
  lc.seed = 3;
  hexa::LockstepSimulation sim(lc);
  sim.Tick();  // tick 0: the supervisor latches the rest pose (as the service does)
  const hexa::StartRequest start =
      sim.supervisor().PreparePaperStart(hexa::PaperMotion::kCombined, 1);
  // GroundTruth(n + 1) carries the voltages the plant applied during step n.
  const auto& applied = report_.applied_valve_v;
  ASSERT_GT(applied.size(), 3000u);
  std::size_t compared = 0;
  for (std::uint64_t n = 1; n + 1 < applied.size(); ++n) {
    const bool start_now = n == 5;
    sim.Tick(start_now ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone,
             start_now ? &start : nullptr);
    for (int i = 0; i < 6; ++i) {
      ASSERT_EQ(applied[n + 1][i], sim.applied_valve_v()[i])
          << "tick " << n << " leg " << i + 1 << ": the DDS session and the in-process "
          << "simulation diverge";
    }
    ++compared;
  }
  EXPECT_GT(compared, 3000u);
}

}  // namespace
