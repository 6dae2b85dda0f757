// The kinematic calibration procedure in process (what hexa_session --trajectory calibration
// --tracker + hexa_calibrate do over DDS), shared by hexa_sim --calibrate and
// platform_study --calibrate: the supervisor visits the designed poses, the tracker measures
// them, the still windows are averaged and fitted (calibration_fit.hpp).
#pragma once

#include <cstdio>

#include "hexa/core/calibration.hpp"
#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/payload_estimation.hpp"

namespace hexa::calib {

// Runs the procedure on `base` (tracker on, nominal controller model, outer loop off), prints
// the fit against the plant's truth to `report` (the lines studies/accuracy_tables.py reads),
// and returns false when the run or the fit failed. `payload`: the platform's payload from the
// same run, as hexa_calibrate estimates it (payload_estimation.hpp).
bool CalibrateInProcess(const LockstepConfig& base, KinematicCalibration& out, std::FILE* report,
                        PayloadEstimate& payload);

// The fitted calibration reaches the controllers as a rig overlay would (ControllerModel):
// calibrated joints and potentiometer offsets and gains in config.controllers, and a precise
// payload estimate's platform mass and inertia (as hexa_calibrate writes it to the overlay).
void ApplyKinematicCalibration(const KinematicCalibration& calibration, const PayloadEstimate& payload,
                               LockstepConfig& config);

}  // namespace hexa::calib
