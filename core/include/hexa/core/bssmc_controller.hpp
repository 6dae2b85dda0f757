// Backstepping-sliding mode position controller of one pneumatic leg (paper Sec. 3.2,
// eq 14-45), as implemented and corrected in docs/controller.md:
//
//   x = l - l_mid (piston position, eq 64), e = x - x_d, S = e_dot + lambda e      (eq 19)
//   M x_ddot = phi_p - B x_dot + C,  phi_p = P1 A1 - P2 A2                   (eq 14-18, M kept)
//   phi = M (x_ddot_d - lambda e_dot) + B_hat x_dot - C_hat - K tanh(xi S)   (eq 25, 26, 45)
//   z = P1 A1 - P2 A2 - phi                                                  (eq 35)
//   A1 P1_dot - A2 P2_dot = phi_dot - beta z                                 (eq 38)
//   -> required orifice area through the flow model (eq 4, 7, 43), routing (extend /
//      retract) chosen by the sign of the required flow term, spool -> voltage (eq 42, 44),
//   saturated to the valve's 0-10 V.
//
// phi_dot is the Gaussian derivative (eq 40) of phi's model part, plus a fraction of the low-passed
// rate of its feedback part from the leg observer (leg_observer.hpp; docs/controller_additions.md
// "Feedback rate in phi_dot and the leg observer"). Velocity x_dot is the Gaussian derivative of
// the measured length.
//
// Update neither throws nor allocates and never returns a non-finite voltage.
#pragma once

#include <cstdint>

#include "hexa/core/control_params.hpp"
#include "hexa/core/differentiator.hpp"
#include "hexa/core/leg_observer.hpp"
#include "hexa/core/pneumatics.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// The controller's nominal model of one leg: what it believes about the rig.
struct NominalLegModel {
  AirParams air;
  CylinderParams cylinder;
  ValveParams valve;
  FrictionParams friction;
  PolytropicSet polytropic;

  static NominalLegModel FromRig(const RigParams& rig);
};

struct BsSmcConfig {
  BsSmcParams params;
  DifferentiatorParams differentiator;
  NominalLegModel model;
  double period_s = 0.001;  // control (and sensor) period
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

struct BsSmcInput {
  double length_m = 0.0;               // measured leg length
  double cap_pressure_pa = 1.0e5;      // P1, absolute
  double rod_pressure_pa = 1.0e5;      // P2, absolute
  double supply_pressure_pa = 7.0e5;   // Ps, absolute (measured)
  double desired_length_m = 0.0;       // x_d + l_mid (incl. outer-loop correction)
  double desired_velocity_m_s = 0.0;   // x_dot_d
  double desired_acceleration_m_s2 = 0.0;  // x_ddot_d
  // Known load of the leg (platform inverse dynamics): the axial force the leg must
  // deliver for the desired motion (inertia of platform and pistons, gravity). With it,
  // M x_ddot_d + F_g of eq 14/25 is replaced by feedforward_force_n (M stays as the gain of
  // the feedback term M lambda e_dot).
  bool has_feedforward = false;
  double feedforward_force_n = 0.0;
  // Sensor tick of this period (LegControllerInput::tick): the dither's time base, the same
  // for the six legs.
  std::uint64_t tick = 0;
  // Coupled leg feedback only (docs/measurements/control_coupled_feedback.md "Coupled leg feedback"): the force the leg
  // observer is driven with in place of this leg's pneumatic force, m_obs (M_ls^-1 F)_i, so
  // that its acceleration F / m_obs is the leg's acceleration on the coupled platform.
  bool has_observer_force = false;
  double observer_force_n = 0.0;
  // Coupled study variant: the feedback part's velocity (e_dot, S) from the leg observer
  // instead of the Gaussian derivative (needs feedback_rate_from_observer and a fraction > 0).
  bool feedback_velocity_from_observer = false;
  // Platform state observer study (studies/platform_observer_feedback): the feedback
  // part's velocity (e_dot, S) from the platform state observer instead of eq 40.
  bool has_feedback_velocity = false;
  double feedback_velocity_m_s = 0.0;
};

struct BsSmcOutput {
  double valve_v = 5.0;
  double sliding_surface_m_s = 0.0;   // S (eq 19)
  double velocity_m_s = 0.0;          // x_dot estimate (eq 40)
  double feedback_rate_n_s = 0.0;     // the feedback part's rate added to phi_dot (times the fraction)
  double friction_scale = 1.0;        // adapted friction scale theta (1 when the adaptation is off)
  double desired_force_n = 0.0;       // phi (eq 45)
  double desired_force_rate_n_s = 0.0;  // phi_dot (eq 40 applied to phi)
  double force_error_n = 0.0;         // z (eq 35)
  double spool_m = 0.0;               // commanded spool position before saturation
  bool saturated = false;             // voltage clipped to the valve range
};

// The feedback part of phi, f = -M lambda e_dot - K tanh(xi S) - k_s S (eq 45's feedback terms),
// and its low-passed rate (0 when the feedback rate is off), before the fraction.
struct BsSmcFeedback {
  double force_n = 0.0;
  double rate_n_s = 0.0;
};

class BsSmcController {
 public:
  explicit BsSmcController(const BsSmcConfig& config);  // validates (throws)

  // Forget the differentiator histories (after a hold).
  void Reset();

  // One control period. Inputs are trusted to be finite and in range (LegController checks
  // them); a non-finite intermediate still yields the null voltage.
  void Update(const BsSmcInput& input, BsSmcOutput& output);

  // Coupled leg feedback (docs/measurements/control_coupled_feedback.md "Coupled leg feedback"; off in the system): one
  // control period in two steps. Begin runs the estimates (velocity, integral, observer) and
  // returns this leg's own feedback part; Finish completes the law with the feedback part that
  // is to act on this leg (the caller mixes the six legs' parts through the leg-space mass
  // matrix) in place of its own. Update(in, out) is Begin then Finish with the leg's own part
  // (bit for bit the uncoupled law).
  BsSmcFeedback Begin(const BsSmcInput& input);
  void Finish(const BsSmcInput& input, const BsSmcFeedback& applied, BsSmcOutput& output);
  // Finish with the leg's own part in the uncoupled law's arithmetic: Begin then this is Update,
  // bit for bit (the coupled leg feedback's fall-back).
  void FinishOwn(const BsSmcInput& input, BsSmcOutput& output);

  const BsSmcConfig& config() const { return config_; }

  // Static friction estimate of eq 14 (without the viscous part), signed: opposes v.
  double FrictionEstimateN(double velocity_m_s) const;

  // Dither force (params.dither_*) at sensor tick `tick` for desired velocity v_d; 0 when off.
  double DitherForceN(std::uint64_t tick, double desired_velocity_m_s) const;
  // Spool fraction X / X_max for a required orifice-area fraction A_v / A_max (eq 43
  // inverted, with the optional linear band near null). Clamped to [0, 1].
  double SpoolFractionForArea(double area_fraction) const;

  // Fraction of the feedback part's rate in phi_dot at this desired speed (the speed schedule
  // of BsSmcParams::feedback_rate_full_speed_m_s).
  double FeedbackRateFraction(double desired_velocity_m_s) const;

 private:
  // Finish with `applied` (coupled) or, when null, the leg's own feedback part in the
  // uncoupled law's arithmetic.
  void Complete(const BsSmcInput& input, const BsSmcFeedback* applied, BsSmcOutput& output);

  // What Begin computed for Finish (this period only).
  struct Stage {
    double x_m = 0.0, v_m_s = 0.0, s_m_s = 0.0;
    double phi_hat_n = 0.0;          // eq 25's phi_hat (incl. -M lambda e_dot)
    double phi_model_n = 0.0;        // phi_hat without the feedback part
    double phi_dot_model_n_s = 0.0;  // eq 40 on phi_model
  };
  Stage stage_;
  BsSmcConfig config_;
  OrificeFlowModel orifice_;  // eq 4, 5 with the plant's laminar band (pneumatics.hpp)
  GaussianDifferentiator velocity_diff_;
  GaussianDifferentiator force_diff_;
  LegObserver observer_;  // used only with feedback_rate_from_observer
  double filtered_spool_m_ = 0.0;  // state of the spool command filter
  double integral_force_n_ = 0.0;  // k_i * integral(S dt), clamped
  // Adapted friction scale theta (BsSmcParams::friction_adaptation_*): a property of the leg,
  // kept through Reset (a hold does not change the friction); 1 when the adaptation is off.
  double friction_scale_ = 1.0;
  // Band-limited derivative of phi's feedback part (feedback_rate_* in BsSmcParams).
  bool feedback_primed_ = false;
  double previous_feedback_n_ = 0.0;
  double feedback_rate_n_s_ = 0.0;
};

}  // namespace hexa
