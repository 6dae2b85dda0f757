// Integrator convergence check (docs/plant.md "Integrator"): the same 5 s run with moving
// valves (realistic profile, seed 1, valves swept through full opening so that end stops,
// choked flow and stick-slip all occur) at RK4 substeps h; the error of each against a
// reference at h = 10 us. Prints the max position error and max chamber-pressure error.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hexa/core/platform_plant.hpp"

namespace {
constexpr double kPi = 3.14159265358979323846;

struct Trace {
  std::vector<double> position_m, pressure_pa, length_m;
  bool ok = true;
};

Trace Run(double step_s, double amplitude_v,
          hexa::PlantIntegrator integrator = hexa::PlantIntegrator::kRk4) {
  hexa::PlatformPlantConfig config;
  config.integrator_step_s = step_s;
  config.integrator = integrator;
  hexa::PlatformPlant plant(config);
  Trace tr;
  for (int k = 0; k < 5000; ++k) {
    hexa::LegArray<double> v;
    const double t = k * 1e-3;
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
      v[i] = 5.0 + amplitude_v * std::sin(2.0 * kPi * (0.5 + 0.2 * i) * t);
    }
    if (plant.Step(v, 1e-3) != hexa::PlantStatus::kOk) tr.ok = false;
    const auto& truth = plant.truth();
    for (int j = 0; j < 3; ++j) tr.position_m.push_back(truth.pose.p_BP_B_m[j]);
    for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
      tr.pressure_pa.push_back(truth.legs[i].chamber1_pressure_pa);
      tr.pressure_pa.push_back(truth.legs[i].chamber2_pressure_pa);
      tr.length_m.push_back(truth.length_m[i]);
    }
  }
  return tr;
}

double MaxDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}
}  // namespace

// Conservative case of tests/plant (closed chambers, no friction, gamma = k): energy drift
// over 10 s, a smooth problem on which RK4's order is visible.
double EnergyDrift(double step_s, hexa::PlantIntegrator integrator) {
  hexa::PlatformPlantConfig c;
  c.disturbance = hexa::MakeIdealDisturbanceProfile();
  c.chambers_sealed = true;
  c.friction_enabled = false;
  const double k = c.rig.air.heat_ratio;
  c.rig.polytropic.extend = {k, k, k};
  c.rig.polytropic.retract = {k, k, k};
  c.integrator_step_s = step_s;
  c.integrator = integrator;
  hexa::PlatformPlant plant(c);
  hexa::PlatformTrueState s = plant.truth();
  s.twist_B << 0.05, -0.04, 0.08, 0.3, -0.2, 0.4;
  plant.SetState(s);
  const double e0 = plant.TotalEnergyJ();
  hexa::LegArray<double> null;
  null.fill(5.0);
  double drift = 0.0;
  for (int i = 0; i < 10000; ++i) {
    plant.Step(null, 1e-3);
    drift = std::max(drift, std::abs(plant.TotalEnergyJ() - e0));
  }
  return drift;
}

int main(int argc, char** argv) {
  // Usage: plant_convergence [rk4|ssprk3]  (integrator under test; the reference is always
  // RK4 at h = 10 us).
  hexa::PlantIntegrator integrator = hexa::PlantIntegrator::kRk4;
  if (argc > 1 && std::string(argv[1]) == "ssprk3") {
    integrator = hexa::PlantIntegrator::kSsprk3;
  } else if (argc > 1 && std::string(argv[1]) != "rk4") {
    std::fprintf(stderr, "usage: plant_convergence [rk4|ssprk3]\n");
    return 2;
  }
  std::printf("integrator %s\n", integrator == hexa::PlantIntegrator::kRk4 ? "rk4" : "ssprk3");
  std::printf("energy drift over 10 s, conservative case\n%10s %16s\n", "h [us]", "max |dE| [J]");
  for (double h_us : {62.5, 125.0, 250.0, 500.0, 1000.0}) {
    std::printf("%10.1f %16.3e\n", h_us, EnergyDrift(h_us * 1e-6, integrator));
  }
  for (double amplitude : {1.5, 5.0}) {
    const Trace ref = Run(10e-6, amplitude);
    std::printf("valve amplitude +-%.1f V around null; reference RK4 h = 10 us\n", amplitude);
    std::printf("%10s %16s %16s %16s %s\n", "h [us]", "max |dp| [m]", "max |dl| [m]",
                "max |dP| [Pa]", "status");
    for (double h_us : {20.0, 50.0, 100.0, 125.0, 200.0, 250.0, 333.333333, 500.0, 1000.0}) {
      const Trace tr = Run(h_us * 1e-6, amplitude, integrator);
      const bool finite = tr.ok;
      std::printf("%10.1f %16.3e %16.3e %16.3e %s\n", h_us,
                  finite ? MaxDiff(tr.position_m, ref.position_m) : NAN,
                  finite ? MaxDiff(tr.length_m, ref.length_m) : NAN,
                  finite ? MaxDiff(tr.pressure_pa, ref.pressure_pa) : NAN,
                  finite ? "ok" : "NON-FINITE");
    }
  }
  return 0;
}
