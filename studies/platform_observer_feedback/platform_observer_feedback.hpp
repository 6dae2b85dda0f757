// The legs' feedback velocity from the platform state observer, a study of the in-process
// lockstep simulation (docs/controller.md "Platform state observer"; not in the system: the
// leg services do not see each other's sensors). Every tick a PlatformStateObserver of the
// supervisor's rig runs on the six legs' inputs (lengths through each leg's potentiometer
// calibration, chamber pressures) and the orientation of the supervisor's newest pose
// estimate (the IMU's, every 5 ms); each BS-SMC's feedback part (e_dot, S) then takes its
// leg's velocity from the observer instead of eq 40 (LegController::Update with a feedback
// velocity). Until the observer's first valid output the legs run as the system's.
#pragma once

#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/platform_state_observer.hpp"

namespace hexa::study {

struct PlatformObserverFeedbackParams {
  bool enabled = false;
  // PlatformStateObserverConfig::disturbance_rate_m_s3 (validated by the observer).
  double disturbance_rate_m_s3 = PlatformStateObserverConfig{}.disturbance_rate_m_s3;
};

// The runner for LockstepConfig::leg_runner; unset when !params.enabled (the system's legs).
LegRunnerFactory PlatformObserverLegRunnerFactory(const PlatformObserverFeedbackParams& params);

}  // namespace hexa::study
