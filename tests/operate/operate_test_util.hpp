// Helpers of the operator-mode unit tests: fixed-seed sampling (tests/support), the reference
// rig's home pose.
#pragma once

#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"
#include "uniform_sampler.hpp"

namespace hexa::operate_test {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

using Sampler = test::UniformSampler;

inline Pose HomePose(const RigParams& rig) {
  Pose pose;
  pose.p_BP_B_m = rig.geometry.home_position_m;
  return pose;
}

}  // namespace hexa::operate_test
