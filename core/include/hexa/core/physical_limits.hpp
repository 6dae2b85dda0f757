// Limits derived from physics, across parameter structs (docs/rig_checks.md, "Physical limits"):
// supply pressure against the gas model, masses against what the legs can hold, time
// constants and stiffnesses against the plant's integrator step and the 1 ms tick, controller
// gains against what the valve chain can do. Each limit carries the reason and the figures it
// was computed from; `hexa_check_config --explain` prints them, the rig-file validation
// reports the ones a rig breaks (on the field that sets it), and the plant checks those that
// would make its state non-finite. Also the structural rules that combine two structs
// (stroke margin vs stroke, setpoint timeout vs supervisor period, ripple vs supply, scaled
// polytropic coefficients).
//
// Preconditions: the structs pass their own checks (param_checks.hpp): positive masses,
// areas, time constants. The derivations divide by them.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "hexa/core/control_params.hpp"
#include "hexa/core/param_checks.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct PhysicalLimit {
  std::string field;     // rig-file field reported when the limit is broken
  std::string quantity;  // what is compared, e.g. "supply pressure"
  double value = 0.0;    // the quantity for this rig
  double limit = 0.0;    // the derived limit
  bool upper = true;     // true: value <= limit; false: value >= limit
  std::string unit;      // "Pa", "kg", "s", "1/s", "N", "V/m", "rad/s", ...
  std::string reason;    // the physics and the figures behind the limit
  bool ok() const { return upper ? value <= limit : value >= limit; }  // false for NaN
};

// The plant's defaults the rig file is checked against (PlatformPlantConfig).
inline constexpr double kPlantNominalStep_s = 5.0e-4;  // integrator_step_s
inline constexpr double kPlantRealRateStepLimit = 1.5;  // stiffness_step_limit: monotone decay
inline constexpr int kPlantMaxSubsteps = 1000;          // PlatformPlant::SubstepCount cap

// Limits the plant depends on: ideal-gas validity of the supply pressure, legs able to hold
// the platform (per profile: payload, friction, supply ripple), the spool lag and the pressure
// ODE against the integrator, and (with `include_mechanical_modes`) the fastest mechanical mode
// of the legs (end stops, bristles, pneumatic spring on the lightest effective mass) against
// the step `step_s`. `profiles` (by name) may be empty: the nominal rig alone.
std::vector<PhysicalLimit> DerivePlantLimits(const RigParams& rig,
                                             const std::map<std::string, DisturbanceProfile>& profiles,
                                             double step_s = kPlantNominalStep_s,
                                             bool include_mechanical_modes = true);
// Limits of the leg controllers' gains against the valve chain and the cylinder.
std::vector<PhysicalLimit> DeriveControllerLimits(const RigParams& rig,
                                                  const LegControllerParams& params);

// Reports every broken limit as an issue on its field: "<quantity> <value> <unit> exceeds /
// is below the limit: <reason>".
void CheckPhysicalLimits(ParamChecker& c, const std::vector<PhysicalLimit>& limits);

// Structural rules across structs (no physics derivation): stroke margin below half the
// stroke, setpoint timeout at least the supervisor period, supply ripple below supply minus
// atmosphere, every polytropic coefficient scaled by a profile still in [1, 2].
void CheckSystemRules(ParamChecker& c, const RigParams& rig, const LegControllerParams& leg,
                      const SupervisorParams& supervisor,
                      const std::map<std::string, DisturbanceProfile>& profiles);
// The profile part alone (the plant has one profile).
void CheckProfileAgainstRig(ParamChecker& c, const RigParams& rig, const DisturbanceProfile& p,
                            const std::string& path);

// Text for hexa_check_config --explain: every limit with value, limit, margin and reason.
std::string ExplainLimits(const std::vector<PhysicalLimit>& limits);

}  // namespace hexa
