// hexa_sim: runs paper trajectories on the in-process lockstep simulation (the same
// protocol as the DDS system, no processes) and prints the per-axis RMSE in the layout of
// the paper's Tables 9 and 10. For batch studies and tuning; the DDS session
// (hexa_session) is the system itself.
#include <cstdio>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/services/cli.hpp"

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_sim",
                        "Runs paper trajectories in the in-process lockstep simulation and "
                        "prints RMSE per axis (Tables 9 / 10 layout).");
  cli.AddOption("trajectory", "name|all", "x y z roll pitch yaw combined, or all", "all");
  cli.AddChoice("controller", {"bssmc", "pi"}, "leg controller", "bssmc");
  cli.AddChoice("profile", {"realistic", "ideal"}, "disturbance profile", "realistic");
  cli.AddOption("seed", "N", "plant seed", "1");
  cli.AddOption("periods", "N", "periods (0 = default)", "0");
  cli.AddOption("rig", "file", "rig file", HEXA_DEFAULT_RIG_FILE);
  cli.AddFlag("no-outer-loop", "disable the outer loop");
  cli.AddFlag("least-squares", "six-leg least-squares estimator instead of GQFK");
  cli.AddFlag("no-feedforward", "no inverse-dynamics feed-forward (paper-faithful)");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  auto seed = cli.GetInt("seed", 0, 1LL << 62);
  auto periods = cli.GetInt("periods", 0, 1000);
  if (!seed || !periods) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  const auto loaded = hexa::config::LoadSystemConfig(cli.Get("rig"));
  if (!loaded.ok) {
    std::fprintf(stderr, "%s\n", loaded.error.c_str());
    return 1;
  }
  hexa::LockstepConfig config;
  config.rig = loaded.config.rig;
  config.leg_controller = loaded.config.leg_controller;
  config.supervisor = loaded.config.supervisor;
  const auto profile = loaded.config.profiles.find(cli.Get("profile"));
  if (profile == loaded.config.profiles.end()) {
    std::fprintf(stderr, "error: profile '%s' not in %s\n", cli.Get("profile").c_str(),
                 cli.Get("rig").c_str());
    return 1;
  }
  config.disturbance = profile->second;
  config.seed = static_cast<std::uint64_t>(*seed);
  config.controller = cli.Get("controller") == "pi" ? hexa::LegControllerKind::kPi
                                                     : hexa::LegControllerKind::kBsSmc;
  if (cli.Flag("no-outer-loop")) config.supervisor.outer_loop.enabled = false;
  if (cli.Flag("least-squares")) config.supervisor.least_squares_estimator = true;
  if (cli.Flag("no-feedforward")) config.supervisor.feedforward_enabled = false;

  std::vector<hexa::PaperMotion> motions;
  if (cli.Get("trajectory") == "all") {
    motions = {hexa::PaperMotion::kX,    hexa::PaperMotion::kY,     hexa::PaperMotion::kZ,
               hexa::PaperMotion::kRoll, hexa::PaperMotion::kPitch, hexa::PaperMotion::kYaw,
               hexa::PaperMotion::kCombined};
  } else {
    hexa::PaperMotion m;
    if (!hexa::ParsePaperMotion(cli.Get("trajectory"), m)) {
      std::fprintf(stderr, "error: unknown trajectory '%s'\n", cli.Get("trajectory").c_str());
      return 2;
    }
    motions = {m};
  }
  std::printf("controller=%s profile=%s seed=%lld outer_loop=%s feedforward=%s\n",
              cli.Get("controller").c_str(), cli.Get("profile").c_str(), *seed,
              config.supervisor.outer_loop.enabled ? "on" : "off",
              config.supervisor.feedforward_enabled ? "on" : "off");
  std::printf("%-9s %-4s | %8s %8s %8s | %8s %8s %8s | %s\n", "traj", "vs", "X cm", "Y cm",
              "Z cm", "rotX deg", "rotY deg", "rotZ deg", "leg RMSE mm (1..6)");
  int failures = 0;
  for (const auto motion : motions) {
    const auto r = hexa::RunPaperSession(config, motion, static_cast<int>(*periods));
    if (!r.completed) {
      ++failures;
      std::printf("%-9s did not complete: state %s, plant %s, %llu ticks\n",
                  hexa::ToString(motion), hexa::ToString(r.final_state),
                  hexa::ToString(r.plant_status), static_cast<unsigned long long>(r.ticks));
    }
    for (int which = 0; which < 2; ++which) {
      const auto& acc = which == 0 ? r.metrics.vs_truth : r.metrics.vs_measured;
      const auto e = acc.Rmse();
      std::printf("%-9s %-4s | %8.4f %8.4f %8.4f | %8.4f %8.4f %8.4f |", hexa::ToString(motion),
                  which == 0 ? "true" : "meas", 100 * e[0], 100 * e[1], 100 * e[2],
                  e[3] * 57.29577951308232, e[4] * 57.29577951308232, e[5] * 57.29577951308232);
      if (which == 0)
        for (const auto& leg : r.metrics.leg_length) std::printf(" %.3f", 1000 * leg.Rmse());
      std::printf("\n");
    }
  }
  return failures == 0 ? 0 : 1;
}
