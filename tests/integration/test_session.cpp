// One command runs a whole session: a short session end to end in lockstep, through
// the launcher (eight control processes + recorder over DDS), checked against fixed bounds, and
// checked bit for bit against the in-process lockstep simulation of the same configuration.
#include <filesystem>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

TEST(Session, CombinedLockstepEndToEnd) {
  const auto run = RunSession("session", 72, {"--trajectory", "combined", "--periods", "1",
                                              "--seed", "3"});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  {
    SCOPED_TRACE("every output is written");
    for (const char* f : {"session.mcap", "report.md", "report.json", "pose.csv", "legs.csv",
                          "events.csv", "summary.png", "plots.json", "pose_tracking.png", "pose_error.png", "leg_lengths.png",
                          "valve_voltages.png", "path_3d.png", "plant.log", "leg1.log",
                          "supervisor.log", "session.log"}) {
      EXPECT_TRUE(std::filesystem::exists(run.dir + "/" + f)) << f;
    }
    const std::string json = Slurp(run.dir + "/report.json");
    for (const char* key : {"\"rmse_vs_ground_truth\"", "\"rmse_vs_measured_pose\"",
                            "\"leg_length_rmse_m\"", "\"deadline_misses\"",
                            "\"control_round_trip_latency_s\"", "\"wall_time_s\"",
                            "\"sim_time_s\""}) {
      EXPECT_NE(json.find(key), std::string::npos) << key;
    }
  }
  {
    SCOPED_TRACE("report figures within bounds");
    const auto& r = run.report;
    EXPECT_TRUE(r.complete_file);
    EXPECT_EQ(r.final_supervisor_state, "IDLE");
    EXPECT_EQ(r.pose_samples_tracking, 200u);  // one 1 s period of eq 49 at 5 ms
    // A working loop tracks the 8 cm circle to about a centimetre (docs/measurements/results.md has the
    // measured figures); a broken one is off by the full amplitude.
    for (int i = 0; i < 3; ++i) EXPECT_LT(r.rmse_vs_truth[i], 0.025) << "axis " << i;
    for (int i = 3; i < 6; ++i) EXPECT_LT(r.rmse_vs_truth[i], 0.06) << "axis " << i;
    for (int i = 0; i < 6; ++i) EXPECT_LT(r.leg_length_rmse_m[i], 0.03) << "leg " << i + 1;
    for (const auto& [topic, missing] : r.missing) EXPECT_EQ(missing, 0u) << topic;
    EXPECT_TRUE(r.faults.empty()) << r.faults.front();
    EXPECT_GT(r.latency_pairs, 6u * 3000u);
    EXPECT_GT(r.sim_time_s, 3.5);
  }
  {
    SCOPED_TRACE("each leg's adapted friction scale theta, recorded and in the report");
    // Measured on this run (seed 3, realistic profile, one period, 2026-11-28): end of the
    // tracking window 1.114 / 1.093 / 1.167 / 1.140 / 1.114 / 1.159 for legs 1-6. The realistic
    // plant's friction is 1.2 x the controllers' model, so a working adaptation ends above 1;
    // one that is off or not carried stays at 1 (or reads 0).
    for (int i = 0; i < 6; ++i) {
      const auto& f = run.report.friction_scale[i];
      EXPECT_GT(f.commands, 900u) << "leg " << i + 1;  // one 1 s period at 1 kHz, and more
      EXPECT_EQ(f.commands, f.bssmc_commands) << "leg " << i + 1;
      EXPECT_GE(f.end, 1.05) << "leg " << i + 1;
      EXPECT_LE(f.end, 1.40) << "leg " << i + 1;
      EXPECT_LE(f.min, f.end);
      EXPECT_GE(f.max, f.end);
    }
    const std::string md = Slurp(run.dir + "/report.md");
    EXPECT_NE(md.find("## Adapted friction scale theta over the tracking window (BS-SMC)"),
              std::string::npos);
    hexa::testing::ExpectSameFrictionScaleAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 3);
  }
  SCOPED_TRACE("the DDS session equals the in-process lockstep simulation bit for bit");
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 3);
}

// A rig overlay (three legs: friction and polytropic coefficients, a gravity load, a
// calibrated joint that moves the supervisor's kinematics) reaches the DDS services exactly
// as hexa_sim applies it: the session equals the in-process simulation with the overlay, and
// differs from the one without it.
TEST(Session, RigOverlayReachesTheServicesAsInProcess) {
  const std::string overlay = HEXA_EXAMPLE_OVERLAY;
  const auto run = RunSession("session_overlay", 73,
                              {"--trajectory", "combined", "--periods", "1", "--seed", "2",
                               "--rig-overlay", overlay});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const std::string legs = Slurp(run.dir + "/leg2.log") + Slurp(run.dir + "/supervisor.log");
  EXPECT_NE(legs.find("rig overlay " + overlay + " applied"), std::string::npos) << legs;
  EXPECT_EQ(Slurp(run.dir + "/plant.log").find("rig overlay"), std::string::npos)
      << "the launcher gives overlays to the controllers and the supervisor only";
  {
    SCOPED_TRACE("with the overlay: bit for bit");
    hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 2,
                                         hexa::LegControllerKind::kBsSmc, UINT64_MAX, {overlay});
  }
  // Without the overlay the in-process run differs: the check above can fail.
  const auto cfg = hexa::config::LoadSystemConfigOrThrow(hexa::config::DefaultRigFile());
  hexa::LockstepConfig lc;
  lc.rig = cfg.rig;
  lc.leg_controller = cfg.leg_controller;
  lc.supervisor = cfg.supervisor;
  lc.disturbance = cfg.profiles.at("realistic");
  lc.seed = 2;
  hexa::LockstepSimulation sim(lc);
  sim.Tick();
  const hexa::StartRequest start = sim.supervisor().PreparePaperStart(hexa::PaperMotion::kCombined, 1);
  bool differs = false;
  for (std::uint64_t n = 1; n + 1 < run.report.applied_valve_v.size() && !differs; ++n) {
    sim.Tick(n == 5 ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone,
             n == 5 ? &start : nullptr);
    for (int i = 0; i < 6; ++i) {
      differs = differs || run.report.applied_valve_v[n + 1][i] != sim.applied_valve_v()[i];
    }
  }
  EXPECT_TRUE(differs) << "the overlay changed nothing the plant applied";
}

// The supervisor's first inputs lost on the wire (a reader that had matched on one side only:
// without the repair tick 1 is never answered and the plant gives up after 10 s). The
// plant withholds them (fault injection) and must recover them with its re-ask, which also
// re-publishes the supervisor's inputs of the setpoint tick: the session completes and is
// still bit-identical to the in-process simulation.
TEST(Session, LockstepRecoversTheSupervisorsLostInputs) {
  const auto run = RunSession("session_lost_inputs", 76,
                              {"--trajectory", "combined", "--periods", "1", "--seed", "3",
                               "--plant-arg", "--lose-supervisor-inputs", "--plant-arg", "0"});
  const std::string plant = Slurp(run.dir + "/plant.log");
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  EXPECT_NE(plant.find("FAULT INJECTION: tick 0: the supervisor's inputs"), std::string::npos)
      << plant;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(plant, m, std::regex("re-asks, ([0-9]+) to the supervisor")))
      << plant;
  EXPECT_GE(std::stoull(m[1]), 1u) << plant;
  ASSERT_TRUE(run.has_report);
  for (const auto& [topic, missing] : run.report.missing) EXPECT_EQ(missing, 0u) << topic;
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 3);
}

}  // namespace
