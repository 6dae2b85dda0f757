// Portable uniform sampling for fixed-seed property tests: doubles from the raw 64-bit engine
// output (the std distributions are implementation-defined, the engine is not), so a seed
// gives the same cases on every platform.
#pragma once

#include <cstdint>
#include <random>

namespace hexa::test {

class UniformSampler {
 public:
  explicit UniformSampler(std::uint64_t seed) : engine_(seed) {}
  double Uniform(double lo, double hi) {
    const double u = static_cast<double>(engine_() >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * u;
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace hexa::test
