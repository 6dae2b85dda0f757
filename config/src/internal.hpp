// Helpers shared by the rig-file loader and the validator (not installed).
#pragma once

#include <string>

#include "hexa/core/rig.hpp"

namespace hexa::config::internal {

// Shortest text that reads back to the same double ("0.00031416", "inf", "nan").
std::string FormatDouble(double value);
// Ten significant digits, for values computed from the file (leg lengths, limits).
std::string FormatDerived(double value);


// Geometry figures used by validation and by Summary().
struct HomeGeometry {
  LegArray<double> length_m{};
  double jacobian_condition = 0.0;     // of the scaled home-pose Jacobian (inf if singular)
  double characteristic_length_m = 0.0;  // RMS platform joint radius (scales rotations)
};
HomeGeometry ComputeHomeGeometry(const GeometryParams& geometry);

}  // namespace hexa::config::internal
