// platform_study: tuning and diagnosis of the leg controllers ON THE FULL PLATFORM, in the
// in-process lockstep simulation (RunPaperSession, same protocol as the DDS system).
// Not a test. docs/measurements/tuning.md gives the grids run with it and the figures.
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
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibrate_in_process.hpp"
#include "coupled_leg_feedback.hpp"
#include "platform_observer_feedback.hpp"
#include "hexa/config/rig_config.hpp"
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/platform_dynamics.hpp"

namespace {

using hexa::PaperMotion;

// Per-axis scale of the combined motion's amplitudes (keys ax ay az; 1 = eq 49). Lets a run
// take one axis' content out of the combined motion (diagnosis of combined z).
hexa::Vector6d g_combined_axis_scale = hexa::Vector6d::Ones();

// The start request of a paper motion, the combined one with g_combined_axis_scale applied.
hexa::StartRequest PaperStart(const hexa::LockstepSimulation& sim, PaperMotion motion, int periods) {
  if (motion != PaperMotion::kCombined || g_combined_axis_scale == hexa::Vector6d::Ones()) {
    return sim.supervisor().PreparePaperStart(motion, periods);
  }
  const auto paper = hexa::MakePaperMotion(motion, sim.supervisor().home_xyz_rpy(), periods);
  hexa::Vector6d phase = hexa::Vector6d::Zero();
  phase[1] = 3.14159265358979323846 / 2.0;  // eq 49: y = 8 cos
  auto scaled = std::make_shared<const hexa::SinusoidMotion>(
      paper->centre(), paper->amplitude().cwiseProduct(g_combined_axis_scale), phase,
      paper->frequency_hz(), periods > 0 ? periods : hexa::DefaultPeriods(motion));
  return sim.supervisor().PrepareStart(hexa::Trajectory(scaled, sim.supervisor().rest_xyz_rpy(),
                                                        sim.supervisor().home_xyz_rpy(),
                                                        sim.supervisor().timing()));
}

struct Key {
  const char* name;
  std::function<void(hexa::LockstepConfig&, double)> set;
};

// Coupled leg feedback (studies/coupled_leg_feedback, docs/measurements/control.md).
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

std::vector<Key> Keys() {
  return {
      {"pobs", [](auto&, double v) { g_platform_observer.enabled = v != 0.0; }},
      {"cl", [](auto&, double v) { g_coupled_legs.enabled = v != 0.0; }},
      {"cl_gain", [](auto&, double v) { g_coupled_legs.gain = v; }},
      {"cl_cutoff", [](auto&, double v) { g_coupled_legs.cutoff_hz = v; }},
      {"cl_raise", [](auto&, double v) { g_coupled_legs.raise_only = v != 0.0; }},
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

// The paper's accuracy (Table 9 pure motions, Table 10 combined), cm and deg.
constexpr double kTable9[6] = {0.782, 0.841, 0.197, 1.012, 1.346, 1.836};
constexpr double kTable10[6] = {0.845, 1.205, 0.296, 1.193, 1.817, 2.433};

std::vector<int> MovingAxes(PaperMotion m) {
  switch (m) {
    case PaperMotion::kX: return {0};
    case PaperMotion::kY: return {1};
    case PaperMotion::kZ: return {2};
    case PaperMotion::kRoll: return {3};
    case PaperMotion::kPitch: return {4};
    case PaperMotion::kYaw: return {5};
    case PaperMotion::kCombined: return {0, 1, 2};
  }
  return {};
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

// Valve activity accumulator (see the header).
struct ValveActivity {
  double sum_du_v = 0.0;
  long saturated = 0;
  long reversals = 0;
  long samples = 0;
  hexa::LegArray<double> prev_v{};
  hexa::LegArray<int> side{};  // -1 extend, +1 retract, 0 not yet
  bool primed = false;
  void Add(const hexa::LegArray<double>& u) {
    for (std::size_t i = 0; i < 6; ++i) {
      if (primed) {
        sum_du_v += std::abs(u[i] - prev_v[i]);
        saturated += (u[i] < 0.05 || u[i] > 9.95) ? 1 : 0;
        const int s = u[i] < 3.0 ? -1 : (u[i] > 7.0 ? 1 : 0);
        if (s != 0 && side[i] != 0 && s != side[i]) ++reversals;
        if (s != 0) side[i] = s;
        ++samples;
      }
      prev_v[i] = u[i];
    }
    primed = true;
  }
  double MeanDu() const { return samples ? sum_du_v / samples : 0.0; }
  double SatFraction() const { return samples ? static_cast<double>(saturated) / samples : 0.0; }
  // reversals per leg per second (1 ms ticks)
  double FlipsPerS() const { return samples ? 1000.0 * reversals / samples : 0.0; }
};

ValveActivity IdleActivity(const hexa::LockstepConfig& config) {
  hexa::LockstepSimulation sim(config);
  ValveActivity a;
  for (int k = 0; k < 3500; ++k) {
    sim.Tick();
    if (k >= 500) a.Add(sim.applied_valve_v());
  }
  return a;
}

// RunPaperSession (same loop and metrics) plus the valve activity of the tracking window.
hexa::PaperSessionResult RunSession(const hexa::LockstepConfig& config, PaperMotion motion, int periods,
                                    ValveActivity& activity) {
  hexa::PaperSessionResult result;
  hexa::LockstepSimulation sim(config);
  result.plant_status = sim.Tick();
  if (result.plant_status != hexa::PlantStatus::kOk) return result;
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  bool started = false, left_idle = false;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    auto cmd = (due && !started) ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    result.plant_status = sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr);
    if (result.plant_status != hexa::PlantStatus::kOk) break;
    if (due) {
      started = true;
      const hexa::SupervisorOutput& out = sim.supervisor_output();
      state = out.state;
      if (state == hexa::SupervisorState::kTracking) {
        result.metrics.AddPose(out.desired_xyz_rpy, out.estimate.xyz_rpy,
                               hexa::VectorFromPose(sim.plant_before_step().truth.pose));
      }
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold || (left_idle && state == hexa::SupervisorState::kIdle)) break;
    }
    if (state == hexa::SupervisorState::kTracking) {
      for (std::size_t i = 0; i < 6; ++i) {
        result.metrics.leg_length[i].Add(sim.leg_outputs()[i].desired_length_m,
                                         sim.plant_before_step().legs[i].length_m);
      }
      activity.Add(sim.applied_valve_v());
    }
  }
  result.final_state = state;
  result.completed = left_idle && state == hexa::SupervisorState::kIdle &&
                     result.plant_status == hexa::PlantStatus::kOk;
  result.ticks = sim.tick();
  return result;
}

// One tick of a paper session: the start command goes with the first supervisor tick.
// Returns false when the plant reports an error.
bool TickSession(hexa::LockstepSimulation& sim, const hexa::StartRequest& start, bool due,
                 bool started) {
  const bool starting = due && !started;
  return sim.Tick(starting ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone,
                  starting ? &start : nullptr) == hexa::PlantStatus::kOk;
}

// Runs a paper session on `sim` (already ticked once) and calls
// fn(plant, t, desired sample, desired leg lengths, desired leg rates) on every 1 ms tick of
// the tracking window: t from the start command, the trajectory at the CURRENT time (no
// setpoint lead), leg lengths and rates through eq 46 on `geometry`.
template <class Fn>
void ForEachTrackingTick(hexa::LockstepSimulation& sim, const hexa::StartRequest& start,
                         const hexa::GeometryParams& geometry, Fn&& fn) {
  bool started = false, left_idle = false;
  double t_start = 0.0;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    if (due && !started) t_start = sim.time_s();
    if (!TickSession(sim, start, due, started)) break;
    if (due) {
      started = true;
      state = sim.supervisor_output().state;
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold || (left_idle && state == hexa::SupervisorState::kIdle)) break;
    }
    if (state != hexa::SupervisorState::kTracking) continue;
    const auto& p = sim.plant_before_step();
    const double tt = p.truth.time_s - t_start;
    hexa::TrajectorySample d;
    start.trajectory.Evaluate(tt, d);
    hexa::LegArray<double> ld{}, vd{}, ad{};
    hexa::LegKinematicsOf(geometry, d, ld, vd, ad);
    fn(p, tt, d, ld, vd);
  }
}

void Trace(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  std::printf("t,state");
  for (int i = 1; i <= 6; ++i)
    std::printf(",ld%d,l%d,ltrue%d,vd%d,ad%d,u%d,phi%d,S%d,P1_%d,P2_%d,corr%d,v%d,z%d,phidot%d", i, i, i,
                i, i, i, i, i, i, i, i, i, i, i);
  std::printf("\n");
  bool started = false, left_idle = false;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  hexa::LegArray<double> corr{};
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    if (!TickSession(sim, start, due, started)) break;
    if (due) {
      started = true;
      state = sim.supervisor_output().state;
      for (std::size_t i = 0; i < 6; ++i) corr[i] = sim.supervisor_output().setpoint[i].correction_m;
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold) {
        std::fprintf(stderr, "HOLD at t=%.3f s: %s\n", sim.time_s(),
                     sim.supervisor_output().fault_detail.data());
        break;
      }
      if (left_idle && state == hexa::SupervisorState::kIdle) break;
    }
    const auto& p = sim.plant_before_step();
    std::printf("%.3f,%d", p.truth.time_s, static_cast<int>(state));
    for (std::size_t i = 0; i < 6; ++i) {
      const auto& o = sim.leg_outputs()[i];
      std::printf(",%.6f,%.6f,%.6f,%.4f,%.3f,%.3f,%.2f,%.4f,%.0f,%.0f,%.6f,%.4f,%.2f,%.1f", o.desired_length_m,
                  p.legs[i].length_m, p.truth.length_m[i], o.desired_velocity_m_s, 0.0,
                  sim.applied_valve_v()[i], o.desired_force_n, o.sliding_surface_m_s,
                  p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa, corr[i],
                  o.velocity_m_s, o.force_error_n, o.desired_force_rate_n_s);
    }
    std::printf("\n");
  }
}

// Least-squares fit y ~ c + a sin(w t) + b cos(w t).
struct Harmonic {
  double c = 0, a = 0, b = 0;
  double amplitude() const { return std::hypot(a, b); }
  double phase_rad() const { return std::atan2(b, a); }
};
Harmonic FitHarmonic(const std::vector<double>& t, const std::vector<double>& y, double w) {
  double m[3][3] = {}, r[3] = {};
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double f[3] = {1.0, std::sin(w * t[k]), std::cos(w * t[k])};
    for (int i = 0; i < 3; ++i) {
      r[i] += f[i] * y[k];
      for (int j = 0; j < 3; ++j) m[i][j] += f[i] * f[j];
    }
  }
  // 3x3 Gauss elimination (well conditioned over whole periods).
  for (int i = 0; i < 3; ++i) {
    for (int k = i + 1; k < 3; ++k) {
      const double q = m[k][i] / m[i][i];
      for (int j = i; j < 3; ++j) m[k][j] -= q * m[i][j];
      r[k] -= q * r[i];
    }
  }
  double x[3];
  for (int i = 2; i >= 0; --i) {
    double s = r[i];
    for (int j = i + 1; j < 3; ++j) s -= m[i][j] * x[j];
    x[i] = s / m[i][i];
  }
  return Harmonic{x[0], x[1], x[2]};
}

// Angular frequency of a paper motion (rad/s) and an angle wrapped to (-pi, pi].
double MotionOmega(PaperMotion motion) {
  return 2.0 * 3.14159265358979323846 * (motion == PaperMotion::kCombined ? 1.0 : 0.1);
}
double WrapPi(double a) {
  while (a > 3.14159265358979323846) a -= 2 * 3.14159265358979323846;
  while (a < -3.14159265358979323846) a += 2 * 3.14159265358979323846;
  return a;
}

void Fit(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const double f_hz = motion == PaperMotion::kCombined ? 1.0 : 0.1;
  const double w = MotionOmega(motion);
  std::vector<double> t;
  std::vector<double> des[6], tru[6], leg_des[6], leg_true[6], leg_corr[6];
  bool started = false, left_idle = false;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    auto cmd = (due && !started) ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr) !=
        hexa::PlantStatus::kOk)
      break;
    if (!due) continue;
    started = true;
    const auto& out = sim.supervisor_output();
    if (out.state != hexa::SupervisorState::kIdle) left_idle = true;
    if (out.state == hexa::SupervisorState::kHold || (left_idle && out.state == hexa::SupervisorState::kIdle)) break;
    if (out.state != hexa::SupervisorState::kTracking) continue;
    t.push_back(out.trajectory_time_s);
    // HEXA_FIT_THETA=1: the six legs' adapted friction scales every 0.2 s on stderr.
    if (std::getenv("HEXA_FIT_THETA") && t.size() % 40 == 1) {
      std::fprintf(stderr, "t %.2f theta", out.trajectory_time_s);
      for (int i = 0; i < 6; ++i) std::fprintf(stderr, " %.3f", sim.leg_outputs()[i].friction_scale);
      std::fprintf(stderr, "\n");
    }
    const hexa::Vector6d truth = hexa::VectorFromPose(sim.plant_before_step().truth.pose);
    for (int k = 0; k < 6; ++k) {
      des[k].push_back(out.desired_xyz_rpy[k]);
      tru[k].push_back(truth[k]);
      leg_des[k].push_back(out.setpoint[k].length_m);
      leg_true[k].push_back(sim.plant_before_step().truth.length_m[k]);
      leg_corr[k].push_back(out.setpoint[k].correction_m);
    }
  }
  const char* names[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
  // Per axis: the first harmonics of desired and true motion, and the residual (the error
  // minus its fitted first harmonic), used by both tables below.
  std::array<Harmonic, 6> fit_des, fit_true;
  std::array<std::vector<double>, 6> residual;
  for (int k = 0; k < 6; ++k) {
    const Harmonic hd = FitHarmonic(t, des[k], w), ht = FitHarmonic(t, tru[k], w);
    fit_des[k] = hd;
    fit_true[k] = ht;
    residual[k].resize(t.size());
    for (std::size_t s = 0; s < t.size(); ++s) {
      const double e = tru[k][s] - des[k][s];
      const double fit_e = (ht.c + ht.a * std::sin(w * t[s]) + ht.b * std::cos(w * t[s])) -
                           (hd.c + hd.a * std::sin(w * t[s]) + hd.b * std::cos(w * t[s]));
      residual[k][s] = e - fit_e;
    }
  }
  std::printf("axis   | desired amp | gain true/des | lag deg  lag ms | peak over | rmse | rmse w/o 1st harmonic\n");
  for (int k = 0; k < 6; ++k) {
    const double unit = k < 3 ? 100.0 : 57.29577951308232;
    const Harmonic& hd = fit_des[k];
    const Harmonic& ht = fit_true[k];
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    // Mean over periods of (max true - max desired) in each period window.
    const double period = 1.0 / f_hz;
    double over = 0.0;
    int n_periods = 0;
    for (double t0 = t.front(); t0 + period <= t.back() + 1e-9; t0 += period) {
      double md = -1e9, mt = -1e9;
      for (std::size_t s = 0; s < t.size(); ++s) {
        if (t[s] < t0 || t[s] >= t0 + period) continue;
        md = std::max(md, des[k][s] - hd.c);
        mt = std::max(mt, tru[k][s] - hd.c);
      }
      over += mt - md;
      ++n_periods;
    }
    over /= std::max(1, n_periods);
    double se = 0.0, sr = 0.0;
    for (std::size_t s = 0; s < t.size(); ++s) {
      const double e = tru[k][s] - des[k][s];
      se += e * e;
      sr += residual[k][s] * residual[k][s];
    }
    const double n = static_cast<double>(t.size());
    std::printf("%-6s | %10.4f | %12.4f | %7.2f %7.2f | %9.4f | %.4f | %.4f\n", names[k],
                unit * hd.amplitude(), hd.amplitude() > 1e-9 ? ht.amplitude() / hd.amplitude() : 0.0,
                lag * 57.29577951308232, 1000.0 * lag / w, unit * over, unit * std::sqrt(se / n),
                unit * std::sqrt(sr / n));
  }
  // Where the residual (error minus its fitted first harmonic) sits in frequency: RMS per band
  // of its DFT over the window (Parseval; 5 ms samples, so up to 100 Hz). "harmonics" = the
  // bins within 0.15 Hz of 2, 3, ... 10 x the motion's frequency, "other" the rest of the band.
  // The first harmonic's own share is split into amplitude (gain - 1) and timing (lag).
  std::printf("axis   | 1st harmonic: amplitude part, timing part | residual by band: < f | "
              "harmonics 2f-10f | other f-10 Hz | 10-30 Hz | > 30 Hz\n");
  for (int k = 0; k < 6; ++k) {
    const double unit = k < 3 ? 100.0 : 57.29577951308232;
    const Harmonic& hd = fit_des[k];
    const Harmonic& ht = fit_true[k];
    const std::size_t n = t.size();
    const std::vector<double>& r = residual[k];
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    const double span = dt * static_cast<double>(n);
    double band[5] = {};  // mean square per band
    for (std::size_t b = 0; b <= n / 2; ++b) {
      std::complex<double> x = 0.0;
      const double wb = 2.0 * 3.14159265358979323846 * static_cast<double>(b) / span;
      for (std::size_t s = 0; s < n; ++s) x += r[s] * std::polar(1.0, -wb * dt * static_cast<double>(s));
      // One-sided power, so the bins sum to the mean square (Parseval).
      const double edge = (b == 0 || 2 * b == n) ? 1.0 : 2.0;
      const double ms = edge * std::norm(x) / static_cast<double>(n * n);
      const double f = static_cast<double>(b) / span;
      const double h = f / f_hz;
      const bool harmonic = h > 1.5 && h < 10.5 && std::abs(h - std::round(h)) * f_hz < 0.15;
      const int i = f < 0.95 * f_hz ? 0 : harmonic ? 1 : f < 10.0 ? 2 : f < 30.0 ? 3 : 4;
      band[i] += ms;
      // HEXA_FIT_BINS=<axis 0-5>: every bin of that axis' residual on stderr (Hz, RMS).
      if (const char* bins = std::getenv("HEXA_FIT_BINS"); bins && ms > 1e-10 && k == std::atoi(bins)) {
        std::fprintf(stderr, "bin %.2f Hz rms %.4f\n", f, unit * std::sqrt(ms));
      }
    }
    // First harmonic of the error, split: amplitude error (|true| - |desired|, in phase) and
    // timing error (the perpendicular part). RMS of a sinusoid = amplitude / sqrt 2.
    const double amp_part = std::abs(ht.amplitude() - hd.amplitude()) / std::sqrt(2.0);
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    const double time_part = ht.amplitude() * std::abs(std::sin(lag)) / std::sqrt(2.0);
    std::printf("%-6s | %.4f %.4f | %.4f | %.4f | %.4f | %.4f | %.4f\n", names[k], unit * amp_part,
                unit * time_part, unit * std::sqrt(band[0]), unit * std::sqrt(band[1]),
                unit * std::sqrt(band[2]), unit * std::sqrt(band[3]), unit * std::sqrt(band[4]));
  }
  std::printf("leg | desired amp mm | gain true/des | lag ms | correction amp mm (lag ms vs desired)\n");
  for (int i = 0; i < 6; ++i) {
    const Harmonic hd = FitHarmonic(t, leg_des[i], w), ht = FitHarmonic(t, leg_true[i], w),
                   hc = FitHarmonic(t, leg_corr[i], w);
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    const double lag_c = WrapPi(hd.phase_rad() - hc.phase_rad());
    std::printf("%d   | %8.3f | %8.4f | %7.2f | %7.3f (%7.2f)\n", i + 1, 1000 * hd.amplitude(),
                ht.amplitude() / hd.amplitude(), 1000.0 * lag / w, 1000 * hc.amplitude(),
                1000.0 * lag_c / w);
  }
}


// Per-leg analysis of the tracking window, every 1 ms tick. The desired leg
// motion is the trajectory's at the CURRENT time (no setpoint lead), from the desired pose
// through eq 46. Per leg: first-harmonic gain / lag of the true length against it, RMSE;
// the force budget along the leg (N RMS and 1st-harmonic amplitude / phase against the
// desired leg velocity, + = leads): F_ff the feed-forward used, z = P1 A1 - P2 A2 - phi
// (eq 35, the pressure loop's tracking error), the friction mismatch (plant friction on
// the rod + the controller's estimate F_f(v_d) + B v_d), the feedback part of phi
// (phi - phi_model); valve saturation and the share of ticks inside the null band.
void Legs(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  const double w = MotionOmega(motion);
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  hexa::BsSmcConfig bc;
  bc.params = config.leg_controller.bssmc;
  bc.differentiator = config.leg_controller.differentiator;
  bc.model = hexa::NominalLegModel::FromRig(config.rig);
  const hexa::BsSmcController estimate(bc);
  const double pa_ar = config.rig.air.atmosphere_pressure_pa * config.rig.cylinder.rod_area_m2;
  // HEXA_LEGS_TRACE=<leg 1-6>: per-tick CSV of that leg on stderr.
  const char* trace_env = std::getenv("HEXA_LEGS_TRACE");
  const int trace_leg = trace_env ? std::atoi(trace_env) - 1 : -1;
  if (trace_leg >= 0)
    std::fprintf(stderr, "t,ld_now,l_true,vd_now,v_true,vd_cmd,v_hat,fric_est,fric_plant,z,fb,ff,u,p1,p2\n");
  std::vector<double> t;
  enum { kLd, kL, kVd, kFf, kZ, kFric, kFb, kVhat, kVtrue, kN };
  std::vector<double> s[6][kN];
  long sat[6] = {}, band[6] = {}, n_ticks = 0;
  ForEachTrackingTick(sim, start, config.rig.geometry, [&](const hexa::PlatformPlantOutput& p, double tt,
                                                          const hexa::TrajectorySample&,
                                                          const hexa::LegArray<double>& ld,
                                                          const hexa::LegArray<double>& vd) {
    t.push_back(tt);
    ++n_ticks;
    for (std::size_t i = 0; i < 6; ++i) {
      const auto& o = sim.leg_outputs()[i];
      const auto& f = p.leg_forces[i];
      const double vdi = o.desired_velocity_m_s;
      const auto& fd = vdi >= 0.0 ? bc.model.friction.extend : bc.model.friction.retract;
      const double fric_est = estimate.FrictionEstimateN(vdi) + bc.params.viscous_estimate_scale * fd.viscous_n_s_m * vdi;
      // phi_model = F_ff + B v_d + Pa Ar + F_f(v_d) (bssmc_controller.cpp)
      const double phi_model = o.feedforward_force_n + fric_est + pa_ar;
      s[i][kLd].push_back(ld[i]);
      s[i][kL].push_back(p.truth.length_m[i]);
      s[i][kVd].push_back(vd[i]);
      s[i][kFf].push_back(o.feedforward_force_n);
      s[i][kZ].push_back(o.force_error_n);
      s[i][kFric].push_back(f.friction_n + fric_est);
      s[i][kFb].push_back(o.desired_force_n - phi_model);
      s[i][kVhat].push_back(o.velocity_m_s);
      s[i][kVtrue].push_back(p.truth.piston_velocity_m_s[i]);
      const double u = sim.applied_valve_v()[i];
      if (static_cast<int>(i) == trace_leg) {
        std::fprintf(stderr, "%.3f,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f,%.2f,%.2f,%.2f,%.2f,%.2f,%.3f,%.0f,%.0f\n", tt,
                     ld[i], p.truth.length_m[i], vd[i], p.truth.piston_velocity_m_s[i], vdi,
                     o.velocity_m_s, fric_est, f.friction_n, o.force_error_n,
                     o.desired_force_n - phi_model, o.feedforward_force_n, u,
                     p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa);
      }
      sat[i] += (u < 0.05 || u > 9.95) ? 1 : 0;
      band[i] += std::abs(u - 5.0) < 2.5 ? 1 : 0;
    }
  });
  const auto wrap = WrapPi;
  auto rms = [](const std::vector<double>& v) {
    double q = 0.0;
    for (double x : v) q += x * x;
    return v.empty() ? 0.0 : std::sqrt(q / static_cast<double>(v.size()));
  };
  std::printf("leg | amp mm | gain | lag ms | rmse mm | vhat lag ms | F_ff amp N (ph deg) | z rms N, amp (ph) | "
              "fric mismatch rms N, amp (ph) | feedback rms N, amp (ph) | sat %% | band %%\n");
  for (int i = 0; i < 6; ++i) {
    const Harmonic hd = FitHarmonic(t, s[i][kLd], w), ht = FitHarmonic(t, s[i][kL], w);
    const Harmonic hv = FitHarmonic(t, s[i][kVd], w);
    const Harmonic hvh = FitHarmonic(t, s[i][kVhat], w), hvt = FitHarmonic(t, s[i][kVtrue], w);
    std::vector<double> e(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) e[k] = s[i][kL][k] - s[i][kLd][k];
    auto force = [&](int q) {
      const Harmonic h = FitHarmonic(t, s[i][q], w);
      std::vector<double> c = s[i][q];
      for (double& x : c) x -= h.c;
      std::printf(" | %6.1f %6.1f (%5.0f)", rms(c), h.amplitude(),
                  wrap(h.phase_rad() - hv.phase_rad()) * 57.29577951308232);
    };
    std::printf("%d | %6.2f | %6.4f | %6.2f | %6.3f | %6.2f", i + 1, 1000 * hd.amplitude(),
                ht.amplitude() / hd.amplitude(), 1000 * wrap(hd.phase_rad() - ht.phase_rad()) / w,
                1000 * rms(e), 1000 * wrap(hvt.phase_rad() - hvh.phase_rad()) / w);
    const Harmonic hf = FitHarmonic(t, s[i][kFf], w);
    std::printf(" | %6.1f (%5.0f)", hf.amplitude(), wrap(hf.phase_rad() - hv.phase_rad()) * 57.29577951308232);
    force(kZ);
    force(kFric);
    force(kFb);
    std::printf(" | %5.2f | %5.1f\n", 100.0 * sat[i] / std::max(1L, n_ticks), 100.0 * band[i] / std::max(1L, n_ticks));
  }
}

// Where the moving axis' error is made (pure z). Every 1 ms tick of the tracking
// window: e = true pose - desired pose of NOW (the trajectory at the current time, no setpoint
// lead) on the moving axis of a pure motion. Printed: RMSE; bias (mean), the first harmonic
// at the motion's frequency and the rest, and the rest's share above 1 Hz (a centred 1 s
// moving average is the part below); the share of the squared error and the RMS within
// +-N ms of the reversals of the desired motion (zero crossings of its rate). Per leg: the
// share of ticks the piston is stuck (|true piston speed| < 2 mm/s while the desired leg speed
// is above 5 mm/s), the number of stick events per second (a stuck run of >= 10 ms), and the
// RMS of the piston speed error v_true - v_d. HEXA_REVERSALS_TRACE=<file> writes the per-tick
// CSV (t, desired and true moving axis, each leg's desired and true speed) to that file.
void Reversals(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  const auto axes = MovingAxes(motion);
  if (axes.size() != 1) {
    std::fprintf(stderr, "reversals: a pure motion (x y z roll pitch yaw)\n");
    return;
  }
  const int ax = axes.front();
  const double unit = ax < 3 ? 100.0 : 57.29577951308232;  // cm, deg
  const double w = MotionOmega(motion);
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const char* trace_path = std::getenv("HEXA_REVERSALS_TRACE");
  std::FILE* trace = trace_path ? std::fopen(trace_path, "w") : nullptr;
  if (trace) {
    std::fprintf(trace, "t,desired,true");
    for (int i = 1; i <= 6; ++i) std::fprintf(trace, ",vd%d,v%d", i, i);
    std::fprintf(trace, "\n");
  }
  std::vector<double> t, e, rate;
  std::vector<double> vd[6], vt[6];
  ForEachTrackingTick(sim, start, config.rig.geometry, [&](const hexa::PlatformPlantOutput& p, double tt,
                                                          const hexa::TrajectorySample& d,
                                                          const hexa::LegArray<double>&,
                                                          const hexa::LegArray<double>& vdl) {
    const double truth = hexa::VectorFromPose(p.truth.pose)[ax];
    t.push_back(tt);
    e.push_back(unit * (truth - d.vector.q[ax]));
    rate.push_back(d.vector.q_dot[ax]);
    if (trace) std::fprintf(trace, "%.3f,%.7f,%.7f", tt, d.vector.q[ax], truth);
    for (std::size_t i = 0; i < 6; ++i) {
      vd[i].push_back(vdl[i]);
      vt[i].push_back(p.truth.piston_velocity_m_s[i]);
      if (trace) std::fprintf(trace, ",%.5f,%.5f", vdl[i], p.truth.piston_velocity_m_s[i]);
    }
    if (trace) std::fprintf(trace, "\n");
  });
  if (trace) std::fclose(trace);
  const std::size_t n = t.size();
  if (n < 2000) {
    std::fprintf(stderr, "reversals: tracking window too short (%zu ticks)\n", n);
    return;
  }
  auto rms = [](const std::vector<double>& v) {
    double q = 0.0;
    for (double x : v) q += x * x;
    return std::sqrt(q / static_cast<double>(v.size()));
  };
  double mean = 0.0;
  for (double x : e) mean += x / static_cast<double>(n);
  const Harmonic h = FitHarmonic(t, e, w);
  std::vector<double> rest(n), slow(n), fast(n);
  for (std::size_t k = 0; k < n; ++k) rest[k] = e[k] - (h.c + h.a * std::sin(w * t[k]) + h.b * std::cos(w * t[k]));
  const std::size_t half = 500;  // 1 s centred moving average at 1 ms
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t a = k > half ? k - half : 0, b = std::min(n - 1, k + half);
    double sum = 0.0;
    for (std::size_t j = a; j <= b; ++j) sum += rest[j];
    slow[k] = sum / static_cast<double>(b - a + 1);
    fast[k] = rest[k] - slow[k];
  }
  std::printf("moving axis RMSE %.4f %s: bias %+.4f, 1st harmonic %.4f (lag %.1f ms), rest %.4f of which "
              "above 1 Hz %.4f\n",
              rms(e), ax < 3 ? "cm" : "deg", mean, h.amplitude() / std::sqrt(2.0),
              1000.0 * WrapPi(-h.phase_rad()) / w, rms(rest), rms(fast));
  std::vector<double> rev;
  for (std::size_t k = 1; k < n; ++k)
    if ((rate[k] > 0.0) != (rate[k - 1] > 0.0)) rev.push_back(t[k]);
  double sq_all = 0.0;
  for (double x : e) sq_all += x * x;
  std::printf("reversals at");
  for (double r : rev) std::printf(" %.3f", r);
  std::printf(" s\n+-N ms | time share | squared-error share | RMS inside | RMS outside\n");
  for (double win_ms : {100.0, 250.0, 500.0, 1000.0}) {
    double sq_in = 0.0;
    long in = 0;
    for (std::size_t k = 0; k < n; ++k) {
      bool near = false;
      for (double r : rev) near = near || std::abs(t[k] - r) <= win_ms / 1000.0;
      if (near) {
        sq_in += e[k] * e[k];
        ++in;
      }
    }
    const long out = static_cast<long>(n) - in;
    std::printf("%6.0f | %.3f | %.3f | %.4f | %.4f\n", win_ms, static_cast<double>(in) / static_cast<double>(n),
                sq_all > 0.0 ? sq_in / sq_all : 0.0, in ? std::sqrt(sq_in / static_cast<double>(in)) : 0.0,
                out ? std::sqrt((sq_all - sq_in) / static_cast<double>(out)) : 0.0);
  }
  std::printf("leg | stuck share (|v| < 2 mm/s, |v_d| > 5 mm/s) | stick events /s | v error RMS m/s\n");
  for (int i = 0; i < 6; ++i) {
    long moving = 0, stuck = 0, events = 0, run = 0;
    std::vector<double> ve(n);
    for (std::size_t k = 0; k < n; ++k) {
      ve[k] = vt[i][k] - vd[i][k];
      const bool mv = std::abs(vd[i][k]) > 0.005;
      const bool st = mv && std::abs(vt[i][k]) < 0.002;
      moving += mv ? 1 : 0;
      stuck += st ? 1 : 0;
      run = st ? run + 1 : 0;
      events += run == 10 ? 1 : 0;
    }
    std::printf("%d | %.3f | %.2f | %.4f\n", i + 1, moving ? static_cast<double>(stuck) / static_cast<double>(moving) : 0.0,
                static_cast<double>(events) / (t.back() - t.front()), rms(ve));
  }
}

// Where combined z's error comes from, through the legs: every 1 ms tick of the tracking
// window the six true leg-length errors e = l - l_d(q_d) (plant's true geometry, the
// trajectory of NOW) map to a pose error J(q_d)^-1 e (eq 48, first order), whose z is checked
// against the true z error. e is split on the leg-space modes at home (eigenvectors V_k of
// M_ls, eq 48, the rig's masses): z_k = (J(q_d)^-1 V_k V_k^T e)_z, sum_k z_k = the z error.
// Per mode: its mass, its task direction, the RMS of its leg error, the RMS of z_k and its
// share of z's mean square (mean z_k z / mean z^2; the shares sum to 1). The last column splits
// z_k into what J(home)^-1 gives (the mode's own z at home) and the rest (the pose-dependent
// geometry moving the mode's leg error into z away from home).
void ZSplit(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const hexa::GeometryParams& geometry = sim.plant().true_geometry();
  hexa::Pose home;
  home.p_BP_B_m = geometry.home_position_m;
  home.R_BP.setIdentity();
  hexa::Matrix6d j_home, m_ls;
  hexa::LegJacobian(geometry, home, j_home);
  hexa::LegSpaceMassMatrix(geometry, hexa::PlatformInertialParams::FromRig(config.rig), home, m_ls);
  const Eigen::SelfAdjointEigenSolver<hexa::Matrix6d> eig(m_ls);
  const hexa::Matrix6d v = eig.eigenvectors();
  const hexa::Matrix6d j_home_inv = j_home.inverse();
  double sq_true = 0.0, sq_lin = 0.0, sq_diff = 0.0;
  std::array<double, 6> sq_mode{}, cross_mode{}, sq_leg_mode{}, sq_home{}, sq_leak{};
  long n = 0;
  std::vector<double> t_s, heave_m;  // the desired motion's heave coordinate V_heave^T l_d
  int heave = 0;
  for (int k = 0; k < 6; ++k) {
    if (std::abs((j_home_inv * v.col(k))[2]) > std::abs((j_home_inv * v.col(heave))[2])) heave = k;
  }
  ForEachTrackingTick(sim, start, config.rig.geometry,
                      [&](const hexa::PlatformPlantOutput& p, double, const hexa::TrajectorySample& d,
                          const hexa::LegArray<double>&, const hexa::LegArray<double>&) {
    hexa::LegArray<double> ld{};
    hexa::InverseKinematics(geometry, d.pose, ld);
    hexa::Matrix6d j;
    hexa::LegJacobian(geometry, d.pose, j);
    const hexa::Matrix6d j_inv = j.inverse();
    Eigen::Vector<double, 6> e;
    for (int i = 0; i < 6; ++i) e[i] = p.truth.length_m[i] - ld[i];
    const double z_true = p.truth.pose.p_BP_B_m.z() - d.pose.p_BP_B_m.z();
    t_s.push_back(static_cast<double>(n) * config.tick_s);
    double h = 0.0;
    for (int i = 0; i < 6; ++i) h += v(i, heave) * ld[static_cast<std::size_t>(i)];
    heave_m.push_back(h);
    const double z_lin = (j_inv * e)[2];
    sq_true += z_true * z_true;
    sq_lin += z_lin * z_lin;
    sq_diff += (z_true - z_lin) * (z_true - z_lin);
    for (int k = 0; k < 6; ++k) {
      const double a = v.col(k).dot(e);
      const double zk = (j_inv * v.col(k))[2] * a;
      const double zk_home = (j_home_inv * v.col(k))[2] * a;
      sq_mode[k] += zk * zk;
      cross_mode[k] += zk * z_lin;
      sq_leg_mode[k] += a * a;
      sq_home[k] += zk_home * zk_home;
      sq_leak[k] += (zk - zk_home) * (zk - zk_home);
    }
    ++n;
  });
  if (n == 0) {
    std::fprintf(stderr, "zsplit: empty tracking window\n");
    return;
  }
  const double dn = static_cast<double>(n);
  std::printf("z error RMS %.4f cm, through the legs (J^-1 e) %.4f cm, difference %.4f cm\n",
              100 * std::sqrt(sq_true / dn), 100 * std::sqrt(sq_lin / dn), 100 * std::sqrt(sq_diff / dn));
  std::printf("mode kg | task direction x y z roll pitch yaw | leg error RMS mm | z_k RMS cm | share of z MS | "
              "z_k at home J / pose-dependent rest RMS cm\n");
  for (int k = 0; k < 6; ++k) {
    const hexa::Vector6d dir = j_home_inv * v.col(k);
    std::printf("%7.3f | %6.3f %6.3f %6.3f %6.3f %6.3f %6.3f | %.3f | %.4f | %+.3f | %.4f / %.4f\n",
                eig.eigenvalues()[k], dir[0], dir[1], dir[2], dir[3], dir[4], dir[5],
                1000 * std::sqrt(sq_leg_mode[k] / dn), 100 * std::sqrt(sq_mode[k] / dn),
                sq_lin > 0 ? cross_mode[k] / sq_lin : 0.0, 100 * std::sqrt(sq_home[k] / dn),
                100 * std::sqrt(sq_leak[k] / dn));
  }
  // The desired legs' common (heave) motion: its amplitude at 1-5 x the motion's frequency.
  const double w = MotionOmega(motion);
  std::printf("desired heave coordinate, amplitude mm at 1-5 x f:");
  for (int hk = 1; hk <= 5; ++hk) {
    double a = 0.0, b = 0.0;
    for (std::size_t s = 0; s < t_s.size(); ++s) {
      a += heave_m[s] * std::sin(hk * w * t_s[s]);
      b += heave_m[s] * std::cos(hk * w * t_s[s]);
    }
    std::printf(" %.4f", 1000.0 * 2.0 * std::hypot(a, b) / static_cast<double>(t_s.size()));
  }
  std::printf("\n");
}


// Leg-space modes at home: eigenvalues of J^-T M_p J^-1 + m_leg I (eq 48; the
// rig's platform mass and inertia, the pistons' moving mass), and for each the BS-SMC's
// velocity loop c / (m s) * P(s) * exp(-s tau): c = M lambda + K xi + k_s, P(s) = beta / (s + beta)
// or, with the feedback rate in phi_dot, ((a + beta tf) s + beta) / ((tf s + 1)(s + beta)),
// tau = spool filter + valve spool + the velocity estimate's group delay. Crossover and phase
// margin (docs/measurements/control.md "Per-leg lag and leg 2's overshoot on combined").
void Modes(const hexa::LockstepConfig& config, const hexa::study::CoupledLegFeedbackParams& coupled) {
  const hexa::RigParams& rig = config.rig;
  hexa::Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  home.R_BP.setIdentity();
  hexa::Matrix6d J;
  hexa::LegJacobian(rig.geometry, home, J);
  const hexa::Matrix6d j_inv = J.inverse();
  hexa::Matrix6d ml;
  hexa::LegSpaceMassMatrix(rig.geometry, hexa::PlatformInertialParams::FromRig(rig), home, ml);
  const Eigen::SelfAdjointEigenSolver<hexa::Matrix6d> eig(ml);
  const hexa::BsSmcParams& b = config.leg_controller.bssmc;
  const double c = b.effective_mass_kg * b.lambda_1_s + b.switching_gain_n * b.boundary_layer_xi_s_m +
                   b.reaching_proportional_n_s_m;
  hexa::DifferentiatorConfig dc;
  dc.params = config.leg_controller.differentiator;
  dc.sample_period_s = config.tick_s;
  const double tau = b.spool_filter_time_constant_s + rig.valve.spool_time_constant_s +
                     hexa::GaussianDifferentiator(dc).GroupDelaySamples() * config.tick_s;
  const double beta = b.backstepping_beta_1_s;
  // Path from the feedback force to the pressure force (eq 38 with the optional feedback
  // rate in phi_dot): ((a + beta tf) s + beta) / ((tf s + 1)(s + beta)), a the
  // fraction, tf its low-pass; a = 0: beta / (s + beta).
  const double a = b.feedback_rate_fraction;
  const double tf = b.feedback_rate_time_constant_s;
  auto path = [&](double w) {
    const std::complex<double> s(0.0, w);
    return ((a + beta * tf) * s + beta) / ((tf * s + 1.0) * (s + beta));
  };
  std::printf("velocity gain c %.1f N s/m, beta %.1f 1/s, lag %.2f ms, feedback rate fraction %.2f, "
              "low-pass %.2f ms\n", c, beta, 1000 * tau, a, 1000 * tf);
  std::printf("mode mass kg | task direction (x y z m, roll pitch yaw rad per unit) | crossover Hz | phase margin deg\n");
  // Coupled leg feedback (coupled=1): the feedback acts through W = M_ls / M, i.e. with gain
  // (m_k / M) c on mode k: every mode's loop is that of a single mass M.
  const double m_ref = coupled.reference_mass_kg > 0.0 ? coupled.reference_mass_kg : b.effective_mass_kg;
  if (coupled.enabled) {
    // W at home and the gain of independent, equal noise on the six feedback parts to one
    // leg's applied feedback: the Euclidean norm of W's row (1 uncoupled).
    const Eigen::Vector<double, 6> raised =
        coupled.raise_only ? eig.eigenvalues().cwiseMax(m_ref) : eig.eigenvalues();
    const hexa::Matrix6d w = eig.eigenvectors() * raised.asDiagonal() * eig.eigenvectors().transpose() / m_ref;
    std::printf("coupled leg feedback: modes %s m_ref = %.3f kg get the loop of that mass; W row 1: "
                "%.3f %.3f %.3f %.3f %.3f %.3f, noise gain (row norm) %.2f\n",
                coupled.raise_only ? "heavier than" : "all, with", m_ref, w(0, 0), w(0, 1),
                w(0, 2), w(0, 3), w(0, 4), w(0, 5), w.row(0).norm());
  }
  for (int k = 0; k < 6; ++k) {
    const double m = !coupled.enabled   ? eig.eigenvalues()[k]
                     : coupled.raise_only ? std::min(m_ref, eig.eigenvalues()[k])
                                          : m_ref;
    auto gain = [&](double w) { return c / (m * w) * std::abs(path(w)); };
    double lo = 1e-3, hi = 1e5;  // |L| falls monotonically with w (|path| <= 1 + a / (beta tf))
    for (int it = 0; it < 200; ++it) {
      const double mid = std::sqrt(lo * hi);
      (gain(mid) > 1.0 ? lo : hi) = mid;
    }
    const double w = lo;
    const double phase = -0.5 * 3.14159265358979323846 + std::arg(path(w)) - w * tau;
    const hexa::Vector6d dir = j_inv * eig.eigenvectors().col(k);
    std::printf("%8.3f | %7.3f %7.3f %7.3f %7.3f %7.3f %7.3f | %6.1f | %6.1f\n", eig.eigenvalues()[k], dir[0], dir[1], dir[2],
                dir[3], dir[4], dir[5], w / (2 * 3.14159265358979323846),
                180.0 + phase * 57.29577951308232);
  }
}

}  // namespace

int main(int argc, char** argv) {
  hexa::LockstepConfig config;
  config.seed = 1;
  std::vector<PaperMotion> motions = {PaperMotion::kX,    PaperMotion::kY,     PaperMotion::kZ,
                                      PaperMotion::kRoll, PaperMotion::kPitch, PaperMotion::kYaw,
                                      PaperMotion::kCombined};
  int periods = 0;
  bool trace = false, zsplit = false, fit = false, legs = false, modes = false, reversals = false, calibrate = false;
  std::optional<hexa::config::SystemConfig> loaded_rig;
  const auto keys = Keys();
  const auto coupled_keys = CoupledKeys();
  hexa::study::CoupledLegFeedbackParams coupled;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto next = [&]() -> std::string { return a + 1 < argc ? argv[++a] : std::string(); };
    if (arg == "trace" || arg == "fit" || arg == "legs" || arg == "reversals" || arg == "zsplit") {
      (arg == "trace" ? trace : arg == "fit" ? fit : arg == "legs" ? legs : arg == "zsplit" ? zsplit : reversals) = true;
      PaperMotion m;
      if (!hexa::ParsePaperMotion(next(), m)) return Usage();
      motions = {m};
    } else if (arg == "modes") {
      modes = true;
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
    if (!hexa::calib::CalibrateInProcess(config, calibration, stderr)) return 1;
    hexa::calib::ApplyKinematicCalibration(calibration, config);
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
  if (reversals) {
    Reversals(config, motions.front(), periods);
    return 0;
  }
  if (zsplit) {
    ZSplit(config, motions.front(), periods);
    return 0;
  }
  if (trace) {
    Trace(config, motions.front(), periods);
    return 0;
  }
  if (fit) {
    Fit(config, motions.front(), periods);
    return 0;
  }
  if (legs) {
    Legs(config, motions.front(), periods);
    return 0;
  }
  if (modes) {
    Modes(config, coupled);
    return 0;
  }
  double score = 0.0;
  int incomplete = 0;
  {
    const ValveActivity idle = IdleActivity(config);
    std::printf("idle     valve du %.3f V/tick sat %.1f %% flip %.1f /s\n", idle.MeanDu(),
                100.0 * idle.SatFraction(), idle.FlipsPerS());
  }
  for (const auto motion : motions) {
    ValveActivity act;
    const auto r = RunSession(config, motion, periods, act);
    const auto e = r.metrics.vs_truth.Rmse();
    double v[6];
    for (int k = 0; k < 6; ++k) v[k] = k < 3 ? 100.0 * e[k] : e[k] * 57.29577951308232;
    const double* paper = motion == PaperMotion::kCombined ? kTable10 : kTable9;
    double ratio = 0.0;
    const auto axes = MovingAxes(motion);
    for (int k : axes) ratio += v[k] / paper[k];
    ratio /= static_cast<double>(axes.size());
    if (!r.completed) {
      ++incomplete;
      ratio = 100.0;  // a session that went to HOLD scores badly whatever its partial RMSE
    }
    score += ratio;
    double leg_max = 0.0;
    std::printf("%-8s %s | %7.4f %7.4f %7.4f cm | %7.4f %7.4f %7.4f deg | legs mm", hexa::ToString(motion),
                r.completed ? "ok  " : "HOLD", v[0], v[1], v[2], v[3], v[4], v[5]);
    for (const auto& leg : r.metrics.leg_length) {
      std::printf(" %6.2f", 1000 * leg.Rmse());
      leg_max = std::max(leg_max, leg.Rmse());
    }
    std::printf(" | /paper %.3f | du %.3f sat %.1f%% flip %.1f\n", ratio, act.MeanDu(),
                100.0 * act.SatFraction(), act.FlipsPerS());
  }
  std::printf("SCORE %.4f incomplete %d\n", score / static_cast<double>(motions.size()), incomplete);
  return 0;
}
