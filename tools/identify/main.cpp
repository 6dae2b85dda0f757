// hexa_identify: identifies the pneumatic model of each leg from an identification recording
// (hexa_session --experiment identify, or hexa_sim --experiment identify): the paper's GA with
// Table 7's settings and a least-squares fit (Ceres) on the same eq 13 objective, per leg and
// stroke direction. Writes a rig overlay (validated like a rig file; refused, never written,
// when a value breaks the rig file's limits), Table 8 style tables (identified, truth when the
// recording carries it, error %), and data for the plots of measured against model-predicted
// x'', dP1/dt, dP2/dt. docs/identification.md.
#include <google/protobuf/text_format.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/free_fall.hpp"
#include "hexa/services/progress.hpp"
#include "hexa/core/genetic_algorithm.hpp"
#include "hexa/core/offline_differentiator.hpp"
#include "hexa/core/platform_inverse_dynamics.hpp"
#include "hexa/core/pneumatic_identification.hpp"
#include "hexa/services/cli.hpp"
#include "lsq.hpp"
#include "recording_input.hpp"
#include "fit_steps.hpp"
#include "report.hpp"

namespace fs = std::filesystem;
using namespace hexa;
using namespace hexa::identify;

namespace {

std::string UtcNow() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// A leg is calibrated when an overlay gives its joints or its potentiometer (hexa_calibrate
// writes both).
bool LegCalibrated(const config::SystemConfig& cfg, int leg) {
  const config::LegOverride& o = cfg.leg_override[static_cast<std::size_t>(leg - 1)];
  return o.p_BA_B_m || o.p_PB_P_m || o.potentiometer_offset_m || o.potentiometer_gain;
}

std::string UncalibratedLegs(const config::SystemConfig& cfg, const std::vector<int>& legs) {
  std::string out;
  for (int leg : legs)
    if (!LegCalibrated(cfg, leg)) out += " " + std::to_string(leg);
  return out;
}

bool HasKinematicCalibration(const config::SystemConfig& cfg, const std::vector<int>& legs) {
  return UncalibratedLegs(cfg, legs).empty();
}

// Checks that the recording is of this rig: its own rig name (hexa_SessionInfo) when it has
// one, and in every case the measurements against the rig file's stroke and supply.
void CheckRig(const IdentificationRecording& rec, const config::SystemConfig& cfg, const std::vector<int>& legs) {
  if (rec.session && !rec.session->rig_name().empty() && rec.session->rig_name() != cfg.rig_name) {
    throw IdentificationInputError(rec.path + ": recorded on rig '" + rec.session->rig_name() +
                                   "' (hexa_SessionInfo), but the rig file " + cfg.source_path +
                                   " describes '" + cfg.rig_name + "': identify with that rig's file");
  }
  const CylinderParams& cyl = cfg.rig.cylinder;
  const double lo = cyl.mid_stroke_length_m - 0.5 * cyl.stroke_m - 0.02;
  const double hi = cyl.mid_stroke_length_m + 0.5 * cyl.stroke_m + 0.02;
  for (int leg : legs) {
    const LegSeries& s = rec.legs[static_cast<std::size_t>(leg - 1)];
    double outside = 0.0, supply_sum = 0.0;
    std::size_t supply_n = 0, out_n = 0;
    for (std::size_t k = 0; k < s.size(); ++k) {
      const double l = s.length_m[k];
      if (std::isfinite(l) && (l < lo || l > hi)) {
        ++out_n;
        outside = l;
      }
      if (std::isfinite(s.supply_pressure_pa[k])) {
        supply_sum += s.supply_pressure_pa[k];
        ++supply_n;
      }
    }
    if (out_n > 0) {
      std::ostringstream m;
      m << rec.path << ": leg " << leg << " length " << outside << " m (" << out_n
        << " samples) is outside the stroke of rig '" << cfg.rig_name << "' [" << lo << ", " << hi
        << "] m: the recording is of a different rig (or the wrong --rig file)";
      throw IdentificationInputError(m.str());
    }
    const double supply = supply_n > 0 ? supply_sum / static_cast<double>(supply_n) : 0.0;
    if (supply_n == 0 || std::abs(supply - cfg.rig.air.supply_pressure_pa) > 0.15 * cfg.rig.air.supply_pressure_pa) {
      std::ostringstream m;
      m << rec.path << ": leg " << leg << " mean supply pressure " << supply << " Pa differs by more than 15 % "
        << "from rig '" << cfg.rig_name << "' (" << cfg.rig.air.supply_pressure_pa
        << " Pa): the recording is of a different rig or has no supply pressure";
      throw IdentificationInputError(m.str());
    }
  }
}

// The options of hexa_identify (--help lists them; docs/cli/hexa_identify.md).
void AddOptions(cli::Parser& cli) {
  cli.AllowPositional("RECORDING.mcap", 1);
  cli.AddOption("out", "dir", "output directory");
  cli.AddOption("rig", "file", "rig file of the recorded rig (the nominal model)", hexa::config::DefaultRigFile());
  cli.AddRepeatable("rig-overlay", "file",
                    "rig overlay on top of --rig, e.g. hexa_calibrate's kinematic calibration: its "
                    "joint positions enter the platform's inverse dynamics and its potentiometer "
                    "offset and gain correct every length reading (as in the controllers)");
  cli.AddOption("legs", "list", "legs to identify, e.g. 1-6 or 1,3", "1-6");
  cli.AddChoice("method", {"both", "ga", "lsq"}, "fits to run", "both");
  cli.AddChoice("overlay-from", {"lsq", "ga"}, "which fit the rig overlay holds", "lsq");
  cli.AddOption("max-iterations", "N", "GA iterations (Table 7: MaxIt = 1000)", "1000");
  cli.AddOption("population", "N", "GA population (Table 7: nPop = 100)", "100");
  cli.AddOption("seed", "N", "GA seed", "1");
  cli.AddChoice("ga-space", {"around-nominal", "wide", "force-at-speeds"},
                "how the GA's genes in [0, 1] map to the parameters (linearly, each to a range): "
                "around-nominal = v_s, B, F_s - F_c, F_c from the rig file's value / f to x f "
                "(--ga-range-factor), gammas 1-2; wide = fixed ranges v_s 0.02-1.5 m/s, B 0-150 N s/m, "
                "F_s - F_c 0-150 N, F_c 0-250 N, gammas 1-2; force-at-speeds = as around-nominal, but "
                "genes 2-4 are eq 3's friction force at 0.1, 0.5 and 1.2 m/s (default; docs/identification.md)",
                "force-at-speeds");
  cli.AddOption("ga-range-factor", "f", "--ga-space around-nominal / force-at-speeds: the factor f (> 1)", "2");
  cli.AddChoice("ga-crossover", {"per-gene", "per-pair"},
                "GA arithmetic crossover: per-gene = the template's a drawn per gene; per-pair = one a "
                "per parent pair (offspring on the line through the parents; docs/identification.md)",
                "per-gene");
  cli.AddChoice("ga-mutation-step", {"range", "population", "success-rule"},
                "GA mutation step: range = the template's sigma = 0.1 of the gene range; population = "
                "0.1 of the gene's spread over the population; success-rule = from 0.1 of the range, "
                "adapted by the 1/5 success rule (docs/identification.md)", "range");
  cli.AddOption("threads", "N", "threads for the GA's fitness evaluations", "2");
  cli.AddOption("diff-window", "N", "Gaussian differentiator window (eq 40, odd, samples)", "41");
  cli.AddOption("diff-sigma", "samples", "Gaussian differentiator sigma (eq 41, samples)", "6");
  cli.AddOption("min-speed", "m/s", "samples slower than this are left out", "0.05");
  cli.AddOption("min-samples", "N", "fewest usable samples per leg and direction", "1000");
  cli.AddOption("pressure-noise", "Pa|auto",
                "pressure sensor noise (sigma) compensated in the pressure channels; auto = "
                "estimated from the recording, 0 = no compensation", "auto");
  cli.AddOption("pressure-smoothing", "samples",
                "Gaussian smoothing (sigma) of the pressures entering the flow regressors", "0");
  cli.AddOption("direction-margin", "samples", "extra same-direction samples each side of a sample", "0");
  cli.AddOption("min-flow-dp", "Pa", "pressure channels: leave out samples near an open path's equal pressures", "5000");
  cli.AddOption("payload-scale", "s", "fix the platform payload scale instead of estimating it");
  cli.AddOption("flat-threshold", "fraction|auto",
                "a parameter whose 10 % change (others re-fitted) raises its channels' Z^2 by "
                "less than this fraction is reported as not identifiable; auto = 1 / n_eff "
                "(the objective's noise level, docs/identification.md)", "auto");
  cli.AddOption("overlay-name", "file", "name of the overlay written into --out", "identified.textproto");
  cli.AddOption("truth-overlay", "file",
                "also write an overlay holding the plant's TRUE parameters (from the recording's "
                "evaluation channel) to this file, for the closed-loop comparison");
  cli.AddOption("free-fall", "file.mcap",
                "also evaluate a free-fall recording (hexa_session / hexa_sim --experiment "
                "free-fall) by Appendix B (eq 67, 72)");
  cli.AddFlag("no-plots", "do not run the plot script");
  cli.AddFlag("no-gravity-load",
              "do not write the gravity loads of the estimated payload (BS-SMC gravity_load_n) "
              "into the overlays");
}

}  // namespace

int main(int argc, char** argv) {
  cli::Parser cli("hexa_identify",
                  "Identifies v_s, B, F_s, F_c, gamma_o, gamma_i, gamma_k per leg and stroke "
                  "direction (Table 8) from an identification recording: the GA of Table 7 and "
                  "least squares (Ceres) on the NRMSE of eq 13; writes a rig overlay, tables and "
                  "plots (docs/identification.md). Usage: hexa_identify RECORDING.mcap --out DIR");
  AddOptions(cli);
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  if (cli.positional().size() != 1 || !cli.Has("out")) {
    std::fprintf(stderr, "error: expected one RECORDING.mcap and --out DIR\n(see --help)\n");
    return 2;
  }
  const auto max_it = cli.GetInt("max-iterations", 0, 100000);
  const auto population = cli.GetInt("population", 2, 100000);
  const auto seed = cli.GetInt("seed", 0, 1LL << 62);
  const auto threads = cli.GetInt("threads", 1, 64);
  const auto window = cli.GetInt("diff-window", 3, 1001);
  const auto sigma = cli.GetDouble("diff-sigma", 0.05, 1000);
  const auto min_speed = cli.GetDouble("min-speed", 0, 10);
  const auto min_samples = cli.GetInt("min-samples", 1, 100000000);
  const bool flat_auto = cli.Get("flat-threshold") == "auto";
  const auto flat = flat_auto ? std::optional<double>(0.0) : cli.GetDouble("flat-threshold", 0, 1);
  const auto p_smooth = cli.GetDouble("pressure-smoothing", 0, 50);
  const auto margin = cli.GetInt("direction-margin", 0, 1000);
  const auto min_flow_dp = cli.GetDouble("min-flow-dp", 0, 1e6);
  if (!max_it || !population || !seed || !threads || !window || !sigma || !min_speed || !min_samples || !flat || !p_smooth || !margin || !min_flow_dp) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
  }
  std::vector<int> legs;
  if (!cli::ParseLegList(cli.Get("legs"), legs)) {
    std::fprintf(stderr, "error: --legs '%s': expected legs 1..6 as a list or range (1-6, 1,3)\n",
                 cli.Get("legs").c_str());
    return 2;
  }
  const std::string recording_path = cli.positional()[0];
  const std::string out_dir = cli.Get("out");
  const std::string method = cli.Get("method");
  const bool run_ga = method != "lsq", run_lsq = method != "ga";
  if ((cli.Get("overlay-from") == "ga" && !run_ga) || (cli.Get("overlay-from") == "lsq" && !run_lsq)) {
    std::fprintf(stderr, "error: --overlay-from %s needs that fit (--method)\n", cli.Get("overlay-from").c_str());
    return 2;
  }

  const auto loaded = config::LoadSystemConfig(cli.Get("rig"), cli.GetAll("rig-overlay"));
  if (!loaded.ok) {
    std::fprintf(stderr, "%s\n", loaded.error.c_str());
    return 1;
  }
  const config::SystemConfig& cfg = loaded.config;

  IdentificationConfig ic;
  ic.differentiator.window = static_cast<int>(*window);
  ic.differentiator.sigma = *sigma;
  ic.min_speed_m_s = *min_speed;
  ic.pressure_smoothing_samples = *p_smooth;
  ic.direction_margin_samples = static_cast<int>(*margin);
  ic.min_flow_pressure_difference_pa = *min_flow_dp;
  ic.period_s = kTickS;
  try {
    ic.Validate();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }

  IdentificationRecording rec;
  try {
    {
      progress::Line line("hexa_identify: reading " + recording_path);
      rec = ReadIdentificationRecording(recording_path, [&](std::uint64_t done, std::uint64_t size) {
        line.Update(static_cast<double>(done) / static_cast<double>(std::max<std::uint64_t>(size, 1)));
      });
    }
    for (int leg : legs) {
      const auto i = static_cast<std::size_t>(leg - 1);
      if (rec.sensor_samples[i] == 0) {
        throw IdentificationInputError(recording_path + ": leg " + std::to_string(leg) +
                                       " has no sensor samples (hexa_LegSensors)");
      }
      if (rec.command_samples[i] == 0) {
        throw IdentificationInputError(recording_path + ": leg " + std::to_string(leg) +
                                       " has no valve commands (hexa_ValveCommand)");
      }
    }
    for (const auto& p : rec.problems) std::fprintf(stderr, "warning: %s: %s\n", recording_path.c_str(), p.c_str());
    CheckRig(rec, cfg, legs);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  std::printf("%zu ticks (%.1f s), file %s; session info: %s; plant truth: %s\n", rec.ticks,
              static_cast<double>(rec.ticks) * kTickS, rec.complete_file ? "complete" : "INCOMPLETE",
              rec.session ? rec.session->rig_name().c_str() : "none",
              rec.truth ? "present (evaluation only)" : "none");

  // What the calibrated controllers believe about the rig (rig file + overlays): the joint
  // positions of the platform's inverse dynamics and the potentiometers' calibration. The
  // `realistic` plant's joints are off by up to 2 mm and its potentiometers by up to 1 mm and
  // 0.5 % gain (docs/calibration.md); left in, they bias each leg's required force and
  // measured motion, and the friction fit absorbs it (docs/identification.md, "Calibration").
  const ControllerModel model = config::MakeControllerModel(cfg);
  {
    const double mid = cfg.rig.cylinder.mid_stroke_length_m;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const PotentiometerCalibrationParams& pot = model.legs[i].potentiometer;
      if (pot.offset_m == 0.0 && pot.gain == 1.0) continue;
      for (double& l : rec.legs[i].length_m) l = mid + (l - mid - pot.offset_m) / pot.gain;
    }
  }
  if (!cfg.overlays.empty()) {
    std::printf("rig overlays applied (joint positions and potentiometer calibration):");
    for (const auto& o : cfg.overlays) std::printf(" %s", o.source_path.c_str());
    std::printf("\n");
  }
  if (!HasKinematicCalibration(cfg, legs)) {
    std::fprintf(stderr,
                 "warning: no kinematic calibration for leg(s)%s: the rig file's nominal joints and "
                 "potentiometers are used. On a rig whose joints or potentiometers are off (the "
                 "simulated 'realistic' profile: up to 2 mm, 1 mm and 0.5 %% gain) the error ends up "
                 "in the friction: F_c +9.6 %%, B -13 %% on leg 4 without it, every target met with "
                 "it (docs/identification.md, \"Calibration\"). Calibrate first (hexa_session "
                 "--trajectory calibration --tracker; hexa_calibrate SESSION.mcap --out "
                 "calibration.textproto) and pass --rig-overlay calibration.textproto.\n",
                 UncalibratedLegs(cfg, legs).c_str());
  }

  // The pressure sensors' noise, for the compensation of the pressure channels.
  double pressure_noise = 0.0;
  if (cli.Get("pressure-noise") == "auto") {
    std::vector<double> sigmas;
    for (int leg : legs) {
      const LegSeries& s = rec.legs[static_cast<std::size_t>(leg - 1)];
      sigmas.push_back(EstimateWhiteNoiseSigma(s.cap_pressure_pa, s.excited));
      sigmas.push_back(EstimateWhiteNoiseSigma(s.rod_pressure_pa, s.excited));
    }
    std::sort(sigmas.begin(), sigmas.end());
    pressure_noise = sigmas[sigmas.size() / 2];
    std::printf("pressure noise estimated from the recording: %.0f Pa (median over the legs' chambers)\n",
                pressure_noise);
  } else {
    const auto given = cli.GetDouble("pressure-noise", 0, 1e6);
    if (!given) {
      std::fprintf(stderr, "error: %s\n", cli.error().c_str());
      return 2;
    }
    pressure_noise = *given;
  }
  ic.pressure_noise_sigma_pa = ic.pressure_smoothing_samples > 0.0 ? 0.0 : pressure_noise;

  // Differentiate every leg (eq 40/41, offline), then the platform's inverse dynamics.
  const OfflineGaussianDifferentiator diff(ic.differentiator, kTickS);
  LegArray<std::vector<double>> velocity, accel;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    diff.Derivative(rec.legs[i].length_m, velocity[i]);
    diff.Derivative(velocity[i], accel[i]);
  }
  const LegArray<LoadSeries> load = ComputeLegLoads(rec, model, cfg, ic, diff, accel);

  // Datasets per leg and direction.
  const ControllerModel nominal = ControllerModel::FromRig(cfg.rig, cfg.leg_controller);  // pneumatics: the rig file's
  std::map<int, std::array<StrokeDataset, 2>> data;
  for (int leg : legs) {
    const auto i = static_cast<std::size_t>(leg - 1);
    std::array<StrokeDataset, 2> d;
    const DatasetReport report = BuildStrokeDatasets(nominal.legs[i].model, rec.legs[i], velocity[i],
                                                     accel[i], load[i], ic,
                                                     static_cast<std::size_t>(*min_samples), d);
    if (!report.ok) {
      std::fprintf(stderr, "error: %s: leg %d: %s\n", recording_path.c_str(), leg, report.error.c_str());
      return 1;
    }
    std::printf("leg %d: %zu excited ticks; samples extend %zu (|v| up to %.2f m/s), retract %zu (up to %.2f m/s)\n",
                leg, report.excited_ticks, report.samples[0], report.max_speed_m_s[0], report.samples[1],
                report.max_speed_m_s[1]);
    data[leg] = std::move(d);
  }

  // Payload scale: per leg from both directions' acceleration channel, median over the legs.
  Report report;
  report.recording = recording_path;
  report.rig_file = cfg.source_path;
  report.config = ic;
  report.truth = rec.truth;
  report.method = method;
  report.ga_params.max_iterations = static_cast<int>(*max_it);
  report.ga_params.population = static_cast<int>(*population);
  report.ga_params.seed = static_cast<std::uint64_t>(*seed);
  report.ga_params.crossover_per_pair = cli.Get("ga-crossover") == "per-pair";
  report.ga_params.mutation_step = cli.Get("ga-mutation-step") == "population" ? GaParams::MutationStep::kPopulationSpread
                                   : cli.Get("ga-mutation-step") == "success-rule" ? GaParams::MutationStep::kSuccessRule
                                                                                   : GaParams::MutationStep::kRange;
  report.threads = static_cast<int>(*threads);
  report.pressure_noise_pa = ic.pressure_noise_sigma_pa;
  report.flat_threshold = *flat;
  if (cli.Has("payload-scale")) {
    const auto s = cli.GetDouble("payload-scale", 0.05, 20);
    if (!s) {
      std::fprintf(stderr, "error: %s\n", cli.error().c_str());
      return 2;
    }
    report.payload_scale = *s;
    report.payload_estimated = false;
  } else {
    std::vector<double> per_leg;
    for (int leg : legs) {
      const auto& d = data[leg];
      const PayloadResult p = FitPayloadScale(d[0], d[1], cfg.rig.friction.extend, cfg.rig.friction.retract);
      report.payload_per_leg[leg] = p.payload_scale;
      per_leg.push_back(p.payload_scale);
      std::printf("leg %d: payload scale %.4f (acceleration channel, both directions)\n", leg, p.payload_scale);
    }
    std::sort(per_leg.begin(), per_leg.end());
    const std::size_t m = per_leg.size();
    report.payload_scale = m % 2 == 1 ? per_leg[m / 2] : 0.5 * (per_leg[m / 2 - 1] + per_leg[m / 2]);
    report.payload_estimated = true;
  }
  std::printf("payload scale used: %.4f%s\n", report.payload_scale,
              report.payload_estimated ? " (median over the legs)" : " (--payload-scale)");

  const auto range_factor = cli.GetDouble("ga-range-factor", 1.0001, 100);
  if (!range_factor) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
  }
  report.ga_space = cli.Get("ga-space");
  report.ga_range_factor = *range_factor;
  for (int leg : legs) {
    for (int dir = 0; dir < 2; ++dir) {
      report.strokes.push_back(FitStroke(data[leg][static_cast<std::size_t>(dir)], leg, dir, cfg, report, run_lsq,
                                         run_ga, *flat));
    }
  }

  if (cli.Has("free-fall")) {
    try {
      EvaluateFreeFall(cli.Get("free-fall"), cfg, legs, report);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
  }

  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "error: cannot create %s: %s\n", out_dir.c_str(), ec.message().c_str());
    return 1;
  }

  // The overlay: identifiable parameters of the chosen fit, validated before it is written.
  const bool from_ga = cli.Get("overlay-from") == "ga";
  const bool gravity = !cli.Flag("no-gravity-load");
  config::RigOverlay overlay = MakeOverlay(report, cfg, from_ga, gravity);
  overlay.provenance.source_recording = fs::absolute(recording_path).string();
  overlay.provenance.date = UtcNow();
  overlay.provenance.tool = "hexa_identify";
  const std::string overlay_path = out_dir + "/" + cli.Get("overlay-name");
  report.overlay_path = overlay_path;
  report.overlay_error = WriteValidatedOverlay(overlay, cfg, overlay_path,
                                               "Written by hexa_identify: identified parameters, not edited.");
  report.overlay_refused = !report.overlay_error.empty();
  if (!report.overlay_refused) {
    std::printf("rig overlay written: %s\n", overlay_path.c_str());
  } else {
    std::fprintf(stderr, "REFUSED: the identified values break the rig file's limits; no overlay written:\n%s\n",
                 report.overlay_error.c_str());
  }
  if (cli.Has("truth-overlay")) {
    if (!rec.truth) {
      std::fprintf(stderr, "error: --truth-overlay: the recording has no hexa_PlantTruth channel\n");
      return 1;
    }
    const std::string error = WriteValidatedOverlay(MakeTruthOverlay(*rec.truth, cfg, gravity), cfg,
                                                    cli.Get("truth-overlay"),
                                                    "The simulated plant's TRUE parameters (evaluation).");
    if (!error.empty()) {
      std::fprintf(stderr, "error: the truth overlay does not validate:\n%s\n", error.c_str());
      return 1;
    }
    std::printf("truth overlay written: %s\n", cli.Get("truth-overlay").c_str());
  }

  WriteReport(report, data, out_dir);
  std::printf("tables: %s/identification.md, data: %s/identification.json\n", out_dir.c_str(), out_dir.c_str());
  if (!cli.Flag("no-plots")) {
    const std::string cmd = "/usr/bin/python3 " + std::string(HEXA_SOURCE_DIR) +
                            "/tools/identify/plot_identification.py " + out_dir;
    if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "warning: the plot script failed (%s)\n", cmd.c_str());
  }
  return report.overlay_refused ? 3 : 0;
}
