// Simulated seconds per wall-clock second of the 6-DoF plant alone, valves moving.
// Run: build/bench/plant/plant_bench --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
// The counter "realtime_factor" is simulated time / wall time (target >= 200).
#include <algorithm>
#include <cmath>

#include <benchmark/benchmark.h>

#include "hexa/core/platform_plant.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

void BM_PlatformPlantOneSecond(benchmark::State& state) {
  hexa::PlatformPlantConfig config;  // realistic profile, default integrator step
  config.integrator_step_s = static_cast<double>(state.range(0)) * 1e-6;
  config.integrator = state.range(1) == 3 ? hexa::PlantIntegrator::kSsprk3
                                          : hexa::PlantIntegrator::kRk4;
  hexa::PlatformPlant plant(config);
  long ticks = 0;
  long substeps = 0;
  for (auto _ : state) {
    // One simulated second: 1000 ticks of 1 ms, valves swept around null so that flows,
    // friction and pressures are all active.
    for (int k = 0; k < 1000; ++k) {
      hexa::LegArray<double> v;
      const double t = plant.truth().time_s;
      for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
        v[i] = 5.0 + 1.2 * std::sin(2.0 * kPi * (0.5 + 0.2 * i) * t);
      }
      benchmark::DoNotOptimize(plant.Step(v, 1e-3));
      substeps += plant.last_substep_count();
      ++ticks;
    }
    if (plant.truth().time_s > 20.0) {
      state.PauseTiming();
      plant.Reset();
      state.ResumeTiming();
    }
  }
  state.counters["realtime_factor"] =
      benchmark::Counter(static_cast<double>(ticks) * 1e-3, benchmark::Counter::kIsRate);
  state.counters["substeps_per_tick"] =
      static_cast<double>(substeps) / static_cast<double>(std::max(ticks, 1L));
}
// Arguments: nominal substep in microseconds, integrator order (4 = RK4, 3 = SSPRK3).
BENCHMARK(BM_PlatformPlantOneSecond)
    ->ArgNames({"step_us", "order"})
    ->Args({250, 4})
    ->Args({500, 4})
    ->Args({1000, 4})
    ->Args({500, 3})
    ->Args({1000, 3})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
