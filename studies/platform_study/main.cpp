// platform_study: tuning and diagnosis of the leg controllers ON THE FULL PLATFORM, in the
// in-process lockstep simulation (RunPaperSession, same protocol as the DDS system).
// docs/measurements/tuning.md gives the grids run with it and the figures. This file holds the
// options and keys; platform_study.hpp lists the subcommands, one source file per group.
//
//   platform_study [--rig file|default] [--seed N] [--controller bssmc|pi] [--ideal] [--traj all|x,y,...]
//                  [--periods N] [key=value ...]
//   platform_study trace <traj> [options]      per-tick CSV of the legs (stdout)
//   platform_study fit <traj> [options]        first-harmonic fit of the tracking window:
//        per axis and per leg the amplitude ratio true/desired, the phase lag, the mean peak
//        overshoot and what remains after removing the fitted harmonic, that first harmonic
//        split into its amplitude and timing parts and the rest's RMS by frequency band
//   platform_study legs <traj> [options]       per-leg lag against the trajectory of NOW (no
//        setpoint lead) and the force budget along each leg (see Legs below)
//   platform_study reversals <traj> [options]  where the moving axis' error is made (pure
//        z): share of the squared error within +-N ms of the desired motion's
//        reversals, bias / first harmonic / rest, the rest's share above 1 Hz, and per leg
//        the stick-slip (see Reversals below)
//   platform_study zsplit <traj> [options]    the z error through the legs, split on the
//        leg-space modes at home (see ZSplit below)
//   platform_study modes [options]             leg-space modal masses at home and the BS-SMC
//        velocity loop's crossover and phase margin on each (see Modes below)
//
// --calibrate (needs --rig): first the kinematic calibration procedure in process, exactly as
// hexa_sim --calibrate (tools/calibrate/calibrate_in_process.hpp), then the run with the
// fitted calibration in the controllers: the acceptance figures' configuration.
// Overrides (key=value) start from the struct defaults (= deploy/rigs/hexataar_r.textproto):
// see kKeys below. Output: per trajectory the RMSE vs ground truth per axis (cm, deg), leg
// RMSE (mm), fraction of ticks with a saturated valve, and the score: the mean over the
// seven trajectories of (moving-axis RMSE / paper's value for that axis), i.e. 1.0 = the
// paper's Table 9 / Table 10 accuracy on average.
// Valve activity (docs/measurements/tuning.md "Valve chatter"), over the TRACKING window, all six legs:
//   du   mean |u(k) - u(k-1)| per 1 ms tick, V
//   sat  fraction of ticks with u < 0.05 V or u > 9.95 V
//   flip extend <-> retract reversals of the command per leg and second (u below 3 V counts as
//        extend, above 7 V as retract; a 25 Hz full-swing limit cycle gives 50)
// and once per run the same figures at IDLE (3 s of idle hold at home, after 0.5 s settling).
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calibrate_in_process.hpp"
#include "coupled_leg_feedback.hpp"
#include "hexa/config/rig_config.hpp"
#include "platform_observer_feedback.hpp"
#include "platform_study.hpp"

namespace {

using hexa::PaperMotion;
using platform_study::g_combined_axis_scale;

struct Key {
  const char* name;
  std::function<void(hexa::LockstepConfig&, double)> set;
};

// Coupled leg feedback (studies/coupled_leg_feedback, docs/measurements/control_coupled_feedback.md).
struct CoupledKey {
  const char* name;
  std::function<void(hexa::study::CoupledLegFeedbackParams&, double)> set;
};

std::vector<CoupledKey> CoupledKeys() {
  return {
      {"coupled", [](auto& c, double v) { c.enabled = v != 0.0; }},
      {"coupled_mref", [](auto& c, double v) { c.reference_mass_kg = v; }},
      {"coupled_obsv", [](auto& c, double v) { c.observer_velocity = v != 0.0; }},
      {"coupled_raise", [](auto& c, double v) { c.raise_only = v != 0.0; }},
  };
}

// The legs' velocity from the platform state observer (studies/platform_observer_feedback,
// docs/controller.md "Platform state observer"). Applied after --calibrate's procedure, which
// runs with the system's legs.
hexa::study::PlatformObserverFeedbackParams g_platform_observer;
// The system's coupled leg feedback (hexa/core/coupled_legs.hpp), keys cl, cl_gain, cl_cutoff,
// cl_raise; like pobs, applied after --calibrate's procedure (the user calibrates with the
// decoupled legs, docs/calibration.md).
hexa::CoupledLegsParams g_coupled_legs;
// cl_pose=1 / 2 / 3: with cl=1, W at the supervisor's desired pose / pose estimate, refreshed
// every supervisor tick / at home, through the study's runner (PoseCouplingRowRunnerFactory).
int g_coupled_legs_pose = 0;

std::vector<Key> Keys() {
  return {
      {"pobs", [](auto&, double v) { g_platform_observer.enabled = v != 0.0; }},
      {"cl", [](auto&, double v) { g_coupled_legs.enabled = v != 0.0; }},
      {"cl_gain", [](auto&, double v) { g_coupled_legs.gain = v; }},
      {"cl_cutoff", [](auto&, double v) { g_coupled_legs.cutoff_hz = v; }},
      {"cl_raise", [](auto&, double v) { g_coupled_legs.raise_only = v != 0.0; }},
      {"cl_pose", [](auto&, double v) { g_coupled_legs_pose = static_cast<int>(v); }},
      {"pobs_rate", [](auto&, double v) { g_platform_observer.disturbance_rate_m_s3 = v; }},
      {"lambda", [](auto& c, double v) { c.leg_controller.bssmc.lambda_1_s = v; }},
      {"K", [](auto& c, double v) { c.leg_controller.bssmc.switching_gain_n = v; }},
      {"xi", [](auto& c, double v) { c.leg_controller.bssmc.boundary_layer_xi_s_m = v; }},
      {"beta", [](auto& c, double v) { c.leg_controller.bssmc.backstepping_beta_1_s = v; }},
      {"M", [](auto& c, double v) { c.leg_controller.bssmc.effective_mass_kg = v; }},
      {"Fg", [](auto& c, double v) { c.leg_controller.bssmc.gravity_load_n = v; }},
      {"visc", [](auto& c, double v) { c.leg_controller.bssmc.viscous_estimate_scale = v; }},
      {"fric", [](auto& c, double v) { c.leg_controller.bssmc.friction_estimate_scale = v; }},
      {"ks", [](auto& c, double v) { c.leg_controller.bssmc.reaching_proportional_n_s_m = v; }},
      {"band", [](auto& c, double v) { c.leg_controller.bssmc.null_band_area_fraction = v; }},
      {"tau", [](auto& c, double v) { c.leg_controller.bssmc.spool_filter_time_constant_s = v; }},
      {"sigma", [](auto& c, double v) { c.leg_controller.differentiator.sigma = v; }},
      {"lag", [](auto& c, double v) { c.leg_controller.differentiator.centre_lag_samples = v; }},
      {"kp", [](auto& c, double v) { c.leg_controller.pi.proportional_v_m = v; }},
      {"ki", [](auto& c, double v) { c.leg_controller.pi.integral_v_m_s = v; }},
      {"ilim", [](auto& c, double v) { c.leg_controller.pi.integrator_limit_v = v; }},
      {"kv", [](auto& c, double v) { c.leg_controller.pi.velocity_feedforward_v_s_m = v; }},
      {"kd", [](auto& c, double v) { c.leg_controller.pi.rate_damping_v_s_m = v; }},
      {"ol", [](auto& c, double v) { c.supervisor.outer_loop.enabled = v != 0.0; }},
      {"ol_gain", [](auto& c, double v) { c.supervisor.outer_loop.gain = v; }},
      {"ol_pos", [](auto& c, double v) { c.supervisor.outer_loop.translation_gain_scale = v; }},
      {"ol_max", [](auto& c, double v) { c.supervisor.outer_loop.max_correction_m = v; }},
      {"ol_gate", [](auto& c, double v) { c.supervisor.outer_loop.gate_leg_speed_m_s = v; }},
      {"lead", [](auto& c, double v) { c.supervisor.setpoint_lead_s = v; }},
      {"ff", [](auto& c, double v) { c.supervisor.feedforward_enabled = v != 0.0; }},
      // Feedback part's rate in phi_dot: fraction alpha and low-pass tau_fb.
      {"fb_alpha", [](auto& c, double v) { c.leg_controller.bssmc.feedback_rate_fraction = v; }},
      {"fb_tau", [](auto& c, double v) { c.leg_controller.bssmc.feedback_rate_time_constant_s = v; }},
      {"fb_speed", [](auto& c, double v) { c.leg_controller.bssmc.feedback_rate_full_speed_m_s = v; }},
      {"fb_obs", [](auto& c, double v) { c.leg_controller.bssmc.feedback_rate_from_observer = v != 0.0; }},
      {"obs_m", [](auto& c, double v) { c.leg_controller.bssmc.observer_mass_kg = v; }},
      {"obs_x", [](auto& c, double v) { c.leg_controller.bssmc.observer_length_sigma_m = v; }},
      {"obs_f", [](auto& c, double v) { c.leg_controller.bssmc.observer_force_sigma_n = v; }},
      {"obs_d", [](auto& c, double v) { c.leg_controller.bssmc.observer_disturbance_rate_m_s3 = v; }},
      {"kf", [](auto& c, double v) { c.leg_controller.pi.force_feedforward_v_n = v; }},
      // BS-SMC integral of S and friction compensation (pure z).
      {"ki_n", [](auto& c, double v) { c.leg_controller.bssmc.integral_gain_n_m = v; }},
      {"iact", [](auto& c, double v) { c.leg_controller.bssmc.integral_active_below_m_s = v; }},
      {"ileak", [](auto& c, double v) { c.leg_controller.bssmc.integral_leak_time_constant_s = v; }},
      {"ilim_n", [](auto& c, double v) { c.leg_controller.bssmc.integral_limit_n = v; }},
      {"idb", [](auto& c, double v) { c.leg_controller.bssmc.integral_deadband_m = v; }},
      {"fsmooth", [](auto& c, double v) { c.leg_controller.bssmc.friction_smoothing_velocity_m_s = v; }},
      // Dither: amplitude N (0 = off, the paper's eq 14), frequency Hz, gate speed m/s.
      {"dither", [](auto& c, double v) { c.leg_controller.bssmc.dither_amplitude_n = v; }},
      {"dither_hz", [](auto& c, double v) { c.leg_controller.bssmc.dither_frequency_hz = v; }},
      {"fadapt", [](auto& c, double v) { c.leg_controller.bssmc.friction_adaptation_rate_1_n_m = v; }},
      {"fadapt_speed", [](auto& c, double v) { c.leg_controller.bssmc.friction_adaptation_speed_m_s = v; }},
      {"dither_gate", [](auto& c, double v) { c.leg_controller.bssmc.dither_gate_speed_m_s = v; }},
      // Plant-only changes (diagnosis): the valve spool's time constant (the
      // controllers do not use it), and the plant's friction model (0 LuGre, 1 static eq 3).
      {"pspool", [](auto& c, double v) { c.rig.valve.spool_time_constant_s = v; }},
      // The plant's friction scale (the disturbance profile's; 1 = the rig file's Table 8
      // values, the realistic profile 1.2). With fric= and visc= (the controllers' estimate
      // scales) it gives a rig whose friction the controllers know at any magnitude.
      {"pfric", [](auto& c, double v) { c.disturbance.friction_scale = v; }},
      // The rest of the disturbance profile, one factor at a time (the `realistic` values:
      // pnoise=1, ppoly=1.1, ppay=1.2, pripple=20000 Pa, pjoint=0.002 m, ppot=0.001 m,
      // ppotgain=0.005; `ideal`: 0, 1, 1, 0, 0, 0, 0).
      {"pnoise", [](auto& c, double v) { c.disturbance.sensor_noise = v != 0.0; }},
      {"ppoly", [](auto& c, double v) { c.disturbance.polytropic_scale = v; }},
      {"ppay", [](auto& c, double v) { c.disturbance.payload_scale = v; }},
      {"pripple", [](auto& c, double v) { c.disturbance.supply_ripple_amplitude_pa = v; }},
      {"pjoint", [](auto& c, double v) { c.disturbance.joint_position_error_max_m = v; }},
      {"ppot", [](auto& c, double v) { c.disturbance.potentiometer_offset_max_m = v; }},
      {"ppotgain", [](auto& c, double v) { c.disturbance.potentiometer_gain_error_max = v; }},
      // The plant's LuGre bristle damping sigma1 (the controllers do not use it).
      {"psigma1", [](auto& c, double v) { c.rig.friction.bristle_damping_n_s_m = v; }},
      {"pfric_static", [](auto& c, double v) {
         c.plant_friction_model = v != 0.0 ? hexa::LegModelParams::FrictionModel::kStatic
                                           : hexa::LegModelParams::FrictionModel::kLugre;
       }},
      // Supervisor period in ticks (5 = the system's 5 ms; 1 = a setpoint every tick, no
      // interpolation inside the period). The outer-loop gain is per supervisor step: scale
      // it with ol_gain to keep its integral rate.
      // Per-axis amplitude scale of the combined motion (study only; see PaperStart).
      {"ax", [](auto&, double v) { g_combined_axis_scale[0] = v; }},
      {"ay", [](auto&, double v) { g_combined_axis_scale[1] = v; }},
      {"az", [](auto&, double v) { g_combined_axis_scale[2] = v; }},
      {"sup_every", [](auto& c, double v) {
         c.supervisor_every_ticks = static_cast<int>(v);
         c.supervisor.period_s = v * c.tick_s;
       }},
  };
}

int Usage() {
  std::fprintf(stderr,
               "usage: platform_study [trace|fit|legs|reversals|zsplit <traj> | modes] [--rig file|default] [--calibrate] [--seed N] [--controller bssmc|pi] [--ideal]\n"
               "       [--traj all|x,y,z,roll,pitch,yaw,combined] [--periods N] [key=value ...]\n"
               "keys:");
  for (const auto& k : Keys()) std::fprintf(stderr, " %s", k.name);
  std::fprintf(stderr, "\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::LockstepConfig config;
  config.seed = 1;
  std::vector<PaperMotion> motions = {PaperMotion::kX,    PaperMotion::kY,     PaperMotion::kZ,
                                      PaperMotion::kRoll, PaperMotion::kPitch, PaperMotion::kYaw,
                                      PaperMotion::kCombined};
  int periods = 0;
  std::string subcommand;  // empty: the accuracy score over `motions`
  bool calibrate = false;
  std::optional<hexa::config::SystemConfig> loaded_rig;
  const auto keys = Keys();
  const auto coupled_keys = CoupledKeys();
  hexa::study::CoupledLegFeedbackParams coupled;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto next = [&]() -> std::string { return a + 1 < argc ? argv[++a] : std::string(); };
    if (arg == "trace" || arg == "fit" || arg == "legs" || arg == "reversals" || arg == "zsplit") {
      subcommand = arg;
      PaperMotion m;
      if (!hexa::ParsePaperMotion(next(), m)) return Usage();
      motions = {m};
    } else if (arg == "modes") {
      subcommand = arg;
    } else if (arg == "--seed") {
      config.seed = std::strtoull(next().c_str(), nullptr, 10);
    } else if (arg == "--controller") {
      const std::string c = next();
      config.controller = c == "pi" ? hexa::LegControllerKind::kPi : hexa::LegControllerKind::kBsSmc;
    } else if (arg == "--rig") {
      // Start from a rig file (as hexa_sim does) instead of the struct defaults; overrides
      // given AFTER --rig apply on top of it.
      std::string path = next();
      if (path == "default") path = hexa::config::DefaultRigFile();
      const auto loaded = hexa::config::LoadSystemConfig(path);
      if (!loaded.ok) {
        std::fprintf(stderr, "%s\n", loaded.error.c_str());
        return 1;
      }
      config.rig = loaded.config.rig;
      config.leg_controller = loaded.config.leg_controller;
      config.supervisor = loaded.config.supervisor;
      config.disturbance = loaded.config.profiles.at(loaded.config.default_profile);
      loaded_rig = loaded.config;
    } else if (arg == "--calibrate") {
      calibrate = true;
    } else if (arg == "--ideal") {
      config.disturbance = hexa::MakeIdealDisturbanceProfile();
    } else if (arg == "--periods") {
      periods = std::atoi(next().c_str());
    } else if (arg == "--traj") {
      const std::string list = next();
      if (list != "all") {
        motions.clear();
        std::size_t pos = 0;
        while (pos <= list.size()) {
          const std::size_t comma = list.find(',', pos);
          const std::string name = list.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
          PaperMotion m;
          if (!hexa::ParsePaperMotion(name, m)) return Usage();
          motions.push_back(m);
          if (comma == std::string::npos) break;
          pos = comma + 1;
        }
      }
    } else if (const auto eq = arg.find('='); eq != std::string::npos) {
      const std::string k = arg.substr(0, eq);
      bool found = false;
      for (const auto& key : keys) {
        if (k == key.name) {
          key.set(config, std::strtod(arg.c_str() + eq + 1, nullptr));
          found = true;
        }
      }
      for (const auto& key : coupled_keys) {
        if (k == key.name) {
          key.set(coupled, std::strtod(arg.c_str() + eq + 1, nullptr));
          found = true;
        }
      }
      if (!found) return Usage();
    } else {
      return Usage();
    }
  }
  config.leg_runner = hexa::study::CoupledLegRunnerFactory(coupled);
  if (calibrate) {
    if (!loaded_rig) {
      std::fprintf(stderr, "--calibrate needs --rig\n");
      return 2;
    }
    // As hexa_sim --calibrate, with the key=value overrides of the leg controllers' parameters
    // (the rig file's nominal leg model, every leg the same parameters: the default rig file has
    // no per-leg overrides), then the fit.
    config.controllers = hexa::ControllerModel::FromRig(loaded_rig->rig, config.leg_controller);
    hexa::KinematicCalibration calibration;
    hexa::PayloadEstimate payload;
    if (!hexa::calib::CalibrateInProcess(config, calibration, stderr, payload)) return 1;
    hexa::calib::ApplyKinematicCalibration(calibration, payload, config);
  }
  config.leg_controller.coupled = g_coupled_legs;
  if (config.controllers)
    for (auto& leg : config.controllers->legs) leg.params.coupled = g_coupled_legs;
  if (g_platform_observer.enabled) {
    if (coupled.enabled) {
      std::fprintf(stderr, "pobs=1 and coupled=1 are exclusive (one leg runner)\n");
      return 2;
    }
    config.leg_runner = hexa::study::PlatformObserverLegRunnerFactory(g_platform_observer);
  }
  if (g_coupled_legs_pose != 0) {
    if (coupled.enabled || g_platform_observer.enabled || !g_coupled_legs.enabled) {
      std::fprintf(stderr, "cl_pose needs cl=1 and excludes coupled=1 and pobs=1 (one leg runner)\n");
      return 2;
    }
    config.leg_runner = hexa::study::PoseCouplingRowRunnerFactory(
        g_coupled_legs_pose == 1   ? hexa::study::CouplingPose::kDesired
        : g_coupled_legs_pose == 2 ? hexa::study::CouplingPose::kEstimate
                                   : hexa::study::CouplingPose::kHome);
  }
  // The subcommands that study one paper motion.
  using MotionStudy = void (*)(const hexa::LockstepConfig&, PaperMotion, int);
  const std::pair<const char*, MotionStudy> motion_studies[] = {
      {"trace", platform_study::Trace}, {"fit", platform_study::Fit},
      {"legs", platform_study::Legs},   {"reversals", platform_study::Reversals},
      {"zsplit", platform_study::ZSplit}};
  for (const auto& [name, study] : motion_studies) {
    if (subcommand == name) {
      study(config, motions.front(), periods);
      return 0;
    }
  }
  if (subcommand == "modes") {
    platform_study::Modes(config, coupled);
    return 0;
  }
  platform_study::Score(config, motions, periods);
  return 0;
}
