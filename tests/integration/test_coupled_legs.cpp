// Coupled leg feedback over DDS (docs/controller.md "Coupled leg feedback"): the session with
// --coupled-legs equals the in-process simulation with the coupling on, bit for bit (also with
// an overlay's platform payload); a leg that crashes, hangs or goes silent takes the others
// back to their decoupled law on the tick after the first tick it did not answer. Lockstep:
// nothing depends on the machine.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

TEST(CoupledLegs, LockstepSessionEqualsTheInProcessSimulationBitForBit) {
  const auto run = RunSession("coupled_legs", 68, {"--trajectory", "combined", "--periods", "1",
                                                   "--seed", "3", "--coupled-legs"});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const auto& r = run.report;
  EXPECT_TRUE(r.faults.empty()) << r.faults.front();
  // The coupling acted: a leg is coupled on every tick it answered while all six ran the
  // BS-SMC on the tick before; not before the first setpoint and after the supervisor's end
  // (the legs hold then and publish no part).
  std::uint64_t coupled = 0, answered = 0;
  for (const auto& tick : r.command_coupled)
    for (int v : tick) {
      answered += v >= 0 ? 1 : 0;
      coupled += v == 1 ? 1 : 0;
    }
  EXPECT_GT(answered, 6u * 3000u);
  EXPECT_GT(coupled, answered * 9 / 10) << "coupled on " << coupled << " of " << answered;
  hexa::testing::ExpectSameAsInProcess(r, hexa::PaperMotion::kCombined, 1, 3,
                                       hexa::LegControllerKind::kBsSmc, UINT64_MAX, {}, true);
  // And it is not the decoupled system: the same session without the coupling differs.
  bool differs = false;
  hexa::testing::RunInProcessSession(
      hexa::PaperMotion::kCombined, 1, 3, hexa::LegControllerKind::kBsSmc, {},
      [&](std::uint64_t n, const hexa::LockstepSimulation& sim) {
        if (n + 1 >= r.applied_valve_v.size()) return false;
        for (int i = 0; i < 6; ++i) differs = differs || r.applied_valve_v[n + 1][i] != sim.applied_valve_v()[i];
        return !differs;
      });
  EXPECT_TRUE(differs);
}

// Leg 3 suffers `kind` at t = 1 s (no standby): the first tick it does not answer is N; the
// other legs answer N coupled (leg 3's part of N - 1 is there) and every tick from N + 1 on
// decoupled (the plant relays no part of leg 3 for N: it never answered it, and is then
// forced to null). Returns N (0 after a failure).
std::uint64_t ExpectFallBackTheTickAfter(const std::string& name, int domain, const std::string& kind) {
  const auto run = RunSession(name, domain, {"--trajectory", "combined", "--periods", "1", "--seed", "1",
                                             "--coupled-legs", "--fault", "3:" + kind + ":1.0"});
  EXPECT_EQ(run.exit_code, 3) << Slurp(run.dir + "/session.log");  // held after the fault
  if (!run.has_report) {
    ADD_FAILURE() << "no recording";
    return 0;
  }
  const auto& c = run.report.command_coupled;
  std::uint64_t first_missing = 0;
  for (std::uint64_t n = 1000; n < c.size(); ++n)
    if (c[n][2] != 1) {
      first_missing = n;
      break;
    }
  EXPECT_GT(first_missing, 0u);
  if (first_missing == 0) return 0;
  ::testing::Test::RecordProperty("first_missed_tick", std::to_string(first_missing));
  std::printf("leg 3 (%s) first missed tick %llu; the other legs decoupled from tick %llu on\n",
              kind.c_str(), static_cast<unsigned long long>(first_missing),
              static_cast<unsigned long long>(first_missing + 1));
  EXPECT_EQ(c[first_missing - 1][2], 1);
  EXPECT_LT(first_missing, c.size() - 200u);  // the others answered on for a while
  for (int leg : {0, 1, 3, 4, 5}) {
    EXPECT_EQ(c[first_missing][leg], 1) << "leg " << leg + 1 << " at the tick leg 3 missed";
    std::uint64_t coupled_after = 0, first_coupled_after = 0;
    for (std::uint64_t n = first_missing + 1; n < c.size(); ++n) {
      if (c[n][leg] != 1) continue;  // decoupled, or no command recorded
      if (coupled_after++ == 0) first_coupled_after = n;
    }
    EXPECT_EQ(coupled_after, 0u) << "leg " << leg + 1 << " coupled from tick " << first_coupled_after
                                 << " on, leg 3 missed " << first_missing;
  }
  // Until the fault, the session is the in-process one with the coupling on.
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 1,
                                       hexa::LegControllerKind::kBsSmc, first_missing - 1, {}, true);
  return first_missing;
}

// The overlay's platform (with its payload, docs/calibration.md "Payload") reaches the
// supervisor's feed-forward and the legs' W over DDS as in process: the coupled session with
// it equals the in-process simulation with it bit for bit, and differs from the one without.
TEST(CoupledLegs, PayloadOverlayReachesSupervisorAndLegsAsInProcess) {
  const std::string overlay = HEXA_PAYLOAD_OVERLAY;
  const auto run = RunSession("coupled_payload", 230, {"--trajectory", "combined", "--periods", "1",
                                                      "--seed", "1", "--coupled-legs", "--rig-overlay", overlay});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const std::string logs = Slurp(run.dir + "/leg3.log") + Slurp(run.dir + "/supervisor.log");
  EXPECT_NE(logs.find("platform mass 7.2 kg"), std::string::npos) << logs;
  EXPECT_EQ(Slurp(run.dir + "/plant.log").find("rig overlay"), std::string::npos);
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 1,
                                       hexa::LegControllerKind::kBsSmc, UINT64_MAX, {overlay}, true);
  bool differs = false;
  hexa::testing::RunInProcessSession(
      hexa::PaperMotion::kCombined, 1, 1, hexa::LegControllerKind::kBsSmc, {},
      [&](std::uint64_t n, const hexa::LockstepSimulation& sim) {
        if (n + 1 >= run.report.applied_valve_v.size()) return false;
        for (int i = 0; i < 6; ++i)
          differs = differs || run.report.applied_valve_v[n + 1][i] != sim.applied_valve_v()[i];
        return !differs;
      },
      true);
  EXPECT_TRUE(differs) << "the platform's payload changed nothing the plant applied";
}

TEST(CoupledLegs, OtherLegsFallBackTheTickAfterACrashedLegsFirstMissedTick) {
  const std::uint64_t n = ExpectFallBackTheTickAfter("coupled_crash", 69, "crash");
  EXPECT_GE(n, 1000u);
  EXPECT_LE(n, 1001u);
}

TEST(CoupledLegs, OtherLegsFallBackTheTickAfterAHungLegsFirstMissedTick) {
  const std::uint64_t n = ExpectFallBackTheTickAfter("coupled_hang", 53, "hang");
  EXPECT_GE(n, 1000u);
  EXPECT_LE(n, 1001u);
}

}  // namespace
