// Helpers of the system tests: run hexa_session as a supervised child (no orphans, even on
// failure), read its report, replay the same configuration in-process.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/recording/report.hpp"
#include "process_group.hpp"
#include "scratch_dir.hpp"

namespace hexa::testing {

inline std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct SessionRun {
  std::string dir;
  int exit_code = -1;
  bool has_report = false;
  recorder::SessionReport report;
};

// Runs hexa_session with `args` (+ --domain, --out) and waits for it. A held session ends
// after 1 s in HOLD (--hold-timeout 1, unless `args` set it): no operator resets it here.
inline SessionRun RunSession(const std::string& name, int domain, std::vector<std::string> args) {
  SessionRun run;
  run.dir = ScratchDir(name);
  deploy::ProcessGroup group;
  deploy::ChildSpec s{"session", {HEXA_SESSION}, {}, run.dir + "/launcher.console.log"};
  if (std::find(args.begin(), args.end(), "--hold-timeout") == args.end())
    args.insert(args.end(), {"--hold-timeout", "1"});
  s.argv.insert(s.argv.end(), args.begin(), args.end());
  s.argv.insert(s.argv.end(), {"--domain", std::to_string(domain), "--out", run.dir,
                               "--timeout", "240"});
  std::string err;
  if (group.Start(s, err) < 0) {
    ADD_FAILURE() << err;
    return run;
  }
  const auto ev = group.WaitEvent(std::chrono::seconds(300));
  if (ev.kind != deploy::ProcessGroup::Event::kChildExited) {
    ADD_FAILURE() << "session did not end in time";
    return run;
  }
  run.exit_code = ev.exit.signal == 0 ? ev.exit.exit_code : 128 + ev.exit.signal;
  if (std::filesystem::exists(run.dir + "/session.mcap")) {
    run.report = recorder::ComputeSessionReport(run.dir + "/session.mcap");
    run.has_report = true;
  }
  return run;
}

// The in-process lockstep simulation of a paper session with the shipped rig file, as
// hexa_session runs it: tick 0 latches the rest pose, START at tick 5. `rig_overlays` are
// applied as the services apply them (config::MakeControllerModel); `coupled_legs`: as
// --coupled-legs. Calls on_step(n, sim) after each step n = 1, 2, ... until it returns false.
template <typename OnStep>
inline void RunInProcessSession(PaperMotion motion, int periods, std::uint64_t seed,
                                LegControllerKind controller,
                                const std::vector<std::string>& rig_overlays, OnStep on_step,
                                bool coupled_legs = false) {
  auto loaded = config::LoadSystemConfig(config::DefaultRigFile(), rig_overlays);
  ASSERT_TRUE(loaded.ok) << loaded.error;
  if (coupled_legs) loaded.config.leg_controller.coupled.enabled = true;
  const config::SystemConfig& cfg = loaded.config;
  LockstepConfig lc;
  lc.rig = cfg.rig;
  lc.leg_controller = cfg.leg_controller;
  lc.supervisor = cfg.supervisor;
  lc.controllers = config::MakeControllerModel(cfg);
  lc.disturbance = cfg.profiles.at("realistic");
  lc.seed = seed;
  lc.controller = controller;
  LockstepSimulation sim(lc);
  sim.Tick();  // tick 0: the supervisor latches the rest pose, as the service does
  const StartRequest start = sim.supervisor().PreparePaperStart(motion, periods);
  for (std::uint64_t n = 1;; ++n) {
    const bool start_now = n == 5;
    sim.Tick(start_now ? OperatorCommandKind::kStart : OperatorCommandKind::kNone,
             start_now ? &start : nullptr);
    if (!on_step(n, static_cast<const LockstepSimulation&>(sim))) return;
  }
}

// Replays a paper trajectory in the in-process lockstep simulation and compares the valve
// voltages the plant applied at every tick, bit for bit.
// GroundTruth(n + 1) carries the voltages applied during step n.
inline void ExpectSameAsInProcess(const recorder::SessionReport& report, PaperMotion motion,
                                  int periods, std::uint64_t seed,
                                  LegControllerKind controller = LegControllerKind::kBsSmc,
                                  std::uint64_t up_to_tick = UINT64_MAX,
                                  const std::vector<std::string>& rig_overlays = {},
                                  bool coupled_legs = false) {
  const auto& applied = report.applied_valve_v;
  ASSERT_GT(applied.size(), 1000u);
  RunInProcessSession(motion, periods, seed, controller, rig_overlays,
                      [&](std::uint64_t n, const LockstepSimulation& sim) {
                        if (n + 1 >= applied.size() || n >= up_to_tick) return false;
                        for (int i = 0; i < 6; ++i) {
                          if (applied[n + 1][i] != sim.applied_valve_v()[i]) {
                            ADD_FAILURE() << "tick " << n << " leg " << i + 1
                                          << ": the DDS session and the in-process simulation diverge";
                            return false;
                          }
                        }
                        return true;
                      },
                      coupled_legs);
}

// The legs' adapted friction scale theta the session recorded (ValveCommand(n).friction_scale)
// equals the in-process controllers' LegControllerOutput::friction_scale after step n, bit for
// bit, at every tick each leg answered (BS-SMC).
inline void ExpectSameFrictionScaleAsInProcess(const recorder::SessionReport& report,
                                               PaperMotion motion, int periods,
                                               std::uint64_t seed) {
  const auto& theta = report.command_friction_scale;
  ASSERT_GT(theta.size(), 1000u);
  std::uint64_t compared = 0;
  RunInProcessSession(motion, periods, seed, LegControllerKind::kBsSmc, {},
                      [&](std::uint64_t n, const LockstepSimulation& sim) {
                        if (n >= theta.size()) return false;
                        for (int i = 0; i < 6; ++i) {
                          const double in_process = sim.leg_outputs()[i].friction_scale;
                          if (std::isnan(theta[n][i])) continue;  // no command of that leg
                          ++compared;
                          if (theta[n][i] != in_process) {
                            ADD_FAILURE() << "tick " << n << " leg " << i + 1 << ": recorded theta "
                                          << theta[n][i] << ", in process " << in_process;
                            return false;
                          }
                        }
                        return true;
                      });
  EXPECT_GT(compared, 6u * 1000u);
}

}  // namespace hexa::testing
