// One pneumatic leg of the plant: 5/3 proportional valve with spool lag (eq 42), orifice
// area (eq 6, 43), choked/unchoked mass flow (eq 4, 5) routed per spool sign (Tables 4, 5),
// chamber volumes (eq 64), polytropic pressure dynamics per stroke direction (eq 7, 65,
// Table 8), LuGre friction whose steady state is eq 3 (Table 8), stiff spring-damper end
// stops. The same LegModel is used by SingleLegPlant (one vertical cylinder carrying a
// load) and by PlatformPlant (six legs driving the rigid platform), so a controller tuned
// on one leg sees the same physics on the platform. docs/plant.md.
//
// Sign conventions: x = piston position, 0 at mid-stroke, > 0 extends (chamber 1 = cap side
// grows). Forces along +x. Pressures absolute.
#pragma once

#include "hexa/core/friction.hpp"
#include "hexa/core/pneumatics.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// Result of a plant step. The plant never integrates a non-finite value.
enum class PlantStatus {
  kOk = 0,
  kInvalidInput,     // non-finite valve voltage or step: the step was rejected, state kept
  kNonFiniteState,   // the integrator produced a non-finite value: last good state kept
};
const char* ToString(PlantStatus status);

// Effective parameters of one leg as the plant uses them (disturbances already applied).
struct LegModelParams {
  AirParams air;
  CylinderParams cylinder;
  ValveParams valve;
  FrictionParams friction;
  PolytropicSet polytropic;
  // eq 4 is continued linearly in (P_u - P_d) above this pressure ratio (pneumatics.hpp).
  double laminar_pressure_ratio = 0.995;
  // LuGre bristle damping sigma1 fades as exp(-(v/v_d)^2) (friction.hpp), v_d:
  double lugre_damping_fade_velocity_m_s = 0.05;
  // Table 8 gives gamma per stroke direction; the plant blends the two sets with
  // w = 0.5 (1 + v / sqrt(v^2 + v_b^2)) so the pressure ODE stays continuous at v = 0.
  double polytropic_blend_velocity_m_s = 1.0e-3;
  // Free-fall test (Appendix B): both chambers open to atmosphere (pressures pinned at
  // P_a, no pneumatic force); the valve is then irrelevant.
  bool chambers_vented = false;
  // false: no friction force at all (energy-conservation tests only).
  bool friction_enabled = true;
  // true: the valve never passes air, the chambers are closed volumes (energy-conservation
  // tests only; a valve with zero area is not a valid rig: valve.max_orifice_area_m2 > 0).
  bool chambers_sealed = false;
  // kLugre: the plant's dynamic friction (default). kStatic: eq 3 itself, F = g(v) sgn(v) +
  // B v with sgn(0) = 0 (no stiction, cannot hold a load at rest): the instantaneous
  // Coulomb + viscous friction that Appendix B's free-fall model (eq 66) assumes.
  enum class FrictionModel { kLugre, kStatic };
  FrictionModel friction_model = FrictionModel::kLugre;

  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

// The leg's parameters from the rig, with friction and polytropic scales applied
// (DisturbanceProfile: 1.2 and 1.1 in `realistic`, 1 and 1 in `ideal`).
LegModelParams MakeLegModelParams(const RigParams& rig, double friction_scale = 1.0,
                                  double polytropic_scale = 1.0);

// The states the leg integrates itself (its piston position and velocity belong to the
// body it drives: the single-leg load, or the platform through the kinematics).
struct LegPneumaticState {
  double chamber1_pressure_pa = 1.0e5;  // P1, cap side
  double chamber2_pressure_pa = 1.0e5;  // P2, rod side
  double spool_m = 0.0;                 // X_spool (eq 42), > 0 = extend routing
  double bristle_m = 0.0;               // LuGre z
};

// Forces on the piston rod along +x and diagnostics of one evaluation.
struct LegForces {
  double pneumatic_n = 0.0;   // P1 A1 - P2 A2 - P_a A_r (eq 1, 50)
  double friction_n = 0.0;    // force the friction exerts on the rod (opposes motion)
  double end_stop_n = 0.0;    // spring-damper beyond either end of the stroke
  double total_n = 0.0;       // sum of the three
  double friction_dissipation_w = 0.0;  // >= 0: power friction takes out (LuGre storage excluded)
  double chamber1_mass_flow_kg_s = 0.0; // net, > 0 into the chamber
  double chamber2_mass_flow_kg_s = 0.0;
};

class LegModel {
 public:
  LegModel() : LegModel(LegModelParams{}) {}
  // Expects validated params (LegModelParams::Validate).
  explicit LegModel(const LegModelParams& params);

  const LegModelParams& params() const { return params_; }

  // Time derivatives of the leg states and the forces on the rod, for piston position x,
  // velocity v, spool target (eq 42, SpoolTargetM) and the present supply pressure.
  // Pure function; no allocation.
  void Evaluate(const LegPneumaticState& state, double position_m, double velocity_m_s,
                double spool_target_m, double supply_pressure_pa, LegPneumaticState& rate,
                LegForces& forces) const;

  // Bound of the fastest decay rate (1/s) of the leg's pressure ODE over the next
  // `horizon_s` with the spool moving towards `spool_target_m`: R T gamma_in |dm/dP| / V at
  // the smallest chamber volume reachable at speed |v|. The plant picks its RK4 substep so
  // that this rate times the step stays inside RK4's stability interval (docs/plant.md).
  // Decay rate (1/s) of the LuGre bristle deflection at piston speed v: sigma0 |v| / g(v)
  // (friction.hpp); 0 without LuGre friction. Stiff at high speed with stiff bristles: the
  // plant's step control keeps it inside the integrator's stability interval too.
  double BristleRate1S(double velocity_m_s) const;
  double PressureStiffnessBound1S(const LegPneumaticState& state, double position_m,
                                  double velocity_m_s, double spool_target_m,
                                  double horizon_s) const;

  // State at rest with valve closed (spool 0, bristle 0) whose pneumatic force equals
  // `axial_force_n` (the force the rod must push along +x) with the rod-side pressure
  // given: P1 = (F + P2 A2 + P_a A_r) / A1.
  LegPneumaticState Equilibrium(double axial_force_n, double chamber2_pressure_pa) const;

  // Energy stored in the leg: sum_i P_i V_i / (k - 1) + P_a A_r x (work against the
  // atmosphere on the rod) + end-stop spring + LuGre bristle spring sigma0 z^2 / 2.
  // d/dt of it equals minus the mechanical power of the leg force when the chambers are
  // closed and gamma_k = k (adiabatic); docs/plant.md derives it.
  double StoredEnergyJ(const LegPneumaticState& state, double position_m) const;

 private:
  LegModelParams params_;
  OrificeFlowModel orifice_;
  // Constants of Evaluate, precomputed once (docs/measurements/plant.md, "Speed"): reciprocals of the
  // Stribeck velocities (extend, retract) and of the LuGre damping fade velocity, R T.
  double inv_stribeck_extend_s_m_ = 0.0;
  double inv_stribeck_retract_s_m_ = 0.0;
  double inv_fade_velocity_s_m_ = 0.0;
  double gas_rt_j_kg_ = 0.0;
};

// ---------------------------------------------------------------------------------------
// One cylinder carrying a load mass under gravity: the single-leg test rig for controller
// tests and for the free-fall identification (Appendix B).
enum class LegMount {
  kRodUp,    // cylinder vertical, rod up: gravity pulls the load towards retraction (eq 1)
  kRodDown,  // hanging, rod down (Fig. 6 free-fall): gravity pulls towards extension
};

struct SingleLegConfig {
  LegModelParams leg;
  double load_mass_kg = 1.25;      // carried by the rod; the piston+rod mass is added
  double gravity_m_s2 = 9.81;
  LegMount mount = LegMount::kRodUp;
  double integrator_step_s = 1.0e-4;  // RK4 substep (docs/plant.md, "Integrator")

  void Validate() const;  // throws std::invalid_argument
};

// Full state of the single-leg rig.
struct SingleLegState {
  double position_m = 0.0;
  double velocity_m_s = 0.0;
  LegPneumaticState leg;
};

class SingleLegPlant {
 public:
  explicit SingleLegPlant(const SingleLegConfig& config);  // validates, then Reset(0)

  // At rest at `position_m`, valve at null, chambers in equilibrium with the load:
  // P2 = `chamber2_pressure_pa` (default (P_s + P_a) / 2), P1 from the force balance.
  void Reset(double position_m = 0.0, double chamber2_pressure_pa = -1.0);
  void ResetTo(const SingleLegState& state);

  // Advances `dt_s` with the valve voltage held (clamped to the valve's 0-10 V like the
  // real coil driver). Fixed RK4 substeps <= integrator_step_s. Non-finite input ->
  // kInvalidInput, nothing advanced; non-finite result -> kNonFiniteState, state kept.
  PlantStatus Step(double valve_v, double dt_s);

  double position_m() const { return state_.position_m; }
  double velocity_m_s() const { return state_.velocity_m_s; }
  double chamber1_pressure_pa() const { return state_.leg.chamber1_pressure_pa; }
  double chamber2_pressure_pa() const { return state_.leg.chamber2_pressure_pa; }
  double supply_pressure_pa() const { return config_.leg.air.supply_pressure_pa; }
  double spool_m() const { return state_.leg.spool_m; }
  double time_s() const { return time_s_; }
  double moving_mass_kg() const { return moving_mass_kg_; }
  const SingleLegState& state() const { return state_; }
  const SingleLegConfig& config() const { return config_; }
  const LegModel& model() const { return model_; }
  // Forces of the last evaluation at the end of the last step.
  const LegForces& last_forces() const { return last_forces_; }
  // Smallest friction dissipation (W) seen at any RK stage since the last Reset; >= 0 for
  // a dissipative friction model.
  double min_friction_dissipation_w() const { return min_dissipation_w_; }

  // Kinetic + gravitational + LegModel::StoredEnergyJ (docs/plant.md).
  double TotalEnergyJ() const;

 private:
  struct Derivative {
    double position = 0.0, velocity = 0.0;
    LegPneumaticState leg;
  };
  void Derivatives(const SingleLegState& s, double spool_target_m, Derivative& d,
                   LegForces& forces);

  SingleLegConfig config_;
  LegModel model_;
  double moving_mass_kg_ = 0.0;
  double gravity_along_x_m_s2_ = 0.0;  // -g rod up, +g rod down
  SingleLegState state_;
  LegForces last_forces_;
  double time_s_ = 0.0;
  double min_dissipation_w_ = 0.0;
};

}  // namespace hexa
