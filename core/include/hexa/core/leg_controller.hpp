// One leg's position controller as the leg_ctrl service runs it every 1 ms sensor tick:
// validates the inputs, interpolates the 5 ms setpoint to the tick, adds the outer-loop
// correction, and runs the BS-SMC (Sec. 3.2) or the PI baseline (ref [11]). Holds (valve at
// null) when there is no setpoint yet, when the setpoint is stale, or when any input is
// non-finite or out of range. Pure: time is an argument; Update neither throws nor
// allocates and never outputs a non-finite number.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/coupled_legs.hpp"
#include "hexa/core/controller_model.hpp"
#include "hexa/core/excitation.hpp"
#include "hexa/core/pi_controller.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// kExcitation: identification experiment (excitation.hpp): open-loop valve excitation inside
// the leg's window, BS-SMC on the setpoints outside it.
enum class LegControllerKind : std::uint8_t { kBsSmc, kPi, kExcitation };

// Matches idl LegCtrlStatus.
enum class LegControlStatus : std::uint8_t {
  kOk,
  kHoldNoSetpoint,     // no setpoint received yet: valve at null
  kHoldStaleSetpoint,  // setpoint older than setpoint_timeout_s: valve at null
  kHoldBadInput,       // non-finite or out-of-range sensor or setpoint: valve at null
  kHoldSupervisor,     // setpoint says hold: the controller keeps length_m at zero velocity
};

const char* ToString(LegControlStatus status);

// Which input put the controller in kHoldBadInput (kNone otherwise).
enum class LegInputFault : std::uint8_t {
  kNone,
  kTime,            // non-finite tick time
  kLength,          // potentiometer reading outside the stroke (+ margin) or not finite
  kCapPressure,     // P1 outside [min_pressure_pa, max_pressure_pa] or not finite
  kRodPressure,     // P2 likewise
  kSupplyPressure,  // P_s likewise
  kSupplyLow,       // P_s below min_supply_pressure_pa: the valve cannot deliver the model's flow
  kSetpoint,        // setpoint not finite, from the future or beyond the envelope
};
const char* ToString(LegInputFault fault);

struct LegControllerConfig {
  LegControllerKind kind = LegControllerKind::kBsSmc;
  LegControllerParams params;
  NominalLegModel model;           // the controller's nominal model of the leg
  double period_s = 0.001;        // sensor / control period
  // Plausibility limits: anything outside -> kHoldBadInput.
  double length_margin_m = 0.02;  // beyond either end of the stroke
  double min_pressure_pa = 0.2e5;
  double max_pressure_pa = 12.0e5;
  // Supply below this: the controller's flow model (eq 4, 5) no longer describes the valve
  // and the leg cannot follow; hold (valve closed keeps the air in the chambers). FromRig:
  // half the nominal gauge supply, P_a + (P_s - P_a) / 2 (docs/faults.md).
  double min_supply_pressure_pa = 0.0;
  double max_setpoint_speed_m_s = 2.0;
  double max_setpoint_acceleration_m_s2 = 100.0;
  double max_correction_m = 0.05;
  double max_feedforward_force_n = 2000.0;        // |force| beyond -> bad input
  double max_feedforward_force_rate_n_s = 1.0e5;  // |rate| beyond -> bad input
  // Calibration of this leg's potentiometer from a rig overlay (reading = offset + gain x).
  // Carried to the controller for the kinematic calibration (docs/config.md, "Rig
  // overlays"); identity by default.
  PotentiometerCalibrationParams potentiometer;
  // kExcitation only: the leg's excitation window and sequence.
  ExcitationParams excitation;
  // params.coupled.enabled: this leg's index (0-based) and row of W (AssignCouplingRow).
  std::size_t leg_index = 0;
  LegArray<double> coupling_row{};

  static LegControllerConfig FromRig(const RigParams& rig, const LegControllerParams& params,
                                     LegControllerKind kind);
  // Leg `leg_index` (0-based) of a per-leg controller model (rig file + overlays).
  static LegControllerConfig FromModel(const ControllerModel& model, std::size_t leg_index,
                                       LegControllerKind kind);
  void Validate() const;  // throws std::invalid_argument naming field, value and limit
};

// Coupled leg feedback: `config`'s leg index and its row of W at home of `supervisor_rig` (the
// rig the supervisor uses: ControllerModel::SupervisorRig), reference mass the BS-SMC's
// effective mass; nothing when params.coupled is off. Throws std::invalid_argument.
void AssignCouplingRow(const RigParams& supervisor_rig, std::size_t leg_index,
                       LegControllerConfig& config);

struct LegControllerInput {
  // Sensor sample of this tick.
  std::uint64_t tick = 0;
  double time_s = 0.0;
  double length_m = 0.0;
  double cap_pressure_pa = 1.0e5;
  double rod_pressure_pa = 1.0e5;
  double supply_pressure_pa = 7.0e5;
  // Latest setpoint (values at setpoint_time_s).
  bool has_setpoint = false;
  std::uint64_t setpoint_tick = 0;
  double setpoint_time_s = 0.0;
  double setpoint_length_m = 0.0;
  double setpoint_velocity_m_s = 0.0;
  double setpoint_acceleration_m_s2 = 0.0;
  double correction_m = 0.0;  // outer-loop correction (Sec. 4.1), added to the length
  bool hold = false;
  // Inverse-dynamics feed-forward of the setpoint: force at setpoint_time_s and
  // its rate; interpolated like the length. Not valid: the lumped load model (paper).
  bool feedforward_valid = false;
  double feedforward_force_n = 0.0;
  double feedforward_force_rate_n_s = 0.0;
  // The six legs' feedback parts of the previous tick, relayed by the plant with this
  // sample (coupled leg feedback); not present: none.
  RelayedFeedback relayed;
};

struct LegControllerOutput {
  std::uint64_t tick = 0;           // tick answered
  std::uint64_t setpoint_tick = 0;  // tick of the setpoint used
  double valve_v = 5.0;
  LegControlStatus status = LegControlStatus::kHoldNoSetpoint;
  LegInputFault input_fault = LegInputFault::kNone;  // why kHoldBadInput
  double input_fault_value = 0.0;                   // the offending value (SI)
  double desired_length_m = 0.0;    // interpolated setpoint + correction actually used
  double desired_velocity_m_s = 0.0;
  double feedforward_force_n = 0.0; // interpolated feed-forward used (0 when none)
  double sliding_surface_m_s = 0.0; // S (eq 19); 0 for the PI baseline
  double velocity_m_s = 0.0;        // estimated leg velocity (BS-SMC), 0 for PI
  double desired_force_n = 0.0;     // phi (BS-SMC)
  // Diagnostics of the BS-SMC (0 for the PI baseline): z (eq 35) and the phi_dot used (eq 38).
  double force_error_n = 0.0;
  double desired_force_rate_n_s = 0.0;
  // Adapted friction scale theta of the BS-SMC (BsSmcParams::friction_adaptation_*; 1 when the
  // adaptation is off, and for the PI baseline). Kept through holds: a leg property.
  double friction_scale = 1.0;
  // The valve was driven open loop this tick (kExcitation inside its window); the position
  // guard of the excitation was in control when `guarding`.
  bool open_loop = false;
  bool guarding = false;
  // The BS-SMC's own feedback part of this tick (for the other legs; valid when it ran), and
  // whether the coupled part acted this tick (params.coupled.enabled and the relay complete).
  FeedbackPart feedback;
  bool coupled = false;
};

class LegController {
 public:
  explicit LegController(const LegControllerConfig& config);  // validates (throws)

  void Update(const LegControllerInput& input, LegControllerOutput& output);
  // Study (studies/platform_observer_feedback): as Update, the BS-SMC's feedback part
  // with `feedback_velocity_m_s` (BsSmcInput::feedback_velocity_m_s) as the leg's velocity.
  void Update(const LegControllerInput& input, LegControllerOutput& output, double feedback_velocity_m_s);

  // Coupled leg feedback (BsSmcController::Begin / Finish; docs/measurements/control_coupled_feedback.md "Coupled leg
  // feedback"): BeginCoupled does everything Update does up to the BS-SMC's feedback part and
  // returns it; nothing (the output is then final) when the leg holds, is open loop or runs
  // the PI. FinishCoupled, only after a BeginCoupled that returned a value, completes the
  // BS-SMC with the feedback part mixed by the caller.
  // `observer_force_n`: BsSmcInput::observer_force_n (none: the leg's own pneumatic force);
  // `observer_velocity`: BsSmcInput::feedback_velocity_from_observer.
  std::optional<BsSmcFeedback> BeginCoupled(const LegControllerInput& input,
                                            LegControllerOutput& output,
                                            std::optional<double> observer_force_n = std::nullopt,
                                            bool observer_velocity = false);
  void FinishCoupled(const BsSmcFeedback& applied, LegControllerOutput& output);

  // Setpoint at time_s from one at t0 (eq: l + v dt + a dt^2 / 2), for tests and tools.
  static void Interpolate(const LegControllerInput& input, double& length_m, double& velocity_m_s,
                          double& acceleration_m_s2);

  const LegControllerConfig& config() const { return config_; }

 private:
  LegInputFault CheckSensors(const LegControllerInput& in, double& value) const;
  bool LengthPlausible(double length_m) const;
  // Returns false (Prepare's "no law to run").
  bool Hold(LegControlStatus status, LegControllerOutput& out,
            LegInputFault fault = LegInputFault::kNone, double value = 0.0);
  // Checks, calibration, interpolation; true when a control law is to run on pending_.
  bool Prepare(const LegControllerInput& input, LegControllerOutput& out);
  void FinishBsSmc(const BsSmcOutput& o, LegControllerOutput& out);
  void RunPi(LegControllerOutput& out);
  void Defend(LegControllerOutput& out);  // never a non-finite or out-of-range voltage

  LegControllerConfig config_;
  BsSmcController bssmc_;
  PiController pi_;
  std::optional<ExcitationGenerator> excitation_;  // kExcitation only
  bool active_ = false;  // the control law ran last tick (histories valid)
  bool potentiometer_calibrated_ = false;  // config_.potentiometer is not the identity
  double last_desired_length_m_ = 0.0;
  BsSmcInput pending_;  // the law's input of this period (Prepare)
  std::optional<CoupledFeedbackMix> coupling_;  // params.coupled.enabled
};

}  // namespace hexa
