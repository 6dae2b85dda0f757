// Reads an identification recording (MCAP, the recorder's protobuf channels) into per-leg,
// per-tick series for hexa_identify: potentiometer, chamber and supply pressures
// (hexa_LegSensors), the valve voltage of each tick and whether it was open loop
// (hexa_ValveCommand, controller CONTROLLER_NONE), the session description
// (hexa_SessionInfo, optional) and, for evaluation only, the plant's truth
// (hexa_PlantTruth, optional). Bad input -> IdentificationInputError naming what is missing.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hexa/core/pneumatic_identification.hpp"
#include "identification.pb.h"

namespace hexa::identify {

class IdentificationInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct IdentificationRecording {
  std::string path;
  std::size_t ticks = 0;                      // series cover ticks 0 .. ticks-1
  LegArray<LegSeries> legs;                   // NaN where a tick has no sample
  LegArray<std::size_t> sensor_samples{};     // per leg
  LegArray<std::size_t> command_samples{};
  std::optional<rec::SessionInfo> session;    // hexa_SessionInfo
  std::optional<rec::PlantTruth> truth;       // hexa_PlantTruth: evaluation only
  bool complete_file = false;
  std::vector<std::string> problems;  // what the reader repaired or found (another build's schema)
};

// Throws IdentificationInputError (or recorder::McapError for a malformed file).
// `progress` (optional) hears the bytes read and the file size.
IdentificationRecording ReadIdentificationRecording(
    const std::string& path,
    const std::function<void(std::uint64_t bytes_read, std::uint64_t file_size)>& progress = {});

}  // namespace hexa::identify
