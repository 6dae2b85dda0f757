// hexa_sim: runs paper trajectories on the in-process lockstep simulation (the same
// protocol as the DDS system, no processes) and prints the per-axis RMSE in the layout of
// the paper's Tables 9 and 10. For batch studies and tuning; the DDS session
// (hexa_session) is the system itself.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "calibrate_in_process.hpp"
#include "experiment.hpp"
#include "coupled_leg_feedback.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/core/calibration.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/json.hpp"

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_sim",
                        "Runs paper trajectories in the in-process lockstep simulation and "
                        "prints RMSE per axis (Tables 9 / 10 layout).");
  cli.AddOption("trajectory", "name|all", "x y z roll pitch yaw combined, or all", "all");
  cli.AddChoice("controller", {"bssmc", "pi"}, "leg controller", "bssmc");
  cli.AddOption("profile", "name", "disturbance profile of the rig file (realistic, ideal, ...)", "realistic");
  cli.AddOption("seed", "N", "plant seed", "1");
  cli.AddOption("periods", "N", "periods (0 = default)", "0");
  cli.AddOption("rig", "file", "rig file", hexa::config::DefaultRigFile());
  cli.AddRepeatable("rig-overlay", "file",
                    "rig overlay for the controllers and the supervisor (the plant keeps the rig "
                    "file + profile), applied in order as the services do");
  cli.AddFlag("no-outer-loop", "disable the outer loop");
  cli.AddFlag("least-squares", "six-leg least-squares estimator instead of GQFK");
  cli.AddFlag("no-feedforward", "no inverse-dynamics feed-forward (paper-faithful)");
  cli.AddFlag("coupled-feedback",
              "study: the BS-SMC feedback mixed across the legs through the leg-space mass "
              "matrix (in process only; docs/measurements/control_coupled_feedback.md \"Coupled leg feedback\")");
  cli.AddOption("coupled-reference-mass", "kg",
                "--coupled-feedback: m_ref of W = M_ls / m_ref (0: the BS-SMC's effective mass)", "0");
  cli.AddFlag("coupled-raise-only",
              "--coupled-feedback: W = V diag(max(m_k, m_ref)) V^T / m_ref (modes lighter than m_ref keep the uncoupled gain)");
  cli.AddFlag("coupled-observer-velocity",
              "--coupled-feedback: the feedback part's velocity from the coupled leg observer");
  cli.AddFlag("coupled-legs",
              "the coupled leg feedback of the system (rig file leg_controller.coupled_legs, "
              "turned on whatever its 'enabled' says; docs/controller_additions.md \"Coupled "
              "leg feedback\")");
  cli.AddFlag("calibrate",
              "first run the kinematic calibration procedure (tracker on, Ceres fit) and use the "
              "fitted calibration in the controllers");
  cli.AddOption("json", "file", "also write the results as JSON (RMSE in m and rad)");
  cli.AddChoice("experiment", {"none", "identify", "free-fall"},
                "identify / free-fall: the identification or free-fall experiment (as "
                "hexa_session --experiment) recorded to --record, instead of trajectories", "none");
  cli.AddOption("free-fall-load-kg", "kg", "--experiment free-fall: load hung on each rod", "12");
  cli.AddOption("legs", "list", "--experiment identify: legs to excite (1-6, 1,3, ...)", "1-6");
  cli.AddOption("excite-duration", "s", "--experiment identify: excitation per leg", "30");
  cli.AddOption("record", "file.mcap", "--experiment identify: the recording to write");
  cli.AddChoice("friction-model", {"lugre", "static"},
                "the plant's friction: LuGre (default) or the static eq 3 (study)", "lugre");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  auto seed = cli.GetInt("seed", 0, 1LL << 62);
  auto periods = cli.GetInt("periods", 0, 1000);
  if (!seed || !periods) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  auto loaded = hexa::config::LoadSystemConfig(cli.Get("rig"), cli.GetAll("rig-overlay"));
  if (!loaded.ok) {
    std::fprintf(stderr, "%s\n", loaded.error.c_str());
    return 1;
  }
  if (cli.Flag("coupled-legs")) loaded.config.leg_controller.coupled.enabled = true;
  hexa::LockstepConfig config;
  config.rig = loaded.config.rig;
  config.leg_controller = loaded.config.leg_controller;
  config.supervisor = loaded.config.supervisor;
  config.controllers = hexa::config::MakeControllerModel(loaded.config);  // as the services
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
  hexa::study::CoupledLegFeedbackParams coupled;
  coupled.enabled = cli.Flag("coupled-feedback");
  coupled.raise_only = cli.Flag("coupled-raise-only");
  coupled.observer_velocity = cli.Flag("coupled-observer-velocity");
  if (const auto m_ref = cli.GetDouble("coupled-reference-mass", 0, 999)) {
    coupled.reference_mass_kg = *m_ref;
  } else {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  config.leg_runner = hexa::study::CoupledLegRunnerFactory(coupled);
  config.plant_friction_model = cli.Get("friction-model") == "static"
                                    ? hexa::LegModelParams::FrictionModel::kStatic
                                    : hexa::LegModelParams::FrictionModel::kLugre;
  if (cli.Get("experiment") == "free-fall") {
    const auto load = cli.GetDouble("free-fall-load-kg", 0, 1000);
    if (!load || !cli.Has("record")) {
      std::fprintf(stderr, "error: %s\n", load ? "--experiment free-fall needs --record FILE.mcap" : cli.error().c_str());
      return 2;
    }
    hexa::sim::ExperimentOptions e;
    e.profile = cli.Get("profile");
    e.record_path = cli.Get("record");
    e.rig_path = cli.Get("rig");
    for (int k = 0; k < argc; ++k) e.command_line += (k ? " " : "") + std::string(argv[k]);
    return hexa::sim::RunFreeFallExperiment(loaded.config, config, e, *load);
  }
  if (cli.Get("experiment") == "identify") {
    hexa::sim::ExperimentOptions e;
    const auto duration = cli.GetDouble("excite-duration", 1, 3600);
    if (!duration || !cli.Has("record")) {
      std::fprintf(stderr, "error: %s\n", duration ? "--experiment identify needs --record FILE.mcap"
                                                   : cli.error().c_str());
      return 2;
    }
    if (!hexa::cli::ParseLegList(cli.Get("legs"), e.legs)) {
      std::fprintf(stderr, "error: --legs '%s': expected legs 1..6 as a list or range (1-6, 1,3)\n",
                   cli.Get("legs").c_str());
      return 2;
    }
    e.per_leg_s = *duration;
    e.profile = cli.Get("profile");
    e.record_path = cli.Get("record");
    e.rig_path = cli.Get("rig");
    for (int k = 0; k < argc; ++k) e.command_line += (k ? " " : "") + std::string(argv[k]);
    return hexa::sim::RunIdentifyExperiment(loaded.config, config, e);
  }

  bool calibrated = false;
  if (cli.Flag("calibrate")) {
    hexa::KinematicCalibration calibration;
    hexa::PayloadEstimate payload;
    if (!hexa::calib::CalibrateInProcess(config, calibration, stdout, payload)) return 1;
    hexa::calib::ApplyKinematicCalibration(calibration, payload, config);
    calibrated = true;
  }

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
  std::printf("controller=%s profile=%s seed=%lld outer_loop=%s feedforward=%s calibration=%s\n",
              cli.Get("controller").c_str(), cli.Get("profile").c_str(), *seed,
              config.supervisor.outer_loop.enabled ? "on" : "off",
              config.supervisor.feedforward_enabled ? "on" : "off",
              calibrated ? "fitted" : (loaded.config.overlays.empty() ? "nominal" : "overlay"));
  for (const auto& o : loaded.config.overlays) {
    std::printf("rig overlay %s (%s, %s)\n", o.source_path.c_str(), o.provenance.method.c_str(),
                o.provenance.date.c_str());
  }
  std::printf("%-9s %-4s | %8s %8s %8s | %8s %8s %8s | %s\n", "traj", "vs", "X cm", "Y cm",
              "Z cm", "rotX deg", "rotY deg", "rotZ deg", "leg RMSE mm (1..6)");
  int failures = 0;
  hexa::json::Value json = {{"seed", *seed},
                            {"profile", cli.Get("profile")},
                            {"controller", cli.Get("controller")},
                            {"overlays", hexa::json::Value::array()},
                            {"trajectories", hexa::json::Value::object()}};
  for (const auto& o : loaded.config.overlays) json["overlays"].push_back(o.source_path);
  for (const auto motion : motions) {
    const auto r = hexa::RunPaperSession(config, motion, static_cast<int>(*periods));
    {
      const auto t = r.metrics.vs_truth.Rmse();
      const auto m = r.metrics.vs_measured.Rmse();
      hexa::json::Value legs = hexa::json::Value::array();
      for (const auto& leg : r.metrics.leg_length) legs.push_back(leg.Rmse());
      json["trajectories"][hexa::ToString(motion)] = {
          {"completed", r.completed},
          {"rmse_vs_truth", {t[0], t[1], t[2], t[3], t[4], t[5]}},
          {"rmse_vs_measured", {m[0], m[1], m[2], m[3], m[4], m[5]}},
          {"leg_rmse_m", legs}};
    }
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
  if (cli.Has("json")) {
    std::string error;
    if (!hexa::json::WriteFile(cli.Get("json"), json, -1, error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
  }
  return failures == 0 ? 0 : 1;
}
