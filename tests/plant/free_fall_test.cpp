// Free-fall identification (Sec. 3.1 eq 9-12, Appendix B eq 66-72) on the simulated
// single cylinder: hanging rod down, chambers vented, Coulomb + viscous friction (LuGre
// with F_s = F_c, i.e. no Stribeck hump), a load that really falls.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/free_fall.hpp"
#include "hexa/core/leg_model.hpp"

namespace hexa {
namespace {

// The paper's free-fall values (F_c 73.183 N, B 1.539 N s/m, 1.410 kg load) are
// inconsistent: 1.66 kg weighs 16 N and cannot overcome 73 N. We take the extend-direction
// Table 8 values (the falling rod extends) as the truth and a 12 kg load (W = 120 N).
constexpr double kCoulombN = 49.1371;
constexpr double kViscousNsM = 34.4445;
constexpr double kLoadKg = 12.0;

struct Record {
  std::vector<double> t, x;
  double mass_kg = 0.0;
};

Record Simulate(LegModelParams::FrictionModel model) {
  SingleLegConfig c;
  c.leg = MakeLegModelParams(MakeReferenceRig());
  c.leg.chambers_vented = true;
  c.leg.friction_model = model;
  for (FrictionDirectionParams* d : {&c.leg.friction.extend, &c.leg.friction.retract}) {
    d->coulomb_n = kCoulombN;
    d->static_n = kCoulombN;  // Coulomb + viscous only
    d->viscous_n_s_m = kViscousNsM;
  }
  c.load_mass_kg = kLoadKg;
  c.mount = LegMount::kRodDown;
  SingleLegPlant plant(c);
  const double start = -0.5 * c.leg.cylinder.stroke_m + 1e-3;
  plant.Reset(start);
  Record r;
  r.mass_kg = plant.moving_mass_kg();
  r.t.push_back(0.0);
  r.x.push_back(0.0);
  // Sample at 1 kHz until 5 mm before the lower end stop.
  while (plant.position_m() < 0.5 * c.leg.cylinder.stroke_m - 5e-3 && plant.time_s() < 5.0) {
    EXPECT_EQ(plant.Step(5.0, 1e-3), PlantStatus::kOk);
    r.t.push_back(plant.time_s());
    r.x.push_back(plant.position_m() - start);
  }
  return r;
}

TEST(FreeFall, FitRecoversExactModelParameters) {
  // Synthetic eq 67 data: the fit itself is exact.
  const double m = 12.25, g = 9.81, fc = 60.0, b = 20.0;
  const double tau = m / b, a = (m * g - fc) / b;
  std::vector<double> t, x;
  for (int i = 0; i <= 400; ++i) {
    t.push_back(i * 1e-3);
    x.push_back(a * (t.back() + tau * std::exp(-t.back() / tau) - tau));
  }
  const FreeFallFit fit = FitFreeFall(t.data(), x.data(), t.size(), m, g);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.coulomb_n, fc, 1e-6 * fc);
  EXPECT_NEAR(fit.viscous_n_s_m, b, 1e-6 * b);
}

TEST(FreeFall, RecoversCoulombAndViscousFromTheSimulatedFall) {
  const Record r = Simulate(LegModelParams::FrictionModel::kStatic);
  ASSERT_GT(r.t.size(), 200u);  // the load fell through the stroke
  const FreeFallFit fit = FitFreeFall(r.t.data(), r.x.data(), r.t.size(), r.mass_kg, 9.81);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.coulomb_n, kCoulombN, 0.02 * kCoulombN);
  EXPECT_NEAR(fit.viscous_n_s_m, kViscousNsM, 0.02 * kViscousNsM);
  RecordProperty("coulomb_n", std::to_string(fit.coulomb_n));
  RecordProperty("viscous_n_s_m", std::to_string(fit.viscous_n_s_m));
}

TEST(FreeFall, RecoversWithPotentiometerNoise) {
  Record r = Simulate(LegModelParams::FrictionModel::kStatic);
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> noise(0.0, 0.05e-3);  // sigma of the potentiometer
  for (std::size_t i = 1; i < r.x.size(); ++i) r.x[i] += noise(rng);
  const FreeFallFit fit = FitFreeFall(r.t.data(), r.x.data(), r.t.size(), r.mass_kg, 9.81);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.coulomb_n, kCoulombN, 0.02 * kCoulombN);
  EXPECT_NEAR(fit.viscous_n_s_m, kViscousNsM, 0.02 * kViscousNsM);
}

}  // namespace
}  // namespace hexa

namespace hexa {
namespace {

// Characterisation, not a pass/fail of the method: with the plant's LuGre friction the
// bristles must first deflect by F_c / sigma0 (0.5 mm at sigma0 = 1e5 N/m) before the full
// Coulomb force acts, so the load gets an impulse eq 66 does not know about and the fit
// under-estimates F_c and over-estimates B. docs/plant.md reports the measured bias.
TEST(FreeFall, LugrePreslidingBiasesTheAppendixBFit) {
  const Record r = Simulate(LegModelParams::FrictionModel::kLugre);
  const FreeFallFit fit = FitFreeFall(r.t.data(), r.x.data(), r.t.size(), r.mass_kg, 9.81);
  ASSERT_TRUE(fit.ok);
  EXPECT_LT(fit.coulomb_n, kCoulombN);
  EXPECT_GT(fit.viscous_n_s_m, kViscousNsM);
  RecordProperty("lugre_coulomb_n", std::to_string(fit.coulomb_n));
  RecordProperty("lugre_viscous_n_s_m", std::to_string(fit.viscous_n_s_m));
  std::printf("LuGre free-fall fit: F_c %.3f N (true %.4f), B %.3f N s/m (true %.4f)\n",
              fit.coulomb_n, kCoulombN, fit.viscous_n_s_m, kViscousNsM);
}

}  // namespace
}  // namespace hexa
