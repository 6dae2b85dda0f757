#include "hexa/core/rig.hpp"
#include "hexa/core/math_constants.hpp"

#include <cmath>

namespace hexa {
namespace {

Eigen::Vector3d OnCircle(double radius_m, double azimuth_deg) {
  const double a = azimuth_deg * kPi / 180.0;
  return {radius_m * std::cos(a), radius_m * std::sin(a), 0.0};
}

}  // namespace

RigParams MakeReferenceRig() {
  // docs/design.md, "Reference rig: HexaTaar-R". Base joints on a 0.35 m circle, pairs at
  // 0/120/240 deg +-10 deg; platform joints on a 0.25 m circle, pairs at 60/180/300 deg
  // +-10 deg; leg i connects base azimuth -> platform azimuth as listed below.
  constexpr std::array<double, kNumLegs> kBaseAzimuthDeg{-10, 10, 110, 130, 230, 250};
  constexpr std::array<double, kNumLegs> kPlatformAzimuthDeg{310, 50, 70, 170, 190, 290};
  RigParams rig;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    rig.geometry.p_BA_B[i] = OnCircle(0.35, kBaseAzimuthDeg[i]);
    rig.geometry.p_PB_P[i] = OnCircle(0.25, kPlatformAzimuthDeg[i]);
  }
  return rig;
}

}  // namespace hexa
