// Faults of the rig itself, injected into the simulated plant (docs/faults.md): sensors that
// fail (a potentiometer stuck or drifting, a chamber-pressure transducer dead, the IMU
// dropping out) and the loss of the supply pressure. Pure: each fault starts at a simulated
// time given by the caller; no clock, no randomness.
//
// What a fault does to the plant's outputs (PlatformPlant applies them):
//   pot-stuck      leg N's potentiometer keeps the reading it had when the fault started
//   pot-drift      leg N's reading drifts away from the truth at pot_drift_m_s
//   pressure-dead  leg N's cap-side (P1) transducer reads 0 Pa (a dead 0-10 V sensor)
//   imu-dropout    the IMU delivers no more samples (ImuReading::dropped_out)
//   supply-loss    the supply pressure falls to the atmosphere with time constant
//                  supply_loss_time_constant_s (a burst supply hose, a compressor trip):
//                  physics, not only the sensor
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "hexa/core/rig.hpp"

namespace hexa {

enum class PlantFaultKind : std::uint8_t { kPotStuck, kPotDrift, kPressureDead, kImuDropout, kSupplyLoss };

// "pot-stuck", "pot-drift", "pressure-dead", "imu-dropout", "supply-loss".
const char* ToString(PlantFaultKind kind);
bool ParsePlantFaultKind(std::string_view text, PlantFaultKind& kind);
// True for the kinds that concern one leg (the others take leg 0).
bool PlantFaultHasLeg(PlantFaultKind kind);

struct PlantFault {
  PlantFaultKind kind = PlantFaultKind::kPotStuck;
  int leg = 0;             // 1..6 for the leg kinds, 0 otherwise
  double at_time_s = 0.0;  // simulated time the fault starts
};

// Parses "kind:leg:time_s" (e.g. "pot-stuck:3:1.5", "supply-loss:0:2"). Returns "" when valid,
// else a message naming the part that is wrong and what is allowed.
std::string ParsePlantFault(std::string_view text, PlantFault& fault);
// A comma-separated list of those ("pot-stuck:3:1.5,supply-loss:0:2"), appended to `faults`.
// Returns "" when every item is valid, else "'item': message" of the first invalid one.
std::string ParsePlantFaultList(std::string_view list, std::vector<PlantFault>& faults);

struct PlantFaultParams {
  double pot_drift_m_s = 0.01;                // 10 mm/s
  double supply_loss_time_constant_s = 0.1;   // assumption (docs/faults.md)
  std::vector<PlantFault> faults;             // none by default

  void Validate() const;  // throws std::invalid_argument naming field, value and limit
};

}  // namespace hexa
