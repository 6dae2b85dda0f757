// Value rules of the parameter structs, one validation per struct in one place (docs/config.md,
// "Validation rules"). The rig-file loader (config/) and the core's own constructors (plant,
// leg model, controllers, supervisor) call the same functions, so a parameter has one rule, one
// limit and one message wherever it is checked. Each rule names the field path of the rig file,
// the offending value and the limit; comparisons are written as !(value OK) so NaN fails too.
// Rules that combine several structs and the limits derived from physics are in
// physical_limits.hpp.
#pragma once

#include <string>
#include <vector>

#include "hexa/core/control_params.hpp"
#include "hexa/core/plant_faults.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct ParamIssue {
  std::string field;    // rig-file path, e.g. "cylinder.cap_area_m2"
  std::string message;  // what is wrong, and why where the limit is not obvious
  std::string value;    // offending value as text
  std::string limit;    // the rule it broke, e.g. "> 0", "(1, 1.6667]"
};

// Shortest text that reads back to the same double ("0.00031416", "inf", "nan").
std::string FormatParam(double value);
// Ten significant digits, for values computed from parameters (limits, derived figures).
std::string FormatDerived(double value);

// Collects issues; `prefix` is prepended to every field path ("" or e.g. "leg_controller.").
class ParamChecker {
 public:
  explicit ParamChecker(std::vector<ParamIssue>& out) : out_(out) {}

  void Fail(const std::string& field, const std::string& message, const std::string& value,
            const std::string& limit);
  // Returns false (and reports) if the value is not finite; further rules then skip it.
  bool Finite(const std::string& field, double v);
  void Positive(const std::string& field, double v, const std::string& what);
  void NonNegative(const std::string& field, double v, const std::string& what);
  void InClosed(const std::string& field, double v, double lo, double hi, const std::string& what);
  void IntInClosed(const std::string& field, int v, int lo, int hi, const std::string& what);
  // A period that the 1 ms plant tick can realise.
  void TickMultiple(const std::string& field, double v, const std::string& what);
  std::size_t count() const { return out_.size(); }

 private:
  std::vector<ParamIssue>& out_;
};

// The plant's tick (docs/design.md "Time"): periods must be whole multiples of it.
inline constexpr double kPlantTick_s = 0.001;

// One function per struct; each checks only its own fields. `path` is the struct's path in
// the rig file ("air", "friction", "disturbance_profile[name=ideal]", ...).
void CheckAirParams(ParamChecker& c, const AirParams& a, const std::string& path = "air");
void CheckCylinderParams(ParamChecker& c, const CylinderParams& y,
                         const std::string& path = "cylinder");
void CheckValveParams(ParamChecker& c, const ValveParams& v, const std::string& path = "valve");
void CheckFrictionParams(ParamChecker& c, const FrictionParams& f,
                         const std::string& path = "friction");
void CheckPolytropicSet(ParamChecker& c, const PolytropicSet& p,
                        const std::string& path = "polytropic");
void CheckPlatformParams(ParamChecker& c, const PlatformParams& p,
                         const std::string& path = "platform");
void CheckSensorNoiseParams(ParamChecker& c, const SensorNoiseParams& s,
                            const std::string& path = "sensors");
void CheckDisturbanceProfile(ParamChecker& c, const DisturbanceProfile& p,
                             const std::string& path);
void CheckDifferentiatorParams(ParamChecker& c, const DifferentiatorParams& d,
                               const std::string& path = "leg_controller.differentiator");
void CheckBsSmcParams(ParamChecker& c, const BsSmcParams& b,
                      const std::string& path = "leg_controller.bssmc");
void CheckPiParams(ParamChecker& c, const PiParams& p, const std::string& path = "leg_controller.pi");
// A calibration as the controllers apply it (rig overlay): offset finite, gain finite and > 0.
// Plausibility against the rig (a few mm, +-10 %) is the overlay validator's (config/).
void CheckPotentiometerCalibrationParams(ParamChecker& c, const PotentiometerCalibrationParams& p,
                                         const std::string& path);
void CheckLegControllerParams(ParamChecker& c, const LegControllerParams& p,
                              const std::string& path = "leg_controller");
void CheckOuterLoopParams(ParamChecker& c, const OuterLoopParams& o,
                          const std::string& path = "supervisor.outer_loop");
void CheckSupervisorParams(ParamChecker& c, const SupervisorParams& s,
                           const std::string& path = "supervisor");
// Injected rig faults (plant_faults.hpp): drift finite, supply-loss time constant > 0, each
// fault at a finite time >= 0 on a leg 1..6 (sensor faults) or leg 0 (IMU, supply).
void CheckPlantFaultParams(ParamChecker& c, const PlantFaultParams& f,
                           const std::string& path = "faults");
// Every struct of a RigParams (no cross-struct rule).
void CheckRigParams(ParamChecker& c, const RigParams& rig);

// For constructors: throws std::invalid_argument("<context>: <field>: <message> (value v,
// limit l); ...") when `issues` is not empty.
void ThrowIfIssues(const std::vector<ParamIssue>& issues, const std::string& context);

}  // namespace hexa
