// Controller and supervisor parameters (rig file sections `leg_controller` and
// `supervisor`). Plain data with the defaults of the reference rig; validated by config/.
#pragma once

#include <array>

namespace hexa {

// Gaussian-weighted numerical differentiator (eq 40, 41).
// Causal: the window is the last N samples; the Gaussian is centred centre_lag_samples
// before the newest sample (0 = newest, (N-1)/2 = window centre). docs/controller.md.
struct DifferentiatorParams {
  int window = 15;                  // N, samples (at most 32)
  double sigma = 0.85;              // standard deviation of w(x), in samples
  double centre_lag_samples = 1.0;  // c of eq 40, in samples before the newest sample (docs/controller.md)
};

// Backstepping-sliding mode controller (Sec. 3.2, eq 19-45).
struct BsSmcParams {
  double lambda_1_s = 40.0;             // sliding surface slope (eq 19); platform grid (docs/measurements/tuning.md)
  double switching_gain_n = 90.0;       // K (eq 22, 30), as a force; platform grid (docs/measurements/tuning.md)
  double boundary_layer_xi_s_m = 1.0;   // xi in tanh(xi S) (eq 45); paper: 10; chatter study (docs/measurements/tuning.md)
  double backstepping_beta_1_s = 90.0;  // beta (eq 38); valve activity (docs/measurements/control.md "Outer loop speed gate")
  double effective_mass_kg = 1.5;       // vertical-motion value; chatter study (docs/measurements/tuning.md)
  double gravity_load_n = 13.2;         // along the leg at home: 6 g/(6 cos) + 0.25 g cos (docs)
  double viscous_estimate_scale = 1.0;  // B_hat = scale * Table 8 B (eq 21)
  double friction_estimate_scale = 1.0; // F_s, F_c estimate = scale * Table 8 (eq 14)
  double friction_smoothing_velocity_m_s = 0.005;  // sgn(v) -> tanh(v / this) in eq 14
  // Proportional term of the reaching law, phi -= k_s S ("constant plus proportional rate"
  // reaching law, Gao & Hung 1993). NOT in the paper (deviation, docs/controller.md): with
  // K tanh(xi S) alone the corrective force is capped near K, and a leg held by static
  // friction or by the platform coupling with a large error gets no more force.
  double reaching_proportional_n_s_m = 50.0;  // chatter study (docs/measurements/tuning.md)
  // Valve-command smoothing (NOT in the paper; docs/controller.md "Valve chatter fixes").
  // Linearised inversion of the quadratic area law (eq 43) near null: for a required area
  // fraction r = A_v / A_max below this value the spool fraction is r / sqrt(r0) instead of
  // sqrt(r) (continuous at r0). 0 = the paper's square root everywhere, whose slope is
  // infinite at null and turns sensor noise into volt-sized spool jumps.
  double null_band_area_fraction = 0.25;  // chatter study (docs/measurements/tuning.md)
  // First-order low-pass on the commanded spool position (time constant; 0 = off). A lag
  // inside the force loop, in series with the spool's own (~3 ms) lag.
  double spool_filter_time_constant_s = 0.002;  // chatter study (docs/measurements/tuning.md)
  // Integral of the sliding surface (NOT in the paper): phi -= k_i * integral(S dt), with the
  // integral's force clamped to +-integral_limit_n (anti-windup). Without it a leg held by
  // static friction (F_s up to ~110 N with the plant's x1.2) against the bounded corrective
  // force of K tanh(xi S) + k_s S keeps a steady error on a step (measured: 9-11 mm of a
  // 10 mm step, tests/integration SixLegProcesses). 0 = off.
  // It integrates only while the setpoint is (nearly) still, |v_d| below
  // integral_active_below_m_s, and decays with integral_leak_time_constant_s while the
  // setpoint moves: integrated during a 1 Hz motion it winds up with phase lag (measured:
  // combined X RMSE 0.62 -> 1.77 cm with k_i 3000 always on).
  double integral_gain_n_m = 3000.0;
  double integral_limit_n = 150.0;  // above the plant's static friction (~110 N)
  double integral_active_below_m_s = 0.005;
  double integral_leak_time_constant_s = 0.1;
  // No integration while |e| is below this (a few potentiometer quantisation steps): integral
  // action against static friction otherwise hunts around the setpoint (measured at idle:
  // +-0.7 mm at ~1 Hz without it).
  double integral_deadband_m = 0.0003;
  // Rate of the feedback part of phi in phi_dot (NOT in the paper's form; a
  // deviation from eq 38, docs/deviations.md). phi_dot = d/dt(model part) (eq 40) +
  // feedback_rate_fraction * LP(d/dt(feedback part)), the feedback part being
  // -M lambda e_dot - K tanh(xi S) - k_s S, LP a first-order low-pass of time constant
  // feedback_rate_time_constant_s (a band-limited derivative). With it the feedback force
  // reaches the pressure force through ((a + beta tau) s + beta) / ((tau s + 1)(s + beta))
  // instead of beta / (s + beta): phase back on the velocity loop of the platform's light
  // modes (docs/measurements/control_light_modes.md "Feedback rate in phi_dot"). 0 = off (only beta z acts on it).
  double feedback_rate_fraction = 0.4;          // docs/measurements/control_light_modes.md "Feedback rate in phi_dot"
  double feedback_rate_time_constant_s = 0.001;
  // Speed schedule of the fraction: a_eff = a (1 - exp(-(v_d / this)^2)), v_d the desired
  // piston speed; 0 = a at every speed. Below ~0.05 m/s the plant's own bristle damping keeps
  // the light modes quiet (docs/measurements/control_light_modes.md) and the rate term only slows the force build-up
  // against static friction (an observer cannot tell a stuck piston from a lagging one).
  double feedback_rate_full_speed_m_s = 0.1;
  // Source of that rate. false: the backward difference of the feedback part computed from
  // the eq 40 velocity (numerical, carries the potentiometer noise twice differentiated).
  // true: analytic, d/dt(feedback) = -M lambda e_ddot - (K xi sech^2(xi S) + k_s) S_dot with
  // e_ddot, e_dot from the leg observer (core/leg_observer.hpp: position + pneumatic force ->
  // velocity, acceleration), whose model and noise figures are the observer_* fields.
  bool feedback_rate_from_observer = true;
  double observer_mass_kg = 1.0;   // between the light modes (0.88 kg) and the z mode (1.5 kg)
  double observer_length_sigma_m = 0.05e-3;
  double observer_force_sigma_n = 3.0;
  double observer_disturbance_rate_m_s3 = 100.0;
  // Dither (NOT in the paper, docs/controller_additions.md "Dither on the friction estimate"): a
  // sinusoidal force A sin(2 pi f t) exp(-(v_d / v_g)^2) added to eq 14's friction estimate while
  // the setpoint is slow. It is part of the model part of phi, so phi_dot carries its rate and the
  // valve follows it: it keeps the spool off its null, where the chatter band's quadratic area law
  // (null_band_area_fraction) makes the pressure loop's small-signal gain vanish, and it keeps the
  // bristles of a slowly moving leg from sticking. t = the sensor tick x period_s (common to the
  // six legs, lockstep and real time alike); f is rounded to 1 / (N period_s), N integer. 0 N = off
  // (the paper's eq 14). Grid on the seven trajectories, seeds 1-3
  // (docs/measurements/control_friction.md "Pure z and the stick-slip of the slow motions"); the
  // paper's 0.1 Hz motions move the legs at |v_d| <= 0.045 m/s.
  double dither_amplitude_n = 7.5;
  double dither_frequency_hz = 25.0;
  double dither_gate_speed_m_s = 0.12;
  // Friction scale adaptation (NOT in the paper, docs/controller_additions.md "Friction
  // adaptation at speed"): eq 14's friction and viscous estimates at v_d, F_r = F_f(v_d) +
  // B_hat v_d, are applied as k F_r with k = 1 + (theta - 1) w(v_d), w = 1 - exp(-(v_d / v_a)^2),
  // and theta follows the gradient law theta_dot = -gamma w S F_r (the Lyapunov-based update of
  // an unknown scale on a known regressor), projected on [min, max]. Fast legs adapt and get
  // the adapted scale; near v_d = 0 (w -> 0) the nominal estimate and the dither act unchanged,
  // since a friction estimate at full magnitude on a slow, reversing leg drives stick-slip
  // (docs/measurements/results.md). gamma = 0: off (theta stays 1, eq 14 as before). gamma = 0.01 1/(N m)
  // moves theta over seconds on the combined motion (measured: two thirds of its rise in ~3 s),
  // several periods of a 1 Hz motion, so theta does not follow the limit cycle within a period.
  double friction_adaptation_rate_1_n_m = 0.01;
  double friction_adaptation_speed_m_s = 0.12;
  double friction_adaptation_min_scale = 0.5;
  double friction_adaptation_max_scale = 2.0;
};

// PI baseline (paper ref [11]) with anti-windup, plus two terms that are not in ref [11]
// and default to what the platform needs (docs/controller.md "PI baseline", docs/measurements/tuning.md):
// a velocity feed-forward of the setpoint and rate damping on the velocity error
// (velocity from the eq 40 differentiator). Both 0 = the plain PI of ref [11].
// Gains: platform grid, seed 7 (docs/measurements/tuning.md).
struct PiParams {
  double proportional_v_m = 200.0;       // valve volts per metre; platform grid (docs/measurements/tuning.md)
  double integral_v_m_s = 30.0;          // valve volts per metre-second
  double integrator_limit_v = 2.0;      // anti-windup clamp of the integral term
  double velocity_feedforward_v_s_m = 6.0;  // volts per (m/s) of setpoint velocity
  double rate_damping_v_s_m = 20.0;         // volts per (m/s) of velocity error v_d - v
  // Force feed-forward, used only when the setpoint carries one: volts per newton of (feed-forward
  // force - measured pneumatic force P1 A1 - P2 A2 - Pa Ar). The PI's only output is a valve
  // opening, i.e. a rate of force change, so the known load enters as a proportional force loop
  // towards it (docs/controller_additions.md "Feed-forward of the platform's inverse dynamics").
  double force_feedforward_v_n = 0.001;  // tuned on the seven trajectories (docs/controller.md)
};

// Coupled leg feedback (docs/controller_additions.md "Coupled leg feedback"; off by default): leg i
// applies f_i(n) + gain * LPF(sum_j W_ij f_j(n - 1) - f_i(n - 1)), W = M_ls(home) / M, the
// six legs' BS-SMC feedback parts f_j of the previous tick as the plant relays them with leg
// i's sensor sample (RelayedFeedback, coupled_legs.hpp). Any leg's part missing: the decoupled
// law (f_i alone) on that tick. Gain and cut-off: chosen on seed 1 of the user's path
// (docs/measurements/coupled_feedback.md); gain 1 and no low-pass is the plain coupled law.
struct CoupledLegsParams {
  bool enabled = false;
  double gain = 0.25;       // share of the coupling increment applied, [0, 1]
  double cutoff_hz = 50.0;  // first-order low-pass of the increment (and its rate); 0 = none
  // W = V diag(max(m_k, M)) V^T / M (M_ls = V diag(m_k) V^T): only the modes heavier than M
  // get the single-mass loop, the light roll / pitch modes keep their uncoupled gain.
  bool raise_only = true;
};

struct LegControllerParams {
  DifferentiatorParams differentiator;
  BsSmcParams bssmc;
  PiParams pi;
  CoupledLegsParams coupled;
  double setpoint_timeout_s = 0.015;    // setpoints older than this -> hold (3 periods)
};

// Outer loop (Sec. 4.1): task-space error -> leg corrections through the Jacobian (eq 48).
struct OuterLoopParams {
  bool enabled = true;
  double gain = 0.4;                    // fraction of the mapped error added per 5 ms step (0.2 -> 0.4 with the speed gate, docs/task_space.md)
  // Scale of the TRANSLATION part of the pose error before the Jacobian mapping (the
  // orientation part always uses `gain`). The position estimate (GQFK with the nominal
  // geometry) is biased by the joint / potentiometer calibration errors it cannot observe,
  // the orientation (IMU) is not: docs/measurements/tuning.md, "Outer loop".
  double translation_gain_scale = 1.0;
  double max_correction_m = 0.005;      // per-leg bound of the accumulated correction
  // Speed gate of the integration (NOT in the paper; docs/task_space.md "Speed
  // gate"): the step's gain is gain / (1 + (v / gate_leg_speed_m_s)^2), v = the
  // largest |desired leg speed| (eq 46) of the step. The loop is for slowly varying errors
  // (calibration bias, friction at 0.1 Hz: legs <= 0.045 m/s, gain >= 0.55 x); on the 1 Hz
  // combined motion (legs up to 0.67 m/s) its 25 ms integration acted on the legs' dynamic
  // lag and drove the corrections between their bounds (valves saturated). 0 = no gate.
  double gate_leg_speed_m_s = 0.05;
};

// Soft limits held on every setpoint the supervisor sends, whatever its source (rig file
// `supervisor.soft_limits`; core/soft_limits.hpp; docs/operate.md "Soft limits"). The legs'
// stroke margin is SupervisorParams::stroke_margin_m and their speed limit max_leg_speed_m_s.
struct SoftLimitParams {
  // Deflection of each leg from its direction at home, at its base and its platform joint.
  // The reference rig's joints are not specified (docs/design.md): 0.8 rad (45.8 deg) lies
  // above what the default box reaches inside the stroke, so it does not bind by default.
  double max_base_joint_angle_rad = 0.8;
  double max_platform_joint_angle_rad = 0.8;
  // The pose box about the home pose: x y z offsets (m) and roll pitch yaw (rad). Home +-10 cm
  // and +-0.3 rad hold the paper's motions (8 cm, 15 deg) inside the workspace check.
  std::array<double, 3> position_min_from_home_m{-0.10, -0.10, -0.10};
  std::array<double, 3> position_max_from_home_m{0.10, 0.10, 0.10};
  std::array<double, 3> rotation_min_rad{-0.30, -0.30, -0.30};
  std::array<double, 3> rotation_max_rad{0.30, 0.30, 0.30};
  // Between two setpoints one period apart: the platform origin's speed (eq 49 peaks at
  // 0.71 m/s) and its rotation rate.
  double max_linear_speed_m_s = 0.8;
  double max_angular_speed_rad_s = 1.0;
};

struct SupervisorParams {
  double period_s = 0.005;
  double blend_duration_s = 2.0;        // smooth blend from the current pose
  double stop_duration_s = 1.0;         // smooth stop at the end
  double stroke_margin_m = 0.01;        // feasibility: keep this far from either end stop
  double max_leg_speed_m_s = 0.8;       // feasibility envelope (derived in docs/)
  double max_leg_acceleration_m_s2 = 8.0;
  int max_consecutive_deadline_misses = 5;
  double workspace_radius_m = 0.15;     // estimate outside -> hold
  double workspace_max_rotation_rad = 0.5236;  // |rotation from home| beyond -> hold (30 deg)
  bool least_squares_estimator = false; // GQFK (eq 47) by default; six-leg LSQ if true
  double estimator_outlier_threshold_m = 0.003;  // LSQ: residual beyond -> leg excluded
  // Length consistency (docs/faults.md): every tick the six measured lengths and the IMU
  // orientation are fitted by least squares (kinematics GqfkLeastSquares); a leg whose length
  // disagrees with the fit of the other five by more than this, for this many ticks in a row,
  // has a wrong length reading (stuck or drifting potentiometer): FAULT_SENSOR_INCONSISTENT.
  double length_consistency_limit_m = 0.008;
  int length_consistency_ticks = 3;
  OuterLoopParams outer_loop;
  // Platform inverse-dynamics feed-forward (core/platform_dynamics.hpp): every
  // setpoint carries the axial force its leg must deliver for the desired motion (nominal
  // masses, J^-T of eq 48), used by the BS-SMC as the known load of eq 14/15 and by the PI
  // baseline as a force feed-forward. false = the paper's lumped load (paper-faithful).
  bool feedforward_enabled = true;
  // Setpoint preview (NOT in the paper; docs/measurements/control.md "Setpoint lead"): while
  // a trajectory runs, the legs get the lengths, rates and feed-forward of the desired motion
  // this far ahead (the trajectory is known in advance); the outer loop and the metrics keep
  // the desired pose of now. Default = the legs' measured lag: their mean first-harmonic lag
  // on the combined motion with no lead, 1.86 ms over the six legs and seeds 1-3 (calibrated,
  // realistic, with the friction adaptation; `platform_study --rig default --calibrate --seed S
  // lead=0 legs combined`, docs/measurements/control.md "Setpoint lead"). Before the friction adaptation
  // it was 5 ms, the valve chain's two first-order lags (2 ms spool filter + 3 ms spool), when
  // the legs lagged 8-17 ms. 0 = off.
  double setpoint_lead_s = 0.002;
  SoftLimitParams soft_limits;
};

}  // namespace hexa
