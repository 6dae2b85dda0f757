// hexa_calibrate: kinematic calibration from a recorded calibration session.
//
//   hexa_session --trajectory calibration --tracker --out DIR      (records DIR/session.mcap)
//   hexa_calibrate DIR/session.mcap [--out overlay.textproto] [--truth-seed N]
//
// Reads the external instrument's poses (hexa_TrackerPose), the potentiometer readings
// (hexa_LegSensors) and the supervisor's desired pose (hexa_PoseReport) from the recording;
// finds the still windows (desired pose unchanged for at least --min-still s) and averages
// the last --window s of each; checks that the poses identify the 8 parameters of every leg
// (rank, condition, predicted uncertainty; refuses otherwise, exit 3); fits the base and
// platform joints and the potentiometer offsets and gains with Ceres (least squares); prints
// the per-leg report and, for a simulated rig, the error of every parameter against the
// plant's truth (--truth-seed). Then the platform's payload from the same recording's moves
// (chamber pressures against the platform's weight through the calibrated geometry,
// core/payload_estimation.hpp), reported with its standard error and written to the overlay's
// `platform` block when it is that precise (--payload-max-std).
#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "calibration_fit.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/core/payload_estimation.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/services/progress.hpp"
#include "hexa/services/cli.hpp"
#include "recording.pb.h"

namespace {

using hexa::kNumLegs;

template <typename T>
T Parse(const hexa::recorder::McapMessageView& view) {
  T msg;
  if (!msg.ParseFromArray(view.data.data(), static_cast<int>(view.data.size()))) {
    throw std::runtime_error("cannot parse a " + T::descriptor()->name() + " message");
  }
  return msg;
}

// Prints the payload estimate; true when it is precise enough to be written.
bool ReportPayload(const hexa::PayloadEstimate& p, const hexa::RigParams& rig, double max_std) {
  if (!p.ok) {
    std::printf("\npayload: not estimated (%s); the overlay leaves the rig file's platform\n", p.message.c_str());
    return false;
  }
  std::printf("\npayload (leg forces while sliding, friction per leg and direction fitted with it):\n"
              "leg | sliding samples | payload scale | residual N\n");
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const auto& l = p.legs[i];
    std::printf("%zu   | %zu | %.4f | %.2f\n", i + 1, l.samples, l.scale, l.residual_rms_n);
  }
  std::printf("payload scale %.4f +- %.4f (1 sigma, the legs' scatter): platform mass %.3f kg +- %.3f "
              "(rig file %.3f kg), inertia scaled alike\n", p.scale, p.scale_std, p.mass_kg,
              p.scale_std * rig.platform.mass_kg, rig.platform.mass_kg);
  if (p.failed_kinematics > 0) std::printf("  (%zu samples left out: forward kinematics failed)\n", p.failed_kinematics);
  if (!p.precise) {
    std::printf("warning: the payload's standard error %.4f exceeds --payload-max-std %.4f: not written; "
                "the controllers keep the rig file's platform\n", p.scale_std, max_std);
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli(
      "hexa_calibrate",
      "Kinematic calibration (base / platform joints, potentiometer offset and gain) from a "
      "recorded calibration session with an external pose instrument (hexa_session "
      "--trajectory calibration --tracker). Usage: hexa_calibrate RECORDING.mcap [options]");
  cli.AddOption("rig", "file", "rig file: the nominal model to calibrate", hexa::config::DefaultRigFile());
  cli.AddOption("min-still", "s", "a still window: desired pose unchanged at least this long", "4");
  cli.AddOption("window", "s", "use the last this-many seconds of each still window", "2");
  cli.AddOption("noise-mm", "mm",
                "1-sigma error of one averaged still sample (reading and pose), for the "
                "identifiability check", "0.035");
  cli.AddOption("max-poses", "N", "use only the first N samples (0 = all; to test the refusal)", "0");
  cli.AddOption("out", "file",
                "write the calibrated rig overlay here (joints, potentiometer offset and gain; "
                "services accept it with --rig-overlay)");
  cli.AddOption("truth-seed", "N",
                "simulated rig: compare every parameter with the plant's truth for this seed");
  cli.AddOption("truth-profile", "name", "disturbance profile of the simulated rig", "realistic");
  cli.AddFlag("no-payload",
              "do not estimate the platform's payload (the overlay then has no platform block: the "
              "controllers keep the rig file's platform mass)");
  cli.AddOption("payload-max-std", "fraction",
                "write the payload estimate only if its standard error is at most this fraction "
                "of the rig file's platform mass",
                std::to_string(hexa::PayloadEstimatorConfig{}.max_scale_std).substr(0, 4));
  cli.AllowPositional("RECORDING.mcap", 1);
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto min_still = cli.GetDouble("min-still", 0.01, 1e4);
  const auto window = cli.GetDouble("window", 0.005, 1e4);
  const auto noise_mm = cli.GetDouble("noise-mm", 1e-9, 10);
  const auto max_poses = cli.GetInt("max-poses", 0, 1000000);
  const auto payload_max_std = cli.GetDouble("payload-max-std", 0.0, 1.0);
  if (!min_still || !window || !noise_mm || !max_poses || !payload_max_std) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
  }
  if (cli.positional().size() != 1) {
    std::fprintf(stderr, "error: give exactly one recording (see --help)\n");
    return 2;
  }
  const std::string recording = cli.positional().front();
  const auto loaded = hexa::config::LoadSystemConfig(cli.Get("rig"));
  if (!loaded.ok) {
    std::fprintf(stderr, "%s\n", loaded.error.c_str());
    return 1;
  }
  const hexa::RigParams& rig = loaded.config.rig;
  const double mid = rig.cylinder.mid_stroke_length_m;

  // 1. Read the three topics; 2. still windows from the desired pose, the last `window`
  // seconds of each averaged (core CalibrationSampleCollector).
  hexa::CalibrationSampleCollector collector(hexa::StillWindowParams{*min_still, *window, 0.001});
  hexa::PayloadRecord payload_record;
  const bool estimate_payload = !cli.Flag("no-payload");
  try {
    hexa::progress::Line line("hexa_calibrate: reading " + recording);
    hexa::recorder::McapScanOptions scan;
    scan.progress = [&](uint64_t done, uint64_t size) {
      line.Update(static_cast<double>(done) / static_cast<double>(std::max<uint64_t>(size, 1)));
    };
    const hexa::recorder::McapScanResult result = hexa::recorder::ReadRecording(
        recording, [&](const hexa::recorder::McapChannel& ch,
                       const hexa::recorder::McapMessageView& view,
                       const google::protobuf::Message&) {
          if (ch.topic == "hexa_TrackerPose") {
            const auto m = Parse<hexa::rec::TrackerPose>(view);
            if (m.position_m_size() != 3 || m.orientation_wxyz_size() != 4) return;
            collector.AddTracker(m.header().tick(),
                                 {m.position_m(0), m.position_m(1), m.position_m(2)},
                                 Eigen::Quaterniond(m.orientation_wxyz(0), m.orientation_wxyz(1),
                                                    m.orientation_wxyz(2), m.orientation_wxyz(3)));
          } else if (ch.topic == "hexa_LegSensors") {
            const auto m = Parse<hexa::rec::LegSensors>(view);
            if (m.leg_id() < 1 || m.leg_id() > 6) return;
            collector.AddReading(m.header().tick(), m.leg_id() - 1, m.length_m());
            if (estimate_payload) {
              payload_record.Add(m.header().tick(), m.leg_id() - 1, m.length_m(), m.cap_pressure_pa(),
                                 m.rod_pressure_pa());
            }
          } else if (ch.topic == "hexa_PoseReport") {
            const auto m = Parse<hexa::rec::PoseReport>(view);
            if (m.desired_pose_size() != 6) return;
            hexa::Vector6d q;
            for (int k = 0; k < 6; ++k) q[k] = m.desired_pose(k);
            collector.AddDesired(m.header().tick(), q, m.state() != hexa::rec::SUPERVISOR_HOLD);
          }
        },
        scan);
    line.Done();
    for (const auto& p : result.problems) std::fprintf(stderr, "warning: %s: %s\n", recording.c_str(), p.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s: %s\n", recording.c_str(), e.what());
    return 1;
  }
  const std::size_t tracker_samples = collector.tracker_count();
  if (tracker_samples == 0) {
    std::fprintf(stderr,
                 "error: %s has no hexa_TrackerPose samples: record the calibration session with "
                 "the external instrument on (hexa_session --trajectory calibration --tracker)\n",
                 recording.c_str());
    return 1;
  }
  std::vector<hexa::CalibrationSample> samples = collector.Samples();
  if (*max_poses > 0 && samples.size() > static_cast<std::size_t>(*max_poses)) {
    samples.resize(static_cast<std::size_t>(*max_poses));
  }
  std::printf("hexa_calibrate: %s: %zu tracker measurements, %zu used as samples (still windows "
              ">= %.2f s, their last %.2f s; readings averaged over each measurement's 10 ms)\n",
              recording.c_str(), tracker_samples, samples.size(), *min_still, *window);

  // 3. Identifiability, then the fit.
  hexa::calib::FitOptions options;
  options.limits.reading_noise_m = *noise_mm * 1e-3;
  const hexa::KinematicCalibration nominal = hexa::NominalCalibration(rig.geometry);
  const hexa::calib::FitResult fit =
      hexa::calib::FitKinematicCalibration(samples, mid, nominal, options);
  std::printf("\nidentifiability (column-scaled Jacobian, %d samples, %.4f mm noise each):\n",
              fit.identifiability.samples, *noise_mm);
  std::printf("leg | rank | condition | predicted 1-sigma: joint max mm, offset mm, gain | weakest\n");
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const auto& l = fit.identifiability.legs[i];
    std::printf("%zu   | %d/8  | %9.3g | %.4f %.4f %.2e | %s\n", i + 1, l.rank, l.condition,
                1e3 * l.predicted_std.head<6>().maxCoeff(), 1e3 * l.predicted_std[6],
                l.predicted_std[7], l.weakest.c_str());
  }
  if (!fit.identifiability.identifiable) {
    std::fprintf(stderr, "\nhexa_calibrate: %s\n", fit.message.c_str());
    return 3;
  }
  std::printf("\nfit (Ceres, per leg):\nleg | converged | iterations | reading rms mm before -> after\n");
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const auto& l = fit.legs[i];
    std::printf("%zu   | %s | %d | %.4f -> %.5f\n", i + 1, l.converged ? "yes" : "NO", l.iterations,
                1e3 * l.initial_rms_m, 1e3 * l.final_rms_m);
  }
  if (!fit.ok) {
    std::fprintf(stderr, "hexa_calibrate: %s\n", fit.message.c_str());
    return 1;
  }

  // 4. The payload: the platform's weight and inertia forces against the leg forces while the
  // legs slide (core/payload_estimation.hpp), with the fitted calibration.
  hexa::PayloadEstimate payload;
  bool write_payload = false;
  if (estimate_payload) {
    hexa::PayloadEstimatorConfig pc;
    pc.max_scale_std = *payload_max_std;
    payload = hexa::EstimatePayload(rig, fit.calibration, payload_record, pc);
    write_payload = ReportPayload(payload, rig, pc.max_scale_std);
  }

  // 5. The calibrated rig overlay, validated by loading it on the rig file.
  if (cli.Has("out")) {
    hexa::config::RigOverlay overlay;
    overlay.rig_name = loaded.config.rig_name;
    overlay.provenance.source_recording = recording;
    overlay.provenance.method =
        "kinematic calibration: least squares (Ceres) of the potentiometer readings at " +
        std::to_string(samples.size()) + " tracker-measured still samples";
    overlay.provenance.tool = "hexa_calibrate";
    char date[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    overlay.provenance.date = date;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      hexa::config::LegOverride& leg = overlay.leg[i];
      leg.p_BA_B_m = fit.calibration[i].p_BA_B_m;
      leg.p_PB_P_m = fit.calibration[i].p_PB_P_m;
      leg.potentiometer_offset_m = fit.calibration[i].potentiometer_offset_m;
      leg.potentiometer_gain = fit.calibration[i].potentiometer_gain;
    }
    if (write_payload) {
      overlay.platform.mass_kg = payload.mass_kg;
      overlay.platform.inertia_diag_kg_m2 = payload.inertia_diag_kg_m2;
      char note[160];
      std::snprintf(note, sizeof(note),
                    "platform: payload scale %.4f +- %.4f (1 sigma) of the rig file's mass and inertia, "
                    "from the leg forces while the legs slide", payload.scale, payload.scale_std);
      overlay.provenance.note = note;
    }
    const std::string path = cli.Get("out");
    {
      std::ofstream file(path);
      file << hexa::config::ToTextFormat(overlay);
      if (!file) {
        std::fprintf(stderr, "error: cannot write %s\n", path.c_str());
        return 1;
      }
    }
    const auto check = hexa::config::LoadSystemConfig(cli.Get("rig"), {path});
    if (!check.ok) {
      std::fprintf(stderr, "error: the written overlay does not validate: %s\n", check.error.c_str());
      return 1;
    }
    std::printf("\nwrote the calibrated rig overlay %s (validated against %s); use it with "
                "--rig-overlay %s\n", path.c_str(), cli.Get("rig").c_str(), path.c_str());
  }

  // 6. Against the simulated plant's truth.
  if (cli.Has("truth-seed")) {
    const auto seed = cli.GetInt("truth-seed", 0, 1LL << 62);
    const auto profile = loaded.config.profiles.find(cli.Get("truth-profile"));
    if (!seed || profile == loaded.config.profiles.end()) {
      std::fprintf(stderr, "error: --truth-seed / --truth-profile: %s\n", cli.error().c_str());
      return 2;
    }
    hexa::PlatformPlantConfig pc;
    pc.rig = rig;
    pc.disturbance = profile->second;
    pc.seed = static_cast<std::uint64_t>(*seed);
    const hexa::PlatformPlant plant(pc);
    const auto& names = hexa::CalibrationParameterNames();
    double worst_joint_before = 0, worst_joint = 0, worst_offset_before = 0, worst_offset = 0,
           worst_gain_before = 0, worst_gain = 0;
    std::printf("\nagainst the plant's truth (seed %lld, profile %s): error before -> after "
                "(mm; gain in ppm)\n", *seed, profile->first.c_str());
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      hexa::LegCalibration truth;
      truth.p_BA_B_m = plant.true_geometry().p_BA_B[i];
      truth.p_PB_P_m = plant.true_geometry().p_PB_P[i];
      truth.potentiometer_offset_m = plant.sensors().calibration().offset_m[i];
      truth.potentiometer_gain = 1.0 + plant.sensors().calibration().gain_error[i];
      const hexa::LegCalibrationVector before = nominal[i].AsVector() - truth.AsVector();
      const hexa::LegCalibrationVector after = fit.calibration[i].AsVector() - truth.AsVector();
      std::printf("leg %zu:", i + 1);
      for (int k = 0; k < hexa::kCalibrationParamsPerLeg; ++k) {
        const double unit = k < 7 ? 1e3 : 1e6;
        std::printf(" %s %+.3f -> %+.4f%s", names[static_cast<std::size_t>(k)], unit * before[k],
                    unit * after[k], k + 1 < hexa::kCalibrationParamsPerLeg ? ";" : "\n");
      }
      worst_joint_before = std::max(worst_joint_before, before.head<6>().cwiseAbs().maxCoeff());
      worst_joint = std::max(worst_joint, after.head<6>().cwiseAbs().maxCoeff());
      worst_offset_before = std::max(worst_offset_before, std::abs(before[6]));
      worst_offset = std::max(worst_offset, std::abs(after[6]));
      worst_gain_before = std::max(worst_gain_before, std::abs(before[7]));
      worst_gain = std::max(worst_gain, std::abs(after[7]));
    }
    std::printf("worst |error| per parameter kind: joint coordinate %.3f -> %.4f mm, "
                "potentiometer offset %.3f -> %.4f mm, gain %.0f -> %.1f ppm\n",
                1e3 * worst_joint_before, 1e3 * worst_joint, 1e3 * worst_offset_before,
                1e3 * worst_offset, 1e6 * worst_gain_before, 1e6 * worst_gain);
    if (estimate_payload && payload.ok) {
      const double truth = profile->second.payload_scale;
      std::printf("payload scale: estimate %.4f +- %.4f, truth %.4f, error %+.4f (%.1f sigma)\n",
                  payload.scale, payload.scale_std, truth, payload.scale - truth,
                  payload.scale_std > 0 ? std::abs(payload.scale - truth) / payload.scale_std : 0.0);
    }
  }
  return 0;
}
