// Per-call cost of the kinematics (eq 46-48) and the forward-kinematics solvers on the
// reference rig. Poses are drawn once (fixed seed) from the workspace of docs/design.md and
// cycled through, so branch predictors and caches see realistic variety.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

struct Sample {
  Pose pose;
  LegArray<double> length_m;
};

std::vector<Sample> WorkspaceSamples(const RigParams& rig, int count) {
  std::mt19937_64 engine(20240611u);
  auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(engine() >> 11) * 0x1.0p-53;
  };
  std::vector<Sample> out;
  while (static_cast<int>(out.size()) < count) {
    Vector6d v;
    v << uniform(-0.08, 0.08), uniform(-0.08, 0.08), 0.45 + uniform(-0.08, 0.08),
        uniform(-15 * kDeg, 15 * kDeg), uniform(-15 * kDeg, 15 * kDeg),
        uniform(-15 * kDeg, 15 * kDeg);
    Sample s;
    s.pose = PoseFromVector(v);
    InverseKinematics(rig.geometry, s.pose, s.length_m);
    bool inside = true;
    for (double l : s.length_m) {
      inside &= std::abs(l - rig.cylinder.mid_stroke_length_m) <= 0.5 * rig.cylinder.stroke_m;
    }
    if (inside) out.push_back(s);
  }
  return out;
}

// Consecutive 5 ms supervisor samples of the combined trajectory (eq 49, 1 Hz).
std::vector<Sample> TrajectorySamples(const RigParams& rig) {
  std::vector<Sample> out;
  for (int k = 0; k < 200; ++k) {
    const double t_s = 0.005 * k;
    const double s = std::sin(2 * kPi * t_s), c = std::cos(2 * kPi * t_s);
    Sample sample;
    sample.pose =
        PoseFromVector((Vector6d() << 0.08 * s, 0.08 * c, 0.45 + 0.08 * s, 0, 0, 0).finished());
    InverseKinematics(rig.geometry, sample.pose, sample.length_m);
    out.push_back(sample);
  }
  return out;
}

constexpr int kNumSamples = 1024;  // power of two: cheap wrap-around

void BM_InverseKinematics(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = WorkspaceSamples(rig, kNumSamples);
  LegArray<double> length_m;
  LegArray<Eigen::Vector3d> unit_B;
  std::size_t n = 0;
  for (auto _ : state) {
    InverseKinematics(rig.geometry, samples[n++ & (kNumSamples - 1)].pose, length_m, &unit_B);
    benchmark::DoNotOptimize(length_m);
    benchmark::DoNotOptimize(unit_B);
  }
}
BENCHMARK(BM_InverseKinematics);

void BM_LegJacobian(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = WorkspaceSamples(rig, kNumSamples);
  Matrix6d J;
  std::size_t n = 0;
  for (auto _ : state) {
    LegJacobian(rig.geometry, samples[n++ & (kNumSamples - 1)].pose, J);
    benchmark::DoNotOptimize(J);
  }
}
BENCHMARK(BM_LegJacobian);

void BM_GqfkPosition(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = WorkspaceSamples(rig, kNumSamples);
  Eigen::Vector3d p;
  std::size_t n = 0;
  for (auto _ : state) {
    const Sample& s = samples[n++ & (kNumSamples - 1)];
    benchmark::DoNotOptimize(GqfkPosition(rig.geometry, s.pose.R_BP, s.length_m, kGqfkDefaultLegs, p));
    benchmark::DoNotOptimize(p);
  }
}
BENCHMARK(BM_GqfkPosition);

void BM_GqfkLeastSquares(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = WorkspaceSamples(rig, kNumSamples);
  GqfkLsqResult result;
  std::size_t n = 0;
  for (auto _ : state) {
    const Sample& s = samples[n++ & (kNumSamples - 1)];
    benchmark::DoNotOptimize(GqfkLeastSquares(rig.geometry, s.pose.R_BP, s.length_m, 0.005, result));
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_GqfkLeastSquares);

// The outlier path: one leg 5 cm off, so the six leave-one-out refits run.
void BM_GqfkLeastSquaresOneBadLeg(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  auto samples = WorkspaceSamples(rig, kNumSamples);
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i].length_m[i % kNumLegs] += 0.05;
  GqfkLsqResult result;
  std::size_t n = 0;
  for (auto _ : state) {
    const Sample& s = samples[n++ & (kNumSamples - 1)];
    benchmark::DoNotOptimize(GqfkLeastSquares(rig.geometry, s.pose.R_BP, s.length_m, 0.005, result));
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_GqfkLeastSquaresOneBadLeg);

void BM_NewtonRaphsonFkFromHome(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = WorkspaceSamples(rig, kNumSamples);
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  NewtonFkResult result;
  std::size_t n = 0;
  long iterations = 0;
  for (auto _ : state) {
    const Sample& s = samples[n++ & (kNumSamples - 1)];
    benchmark::DoNotOptimize(NewtonRaphsonFk(rig.geometry, s.length_m, home, {}, result));
    iterations += result.iterations;
  }
  state.counters["newton_iterations"] =
      benchmark::Counter(static_cast<double>(iterations), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_NewtonRaphsonFkFromHome);

// The supervisor's use: each 5 ms sample starts from the previous solution.
void BM_NewtonRaphsonFkWarmStart(benchmark::State& state) {
  const RigParams rig = MakeReferenceRig();
  const auto samples = TrajectorySamples(rig);
  NewtonFkResult result;
  Pose previous = samples.back().pose;
  std::size_t n = 0;
  long iterations = 0;
  for (auto _ : state) {
    const Sample& s = samples[n];
    n = (n + 1) % samples.size();
    benchmark::DoNotOptimize(NewtonRaphsonFk(rig.geometry, s.length_m, previous, {}, result));
    previous = result.pose;
    iterations += result.iterations;
  }
  state.counters["newton_iterations"] =
      benchmark::Counter(static_cast<double>(iterations), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_NewtonRaphsonFkWarmStart);

}  // namespace
}  // namespace hexa

BENCHMARK_MAIN();
