// Safety at system level (docs/design.md "Safety"): faults injected into leg-controller
// processes are detected, the plant closes the valve, the supervisor holds; a hot standby
// takes over without the platform noticing.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

bool AnyFault(const hexa::recorder::SessionReport& r, const std::string& needle1,
              const std::string& needle2 = "") {
  for (const auto& f : r.faults)
    if (f.find(needle1) != std::string::npos &&
        (needle2.empty() || f.find(needle2) != std::string::npos))
      return true;
  return false;
}

std::string Faults(const hexa::recorder::SessionReport& r) {
  std::string s;
  for (const auto& f : r.faults) s += f + "\n";
  return s;
}

// Lockstep, deterministic: leg 3 starts writing NaN / 42 V at t = 1 s.
TEST(Faults, GarbageCommandsAreNulledReportedAndTheSupervisorHolds) {
  const auto run = RunSession("fault_garbage", 99, {"--trajectory", "combined", "--periods", "1",
                                                    "--fault", "3:garbage:1.0"});
  EXPECT_NE(run.exit_code, 0) << "a session that ends in HOLD must not report success";
  ASSERT_TRUE(run.has_report) << Slurp(run.dir + "/session.log");
  const auto& r = run.report;
  EXPECT_TRUE(AnyFault(r, "plant: leg 3", "FAULT_COMMAND_NOT_FINITE") ||
              AnyFault(r, "plant: leg 3", "FAULT_COMMAND_OUT_OF_RANGE"))
      << Faults(r);
  EXPECT_TRUE(AnyFault(r, "supervisor:")) << Faults(r);
  EXPECT_EQ(r.final_supervisor_state, "HOLD");
  // One report when the episode starts and a reminder at the status rate (every 100 ticks),
  // not one per tick as the check flips between NaN and out of range.
  std::size_t leg3_events = 0;
  for (const auto& f : r.faults) leg3_events += f.rfind("plant: leg 3 ", 0) == 0 ? 1 : 0;
  const std::size_t ticks_after = r.applied_valve_v.size() - 1000;
  EXPECT_GE(leg3_events, 1u);
  EXPECT_LE(leg3_events, 2 + ticks_after / 100) << Faults(r);
  // From the first bad tick on, the plant applied the null voltage to leg 3, and every
  // voltage it applied was finite and in range.
  const std::size_t first_bad = 1000 + 1;  // command of tick 1000 applied during step 1000
  ASSERT_GT(r.applied_valve_v.size(), first_bad + 900);  // the supervisor holds ~1 s
  for (std::size_t n = 1; n < r.applied_valve_v.size(); ++n) {
    for (int i = 0; i < 6; ++i) {
      const double v = r.applied_valve_v[n][i];
      ASSERT_TRUE(std::isfinite(v) && v >= 0.0 && v <= 10.0) << "tick " << n << " leg " << i + 1
                                                            << " (lockstep loses no sample)";
    }
    if (n >= first_bad) {
      ASSERT_EQ(r.applied_valve_v[n][2], 5.0) << "tick " << n;
    }
  }
}

// Lockstep: the primary controller of leg 2 dies (SIGKILL) at t = 1 s while a hot standby
// runs the same law on the same inputs. Exclusive ownership hands the valve to the standby;
// the plant re-asks the silent leg for the tick; the session completes without a fault.
// The whole session, after the crash too, is bit-identical to the fault-free in-process
// simulation: lockstep does not wait for standbys, but a lockstep leg controller queues every
// tick (64-deep sensor reader, ring of 16 setpoints) and answers in tick order, so the standby
// computed every tick the primary did (docs/architecture.md, "Hot standby").
TEST(Faults, HotStandbyTakesOverACrashedPrimaryWithoutAFault) {
  const auto run = RunSession("fault_standby", 74, {"--trajectory", "combined", "--periods", "1",
                                                    "--seed", "2", "--standby",
                                                    "--fault", "2:crash:1.0"});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const auto& r = run.report;
  EXPECT_EQ(r.final_supervisor_state, "IDLE");
  EXPECT_TRUE(r.faults.empty()) << Faults(r);
  // No FaultEvent names the take-over, but the report does.
  ASSERT_EQ(r.takeovers.size(), 1u);
  EXPECT_EQ(r.takeovers[0].rfind("leg 2: the hot standby drives the valve from tick ", 0), 0u)
      << r.takeovers[0];
  EXPECT_NE(Slurp(run.dir + "/report.md").find("- take-over (no FaultEvent): leg 2: "),
            std::string::npos);
  EXPECT_EQ(r.pose_samples_tracking, 200u);
  for (int i = 0; i < 3; ++i) EXPECT_LT(r.rmse_vs_truth[i], 0.025) << "axis " << i;
  for (int i = 0; i < 6; ++i) EXPECT_LT(r.leg_length_rmse_m[i], 0.03) << "leg " << i + 1;
  // Leg 2 kept being driven after the crash: its applied voltage is not stuck at null.
  int driven = 0;
  for (std::size_t n = 1100; n < r.applied_valve_v.size(); ++n)
    driven += std::abs(r.applied_valve_v[n][1] - 5.0) > 0.05 ? 1 : 0;
  EXPECT_GT(driven, 500);
  hexa::testing::ExpectSameAsInProcess(r, hexa::PaperMotion::kCombined, 1, 2,
                                       hexa::LegControllerKind::kBsSmc);
  // --cpus-* auto pins nothing in lockstep: its processes run at normal priority and must be
  // free to leave a CPU that real-time loops take (docs/measurements/faults_under_load.md). Real time
  // pins (SessionCpus.AutoPinsRealTimeOnlyAndLockstepRunsOnEveryCpu).
  for (const std::string name : {"leg1", "leg2_standby", "leg6", "leg6_standby", "supervisor", "plant"}) {
    const std::string log = Slurp(run.dir + "/" + name + ".log");
    ASSERT_FALSE(log.empty()) << name;
    EXPECT_EQ(log.find("CPU affinity: "), std::string::npos) << name << " pinned in lockstep: " << log;
  }
}

// First fault line whose text contains `needle`; "" if none.
std::string FindFault(const hexa::recorder::SessionReport& r, const std::string& needle) {
  for (const auto& f : r.faults)
    if (f.find(needle) != std::string::npos) return f;
  return "";
}

// The tick a fault line names ("source: leg N tick T REASON: detail").
std::uint64_t TickOf(const std::string& fault_line) {
  const auto at = fault_line.find(" tick ");
  return at == std::string::npos ? 0 : std::stoull(fault_line.substr(at + 6));
}

// A fault session in lockstep: 1 period of the combined trajectory, the fault at t = 1 s
// (in the blend, the platform moving). Lockstep: nothing here depends on the machine's speed.
hexa::testing::SessionRun RunFaultSession(const std::string& name, int domain,
                                          std::vector<std::string> fault_args) {
  std::vector<std::string> args{"--trajectory", "combined", "--periods", "1"};
  args.insert(args.end(), fault_args.begin(), fault_args.end());
  return RunSession(name, domain, args);
}

// A lockstep fault session that must end held after a fault: exit 3, the supervisor in
// HOLD, and the first FaultEvent line containing `source` ("plant: leg 3") names `reason`.
// Returns that line ("" after a failure).
std::string ExpectHeldAfter(const hexa::testing::SessionRun& run, const std::string& source,
                            const std::string& reason) {
  EXPECT_EQ(run.exit_code, 3) << hexa::testing::Slurp(run.dir + "/session.log");
  EXPECT_TRUE(run.has_report) << hexa::testing::Slurp(run.dir + "/session.log");
  if (!run.has_report) return "";
  EXPECT_EQ(run.report.final_supervisor_state, "HOLD");
  const std::string f = FindFault(run.report, source);
  EXPECT_NE(f.find(reason), std::string::npos) << Faults(run.report);
  return f.find(reason) == std::string::npos ? "" : f;
}

// Lockstep, no standby: leg 3's control thread hangs at t = 1 s (tick 1000, before answering).
// Its liveliness is asserted by the control loop (MANUAL_BY_TOPIC), so it lapses; the plant
// names the cause, stops awaiting the leg (valve at null) and keeps ticking; the supervisor
// holds; the session ends "held after a fault" (exit 3). Before this, lockstep waited for the
// 10 s lockstep timeout, the supervisor never held and the session ended in TRACKING.
TEST(Faults, LockstepHangIsLivelinessLostTheLegIsDroppedAndTheSupervisorHolds) {
  const auto run = RunFaultSession("fault_hang_ls", 84, {"--fault", "3:hang:1.0"});
  const std::string first = ExpectHeldAfter(run, "plant: leg 3", "FAULT_LIVELINESS_LOST");
  if (first.empty()) return;
  const auto& r = run.report;
  EXPECT_EQ(TickOf(first), 1000u) << first;  // lockstep: the tick the leg did not answer
  // The supervisor holds at one of its next ticks (it takes faults every tick), not when its
  // main thread next wakes while lockstep runs on (then the platform went on moving with leg
  // 3 frozen). 50 ticks leave room for a FaultEvent repaired by a retransmission.
  const std::string held = FindFault(r, "supervisor: leg 3");
  ASSERT_NE(held.find("FAULT_LIVELINESS_LOST"), std::string::npos) << Faults(r);
  EXPECT_LE(TickOf(held), 1050u) << held;
  EXPECT_FALSE(AnyFault(r, "FAULT_COMMAND_DEADLINE_MISSED")) << "the 10 s timeout, not liveliness";
  // The plant kept ticking (the supervisor holds 1 s before the session ends) with leg 3 at
  // null from the step of tick 1000 on, and was the in-process simulation's until then.
  ASSERT_GT(r.applied_valve_v.size(), 1900u);
  for (std::size_t n = 1001; n < r.applied_valve_v.size(); ++n)
    ASSERT_EQ(r.applied_valve_v[n][2], 5.0) << "tick " << n;
  hexa::testing::ExpectSameAsInProcess(r, hexa::PaperMotion::kCombined, 1, 1,
                                       hexa::LegControllerKind::kBsSmc, 1000);
}

// Lockstep with a hot standby: the primary of `leg` suffers `kind` at t = 1 s. The session must
// complete without a fault, bit-identical to the fault-free in-process run.
void ExpectStandbyTakesOverWithoutAFault(const std::string& name, int domain, int leg,
                                         const std::string& kind, std::uint64_t seed) {
  const auto run = RunFaultSession(name, domain, {"--seed", std::to_string(seed), "--standby",
                                                  "--fault", std::to_string(leg) + ":" + kind + ":1.0"});
  ASSERT_EQ(run.exit_code, 0) << hexa::testing::Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const auto& r = run.report;
  EXPECT_TRUE(r.faults.empty()) << Faults(r);
  EXPECT_EQ(r.final_supervisor_state, "IDLE");
  hexa::testing::ExpectSameAsInProcess(r, hexa::PaperMotion::kCombined, 1, seed,
                                       hexa::LegControllerKind::kBsSmc);
}

// Leg 2's primary goes silent (computes, publishes nothing). Its loop no longer asserts
// liveliness when an answer it computed was not published, so the lease lapses and
// ownership passes to the standby, which answers the plant's re-ask. Before this (AUTOMATIC
// liveliness in lockstep), a silent or hung primary was never replaced.
TEST(Faults, LockstepSilentPrimaryIsReplacedByItsStandbyWithoutAFault) {
  ExpectStandbyTakesOverWithoutAFault("fault_silence_sb", 50, 2, "silence", 3);
}

// Leg 5's primary hangs (its control thread stops in the data callback, holding the control
// lock). Before this its AUTOMATIC liveliness was kept by Cyclone's threads and the standby
// never took over (the 10 s lockstep timeout ended the session).
TEST(Faults, LockstepHungPrimaryIsReplacedByItsStandbyWithoutAFault) {
  ExpectStandbyTakesOverWithoutAFault("fault_hang_sb", 92, 5, "hang", 2);
}

// Lockstep: leg 4 takes 5 ms more per cycle from t = 1 s. Lockstep waits for it (the results
// are right, only late), but its compute time per cycle is over the 0.5 ms budget: after 20
// cycles in a row the plant reports FAULT_COMPUTE_OVERRUN and the supervisor holds. Before,
// `slow` tested nothing in lockstep.
TEST(Faults, LockstepSlowLegIsAComputeOverrun) {
  const auto run = RunFaultSession("fault_slow_ls", 51, {"--fault", "4:slow:1.0"});
  const std::string f = ExpectHeldAfter(run, "plant: leg 4", "FAULT_COMPUTE_OVERRUN");
  if (f.empty()) return;
  EXPECT_GE(TickOf(f), 1019u);  // the 20th slow cycle answers tick 1019
  EXPECT_LE(TickOf(f), 1021u);
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 1,
                                       hexa::LegControllerKind::kBsSmc, 1019);
}

// Rig faults injected into the plant (docs/faults.md): each is detected by the component that
// can see it, named, and held.
TEST(Faults, DeadPressureSensorIsSensorInvalidFromItsLeg) {
  const auto run = RunFaultSession("fault_pdead", 52, {"--plant-fault", "pressure-dead:2:1.0"});
  const std::string f = ExpectHeldAfter(run, "leg2: leg 2", "FAULT_SENSOR_INVALID");
  if (f.empty()) return;
  const auto& r = run.report;
  EXPECT_NE(f.find("cap pressure"), std::string::npos) << f;
  EXPECT_EQ(TickOf(f), 1002u);  // held from tick 1000, reported at the third held tick
  for (std::size_t n = 1001; n < r.applied_valve_v.size(); ++n)
    ASSERT_EQ(r.applied_valve_v[n][1], 5.0) << "tick " << n;  // the leg closed its valve
}

TEST(Faults, SupplyLossIsSupplyPressureLowAndEveryValveCloses) {
  const auto run = RunFaultSession("fault_supply", 88, {"--plant-fault", "supply-loss:0:1.0"});
  const std::string f =
      ExpectHeldAfter(run, "FAULT_SUPPLY_PRESSURE_LOW", "FAULT_SUPPLY_PRESSURE_LOW");
  if (f.empty()) return;
  const auto& r = run.report;
  // 7 -> 4 bar with a 0.1 s time constant: 69 ms; + 3 held ticks (+ the supply ripple).
  EXPECT_GE(TickOf(f), 1060u) << f;
  EXPECT_LE(TickOf(f), 1080u) << f;
  const std::size_t last = r.applied_valve_v.size() - 1;
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.applied_valve_v[last][i], 5.0) << "leg " << i + 1;
}

TEST(Faults, StuckPotentiometerIsInconsistentAndItsValveIsClosed) {
  const auto run = RunFaultSession("fault_stuck", 89, {"--plant-fault", "pot-stuck:3:1.0"});
  const std::string f = ExpectHeldAfter(run, "supervisor: leg 3", "FAULT_SENSOR_INCONSISTENT");
  if (f.empty()) return;
  const auto& r = run.report;
  EXPECT_GT(TickOf(f), 1000u);
  // The plant closed the leg's valve on the supervisor's report (the leg's own controller
  // would drive it on its false reading into the end stop).
  const std::size_t last = r.applied_valve_v.size() - 1;
  EXPECT_EQ(r.applied_valve_v[last][2], 5.0);
}

TEST(Faults, ImuDropoutIsImuLostAndTheSupervisorHoldsWithoutIt) {
  const auto run = RunFaultSession("fault_imu", 90, {"--plant-fault", "imu-dropout:0:1.0"});
  const std::string f = ExpectHeldAfter(run, "plant: leg 0", "FAULT_IMU_LOST");
  if (f.empty()) return;
  const auto& r = run.report;
  EXPECT_EQ(TickOf(f), 1000u);
  EXPECT_TRUE(AnyFault(r, "supervisor:", "FAULT_IMU_LOST")) << Faults(r);
  ASSERT_GT(r.applied_valve_v.size(), 1900u);  // lockstep went on without the IMU
}

// The supervisor dies (SIGKILL) at t = 1 s. The legs see its setpoint writer's lease lapse,
// stop waiting for setpoints (lockstep), hold on the last one, which goes stale: valve at
// null, FAULT_SETPOINT_STALE. The session ends "supervisor lost" (exit 5).
TEST(Faults, SupervisorCrashMakesEveryLegHoldOnAStaleSetpoint) {
  const auto run = RunFaultSession("fault_sup_crash", 91, {"--fault", "supervisor:crash:1.0"});
  EXPECT_EQ(run.exit_code, 5) << hexa::testing::Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const auto& r = run.report;
  for (int leg = 1; leg <= 6; ++leg) {
    const std::string f = FindFault(r, "leg" + std::to_string(leg) + ": leg");
    EXPECT_NE(f.find("FAULT_SETPOINT_STALE"), std::string::npos) << "leg " << leg << "\n" << Faults(r);
  }
  const std::size_t last = r.applied_valve_v.size() - 1;
  ASSERT_GT(last, 1100u);  // lockstep went on without the supervisor
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.applied_valve_v[last][i], 5.0) << "leg " << i + 1;
}

// Real time: the primary of leg 5 dies without a standby. The plant sees its liveliness lapse,
// closes the valve and reports it as such; the supervisor holds. Behaviour only, nothing
// timed: the liveliness lease is raised to 0.1 s and the command tolerance to 300 ticks (well
// beyond the lease, so the lease always lapses first) so that a loaded machine's stalls do not
// end the session before the crash, and the valve is checked from the tick the plant
// reported, not from an assumed one.
TEST(Faults, RealTimeCrashWithoutStandbyIsDetectedAndHolds) {
  const auto run = RunSession("fault_crash_rt", 75, {"--trajectory", "combined", "--periods", "1",
                                                     "--mode", "realtime", "--stale-ticks", "300",
                                                     "--rt-lease", "0.1", "--fault", "5:crash:1.0"});
  EXPECT_NE(run.exit_code, 0);
  ASSERT_TRUE(run.has_report) << Slurp(run.dir + "/session.log");
  const auto& r = run.report;
  std::size_t fault_tick = 0;
  // The crashed controller's liveliness lapses (0.1 s lease here): the plant names that,
  // before its last command goes stale (300 ticks here).
  for (const auto& f : r.faults) {
    if (f.find("plant: leg 5 tick ") != 0 || f.find("FAULT_LIVELINESS_LOST") == std::string::npos)
      continue;
    fault_tick = std::stoul(f.substr(std::string("plant: leg 5 tick ").size()));
    break;
  }
  ASSERT_GT(fault_tick, 1000u) << "no liveliness-lost fault of leg 5 after the crash:\n" << Faults(r);
  EXPECT_FALSE(AnyFault(r, "plant: leg 1")) << Faults(r);  // the other legs ran on
  EXPECT_EQ(r.final_supervisor_state, "HOLD");
  // From the reported tick on, leg 5's valve is held at null in every recorded tick.
  std::size_t known = 0;
  for (std::size_t n = fault_tick + 1; n < r.applied_valve_v.size(); ++n) {
    if (std::isnan(r.applied_valve_v[n][4])) continue;  // GroundTruth sample not recorded
    ASSERT_EQ(r.applied_valve_v[n][4], 5.0) << "tick " << n;
    ++known;
  }
  EXPECT_GT(known, 100u);
}

}  // namespace
