// The simulated 6-DoF rig (docs/design.md "Plant model"): rigid platform (Newton-Euler,
// quaternion orientation) driven by six pneumatic legs (LegModel, the same code path as
// SingleLegPlant) acting along the legs, gravity, leg moving mass lumped into the platform
// dynamics through the Jacobian (eq 48), sensors (SensorModel) and a DisturbanceProfile
// drawn from an explicit seed. No clock: Step() advances simulated time by its argument.
// docs/plant.md gives the equations, assumptions and measured figures.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexa/core/leg_model.hpp"
#include "hexa/core/plant_faults.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/sensor_model.hpp"
#include "hexa/core/tracker_model.hpp"

namespace hexa {

// `ideal`: the plant equals the controllers' model, perfect sensors.
DisturbanceProfile MakeIdealDisturbanceProfile();
// `realistic` (the default, docs/design.md): friction x1.2, polytropic x1.1, payload +20 %,
// supply ripple +-0.2 bar at 0.5 Hz, joints off by up to 2 mm, potentiometer offset up to
// 1 mm and gain error up to 0.5 %, sensor noise.
DisturbanceProfile MakeRealisticDisturbanceProfile();

// The free-fall bench of Appendix B (Fig. 6) in place of the platform: every leg's cylinder
// hangs rod down from the bench with both chambers vented and `load_kg` hung on its rod, held
// at the top of its stroke until `release_s`, then falls (SingleLegPlant, the plant's leg
// model with the profile's friction). The sensors read the six falling legs like the
// platform's; the valves do nothing (vented). docs/plant.md, "Free-fall identification".
struct FreeFallBenchParams {
  bool enabled = false;
  double load_kg = 12.0;     // the paper's 1.410 kg cannot fall against its friction (docs)
  double release_s = 0.5;
  double start_margin_m = 0.005;  // held this far from the upper end of the stroke
};

// Explicit integrator of the plant ODE (docs/plant.md, "Integrator").
enum class PlantIntegrator {
  kRk4,     // classical Runge-Kutta, 4 stages (stable on the real axis to h lambda = 2.78)
  kSsprk3,  // strong-stability-preserving RK3 (Shu-Osher), 3 stages (to 2.51); the default:
            // as accurate as RK4 on this piecewise-smooth model at 3/4 of the cost
};

struct PlatformPlantConfig {
  RigParams rig = MakeReferenceRig();   // what the controllers know (nominal)
  DisturbanceProfile disturbance = MakeRealisticDisturbanceProfile();
  std::uint64_t seed = 1;
  // Largest substep (docs/plant.md, "Integrator"). A tick is split into
  // ceil(dt / integrator_step_s) equal substeps, or more when the pressure ODE is stiff:
  double integrator_step_s = 5.0e-4;
  // ... the substep is reduced so that (bound of the fastest pressure decay rate) x h stays
  // below this (RK4 / SSPRK3 are stable on the negative real axis up to 2.78 / 2.51).
  double stiffness_step_limit = 1.5;
  PlantIntegrator integrator = PlantIntegrator::kSsprk3;  // docs/plant.md, "Integrator"
  // Rod-side pressure of the holding equilibrium at Reset; <= 0: (P_s + P_a) / 2.
  double home_chamber2_pressure_pa = -1.0;
  // Leg model extras (laminar band, LuGre damping fade, polytropic blend).
  double laminar_pressure_ratio = 0.995;
  double lugre_damping_fade_velocity_m_s = 0.05;
  bool friction_enabled = true;  // false only for energy-conservation tests
  // External pose instrument for kinematic calibration; off by default.
  TrackerParams tracker;
  bool chambers_sealed = false;  // true only for energy-conservation tests (valves never open)
  // The legs' friction: LuGre (default) or the static eq 3 (identification study of what
  // the LuGre dynamics do to an eq 3 fit, docs/identification.md).
  LegModelParams::FrictionModel friction_model = LegModelParams::FrictionModel::kLugre;
  FreeFallBenchParams free_fall;  // enabled: the bench instead of the platform
  // Injected rig faults (sensors, supply; plant_faults.hpp). None by default.
  PlantFaultParams faults;

  void Validate() const;  // throws std::invalid_argument naming field, value and limit
};

// The plant's TRUE geometry for a seed: every joint of `nominal` off by up to
// profile.joint_position_error_max_m (uniform in a ball), drawn from the seed. PlatformPlant
// uses exactly this; the 3-D scene (docs/foxglove.md) recomputes it to draw the simulated legs
// where they really are.
GeometryParams TrueGeometry(const GeometryParams& nominal, const DisturbanceProfile& profile,
                            std::uint64_t seed);

// True state of the rig (ground truth, for evaluation only).
struct PlatformTrueState {
  Pose pose;                                 // p_BP_B, R_BP
  Eigen::Quaterniond q_BP = Eigen::Quaterniond::Identity();
  Vector6d twist_B = Vector6d::Zero();       // [v_BP_B; w_BP_B]
  LegArray<double> length_m{};               // true leg lengths (true geometry, eq 46)
  LegArray<double> piston_position_m{};      // x = length - mid_stroke_length (eq 64)
  LegArray<double> piston_velocity_m_s{};    // l_dot = J twist (eq 48)
  LegArray<LegPneumaticState> legs{};        // P1, P2, spool, bristle
  LegArray<double> applied_valve_v{};        // valve voltages of the last step (clamped)
  double supply_pressure_pa = 0.0;           // with ripple
  double time_s = 0.0;
  std::uint64_t tick = 0;
};

struct PlatformPlantOutput {
  PlantStatus status = PlantStatus::kOk;
  PlatformTrueState truth;
  LegArray<LegSensorReading> legs{};
  ImuReading imu;
  TrackerReading tracker;  // fresh only when the tracker is enabled and due
  LegArray<LegForces> leg_forces{};
};

class PlatformPlant {
 public:
  explicit PlatformPlant(const PlatformPlantConfig& config);  // validates, then Reset()

  // Home pose, at rest, valves at null, every leg's chambers at the pressures that hold the
  // loaded platform (static force balance J^T f = -gravity wrench, P2 fixed). Sensors and
  // the RNG are re-seeded: a reset run repeats bit for bit.
  void Reset();

  // Advances dt_s (one 1 ms tick in the system) with the valve voltages held, in fixed
  // substeps of at most integrator_step_s, then samples the sensors. Voltages outside
  // 0-10 V are clamped (the coil driver saturates). A non-finite voltage or dt ->
  // kInvalidInput and nothing advances; a non-finite result -> kNonFiniteState and the
  // last good state is kept. Never throws, never allocates.
  PlantStatus Step(const LegArray<double>& valve_v, double dt_s);

  const PlatformPlantOutput& output() const { return output_; }
  const PlatformTrueState& truth() const { return output_.truth; }
  const PlatformPlantConfig& config() const { return config_; }

  // The plant's TRUE geometry (nominal + per-seed joint errors) and leg model.
  const GeometryParams& true_geometry() const { return true_geometry_; }
  const LegModel& leg_model() const { return leg_model_; }
  const SensorModel& sensors() const { return sensors_; }
  double platform_mass_kg() const { return platform_mass_kg_; }

  // Kinetic (platform + axial leg mass) + gravitational + sum of LegModel::StoredEnergyJ.
  double TotalEnergyJ() const;
  // Smallest friction dissipation seen at any RK stage since Reset (>= 0 expected).
  double min_friction_dissipation_w() const { return min_dissipation_w_; }
  // Rate of the twist, d/dt [v_BP_B; w_BP_B], at the present state and valve targets (the
  // forward dynamics the integrator uses); tests compare inverse dynamics against it.
  Vector6d twist_rate_B() const;
  // Substeps taken by the last successful Step (step control, docs/plant.md).
  int last_substep_count() const { return last_substep_count_; }

  // Replaces the dynamic state (tests: perturbations, energy checks). Pose/twist/legs are
  // taken from `state`; derived fields are recomputed.
  void SetState(const PlatformTrueState& state);

  static constexpr int kStateSize = 13 + 4 * static_cast<int>(kNumLegs);
  using StateVector = Eigen::Matrix<double, kStateSize, 1>;

 private:
  void Derivative(const StateVector& x, double time_s, StateVector& dxdt, bool record);
  PlantStatus StepBench(double dt_s);
  void ResetBench();
  double SupplyPressurePa(double time_s) const;
  int SubstepCount(double dt_s) const;  // substeps for the next tick (step control)
  void FillTruth();
  void SampleSensors();
  void ApplySensorFaults();

  PlatformPlantConfig config_;
  GeometryParams true_geometry_;
  LegModel leg_model_;
  SensorModel sensors_;
  TrackerModel tracker_;
  double platform_mass_kg_ = 0.0;
  Eigen::Matrix3d platform_inertia_P_ = Eigen::Matrix3d::Identity();
  double leg_mass_kg_ = 0.0;
  double gravity_m_s2_ = 9.81;

  StateVector state_ = StateVector::Zero();
  // Derivative at (state_, time_s_), kept from the last evaluation that recorded the
  // outputs; reused as the first RK stage of the next Step (spool rates refreshed).
  StateVector rate_at_state_ = StateVector::Zero();
  LegArray<double> spool_target_m_{};
  double time_s_ = 0.0;
  std::uint64_t tick_ = 0;
  double min_dissipation_w_ = 0.0;
  int last_substep_count_ = 0;
  PlatformPlantOutput output_;
  std::vector<SingleLegPlant> bench_;  // free-fall bench legs (FreeFallBenchParams)
  LegArray<double> stuck_length_m_{};  // pot-stuck: the reading held
  LegArray<bool> stuck_latched_{};
};

}  // namespace hexa
