// Helpers of the operator-mode unit tests: portable fixed-seed sampling, the reference rig's
// home pose.
#pragma once

#include <cstdint>
#include <random>

#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa::operate_test {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Uniform doubles from the raw 64-bit engine output (std distributions are
// implementation-defined, the engine is not).
class Sampler {
 public:
  explicit Sampler(std::uint64_t seed) : engine_(seed) {}
  double Uniform(double lo, double hi) {
    const double u = static_cast<double>(engine_() >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * u;
  }

 private:
  std::mt19937_64 engine_;
};

inline Pose HomePose(const RigParams& rig) {
  Pose pose;
  pose.p_BP_B_m = rig.geometry.home_position_m;
  return pose;
}

}  // namespace hexa::operate_test
