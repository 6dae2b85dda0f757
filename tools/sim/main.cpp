// hexa_sim: runs paper trajectories on the in-process lockstep simulation (the same
// protocol as the DDS system, no processes) and prints the per-axis RMSE in the layout of
// the paper's Tables 9 and 10. For batch studies and tuning; the DDS session
// (hexa_session) is the system itself.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "calibration_fit.hpp"
#include "experiment.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/core/calibration.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/services/cli.hpp"

namespace {

// The calibration procedure in process (what hexa_session --trajectory calibration --tracker
// + hexa_calibrate do over DDS): the supervisor visits the designed poses, the tracker
// measures them, the still windows are averaged and fitted. Prints the fit against the
// plant's truth; returns false when the run or the fit failed.
bool CalibrateInProcess(const hexa::LockstepConfig& base, hexa::KinematicCalibration& out) {
  hexa::LockstepConfig config = base;
  config.tracker.enabled = true;
  config.controllers.reset();  // nominal model: what is being calibrated
  // The outer loop integrates estimation noise at rest (docs/task_space.md, idle wander:
  // ~1 mm); the calibration wants the legs still where they are commanded.
  config.supervisor.outer_loop.enabled = false;
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::Supervisor& sup = sim.supervisor();
  const hexa::StartRequest start = sup.PrepareStart(hexa::MakeCalibrationTrajectory(
      config.rig, sup.rest_xyz_rpy(), sup.home_xyz_rpy(), sup.timing(),
      hexa::CalibrationProcedureParams{}));
  if (!start.feasibility.feasible) {
    std::fprintf(stderr, "calibration trajectory rejected: %s\n", start.feasibility.message.c_str());
    return false;
  }
  hexa::CalibrationSampleCollector collector(hexa::StillWindowParams{});
  bool started = false, left_idle = false;
  while (sim.time_s() < 1000.0) {
    const bool due = sim.supervisor_due();
    const auto cmd = due && !started ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr) !=
        hexa::PlantStatus::kOk) {
      return false;
    }
    const std::uint64_t tick = sim.tick() - 1;
    const auto& p = sim.plant_before_step();
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) collector.AddReading(tick, i, p.legs[i].length_m);
    if (p.tracker.fresh) collector.AddTracker(tick, p.tracker.p_BP_B_m, p.tracker.q_BP);
    if (!due) continue;
    started = true;
    const auto& out = sim.supervisor_output();
    collector.AddDesired(tick, out.desired_xyz_rpy, out.state != hexa::SupervisorState::kHold);
    if (out.state == hexa::SupervisorState::kHold) {
      std::fprintf(stderr, "calibration run went to HOLD: %s\n", out.fault_detail.data());
      return false;
    }
    if (out.state != hexa::SupervisorState::kIdle) left_idle = true;
    if (left_idle && out.state == hexa::SupervisorState::kIdle) break;
  }
  const auto samples = collector.Samples();
  const double mid = config.rig.cylinder.mid_stroke_length_m;
  const auto fit = hexa::calib::FitKinematicCalibration(
      samples, mid, hexa::NominalCalibration(config.rig.geometry), hexa::calib::FitOptions{});
  std::printf("calibration: %.1f s simulated, %zu samples (tracker measurements in still windows), %s\n", sim.time_s(), samples.size(),
              fit.message.c_str());
  if (!fit.ok) return false;
  const hexa::PlatformPlant& plant = sim.plant();
  double worst_joint = 0, worst_offset = 0, worst_gain = 0;
  for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
    hexa::LegCalibration truth;
    truth.p_BA_B_m = plant.true_geometry().p_BA_B[i];
    truth.p_PB_P_m = plant.true_geometry().p_PB_P[i];
    truth.potentiometer_offset_m = plant.sensors().calibration().offset_m[i];
    truth.potentiometer_gain = 1.0 + plant.sensors().calibration().gain_error[i];
    const hexa::LegCalibrationVector e = fit.calibration[i].AsVector() - truth.AsVector();
    double truth_rms = 0.0;  // how well the TRUE parameters explain the data (data quality)
    for (const auto& smp : samples) {
      const double r = smp.reading_m[i] - hexa::PredictedReadingM(truth, smp.pose, mid);
      truth_rms += r * r;
    }
    truth_rms = std::sqrt(truth_rms / static_cast<double>(samples.size()));
    std::printf("  leg %zu: data residual with the true parameters %.4f mm\n", i + 1, 1e3 * truth_rms);
    worst_joint = std::max(worst_joint, e.head<6>().cwiseAbs().maxCoeff());
    worst_offset = std::max(worst_offset, std::abs(e[6]));
    worst_gain = std::max(worst_gain, std::abs(e[7]));
    std::printf("  leg %zu residual vs truth: joints (mm)", i + 1);
    for (int k = 0; k < 6; ++k) std::printf(" %+.4f", 1e3 * e[k]);
    std::printf(" | offset %+.4f mm | gain %+.1f ppm | fit rms %.4f mm\n", 1e3 * e[6], 1e6 * e[7],
                1e3 * fit.legs[i].final_rms_m);
  }
  std::printf("  worst residual: joint %.4f mm, offset %.4f mm, gain %.1f ppm\n", 1e3 * worst_joint,
              1e3 * worst_offset, 1e6 * worst_gain);
  out = fit.calibration;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_sim",
                        "Runs paper trajectories in the in-process lockstep simulation and "
                        "prints RMSE per axis (Tables 9 / 10 layout).");
  cli.AddOption("trajectory", "name|all", "x y z roll pitch yaw combined, or all", "all");
  cli.AddChoice("controller", {"bssmc", "pi"}, "leg controller", "bssmc");
  cli.AddOption("profile", "name", "disturbance profile of the rig file (realistic, ideal, ...)", "realistic");
  cli.AddOption("seed", "N", "plant seed", "1");
  cli.AddOption("periods", "N", "periods (0 = default)", "0");
  cli.AddOption("rig", "file", "rig file", HEXA_DEFAULT_RIG_FILE);
  cli.AddRepeatable("rig-overlay", "file",
                    "rig overlay for the controllers and the supervisor (the plant keeps the rig "
                    "file + profile), applied in order as the services do");
  cli.AddFlag("no-outer-loop", "disable the outer loop");
  cli.AddFlag("least-squares", "six-leg least-squares estimator instead of GQFK");
  cli.AddFlag("no-feedforward", "no inverse-dynamics feed-forward (paper-faithful)");
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
  const auto loaded = hexa::config::LoadSystemConfig(cli.Get("rig"), cli.GetAll("rig-overlay"));
  if (!loaded.ok) {
    std::fprintf(stderr, "%s\n", loaded.error.c_str());
    return 1;
  }
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
    if (!CalibrateInProcess(config, calibration)) return 1;
    // The fitted calibration reaches the controllers as a rig overlay would (ControllerModel).
    hexa::ControllerModel model = *config.controllers;
    model.geometry = hexa::CalibratedGeometry(model.geometry, calibration);
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
      model.legs[i].potentiometer.offset_m = calibration[i].potentiometer_offset_m;
      model.legs[i].potentiometer.gain = calibration[i].potentiometer_gain;
    }
    config.controllers = model;
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
  std::string json = "{\"seed\": " + std::to_string(*seed) + ", \"profile\": \"" + cli.Get("profile") +
                     "\", \"controller\": \"" + cli.Get("controller") + "\", \"overlays\": [";
  for (std::size_t i = 0; i < loaded.config.overlays.size(); ++i)
    json += (i ? ", \"" : "\"") + loaded.config.overlays[i].source_path + "\"";
  json += "], \"trajectories\": {";
  bool first_json = true;
  for (const auto motion : motions) {
    const auto r = hexa::RunPaperSession(config, motion, static_cast<int>(*periods));
    {
      char buf[512];
      const auto t = r.metrics.vs_truth.Rmse();
      const auto m = r.metrics.vs_measured.Rmse();
      std::snprintf(buf, sizeof buf,
                    "%s\"%s\": {\"completed\": %s, \"rmse_vs_truth\": [%.9g, %.9g, %.9g, %.9g, %.9g, %.9g], "
                    "\"rmse_vs_measured\": [%.9g, %.9g, %.9g, %.9g, %.9g, %.9g], \"leg_rmse_m\": [",
                    first_json ? "" : ", ", hexa::ToString(motion), r.completed ? "true" : "false", t[0], t[1],
                    t[2], t[3], t[4], t[5], m[0], m[1], m[2], m[3], m[4], m[5]);
      json += buf;
      for (std::size_t i = 0; i < r.metrics.leg_length.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%s%.9g", i ? ", " : "", r.metrics.leg_length[i].Rmse());
        json += buf;
      }
      json += "]}";
      first_json = false;
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
  json += "}}\n";
  if (cli.Has("json")) {
    FILE* f = std::fopen(cli.Get("json").c_str(), "w");
    if (f == nullptr || std::fputs(json.c_str(), f) < 0) {
      std::fprintf(stderr, "error: cannot write %s\n", cli.Get("json").c_str());
      return 1;
    }
    std::fclose(f);
  }
  return failures == 0 ? 0 : 1;
}
