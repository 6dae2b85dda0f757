// What the controllers and the supervisor believe about the rig, leg by leg: the rig file's
// nominal model, possibly corrected per leg by rig overlays (identification, kinematic
// calibration; config/, docs/config.md "Rig overlays"). The simulated plant never uses it:
// the plant simulates the rig file plus a disturbance profile (its truth).
//
// Plain data; built by config/ (MakeControllerModel) or from a rig in code (FromRig).
#pragma once

#include <cstddef>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// One leg controller's view: its pneumatic / friction model (eq 3, 4, 7, 14, 64), its
// controller parameters (gains; the BS-SMC's effective mass and gravity load may differ per
// leg) and the calibration of its potentiometer.
struct LegControllerModel {
  NominalLegModel model;
  LegControllerParams params;
  // Reaches LegControllerConfig::potentiometer; identity unless an overlay calibrates it.
  PotentiometerCalibrationParams potentiometer;
};

struct ControllerModel {
  // Joint positions the supervisor's kinematics use (eq 46-48): calibrated by an overlay,
  // else the rig file's nominal geometry.
  GeometryParams geometry;
  // Platform mass and inertia (with its payload) the supervisor's feed-forward and the coupled
  // legs' W use (eq 48's mass matrix): an overlay's estimate, else the rig file's.
  PlatformParams platform;
  LegArray<LegControllerModel> legs{};

  // Every leg = the rig's nominal model and the same controller parameters (no overlay).
  static ControllerModel FromRig(const RigParams& rig, const LegControllerParams& params);

  // `rig` with this model's geometry and platform: what the supervisor is constructed with.
  RigParams SupervisorRig(const RigParams& rig) const;
};

}  // namespace hexa
