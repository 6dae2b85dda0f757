// What the plant's dynamic LuGre friction does to an identification with the static eq 3
// (docs/identification.md, "LuGre"): one vertical cylinder (SingleLegPlant, the plant's leg
// model, 3 kg on the rod) driven by the identification excitation for 60 s, friction and
// polytropic coefficients of the `realistic` profile (x1.2, x1.1), identified by least squares
// with hexa_identify's default settings, for {static eq 3, LuGre} x {no noise, the rig's sensor
// noise}. Prints a markdown table of the errors. A study (studies/identification_study.py runs it).
#include <cstdio>
#include <random>
#include <string>

#include "hexa/core/offline_differentiator.hpp"
#include "lsq.hpp"
#include "synthetic.hpp"

using namespace hexa;

int main() {
  const RigParams rig = MakeReferenceRig();
  std::printf("| plant friction | sensor noise | direction | v_s | B | F_s | F_c | gamma_o | gamma_i | gamma_k | Z |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto model : {LegModelParams::FrictionModel::kStatic, LegModelParams::FrictionModel::kLugre}) {
    for (const bool noise : {false, true}) {
      LegModelParams truth = MakeLegModelParams(rig, 1.2, 1.1);
      truth.friction_model = model;
      testing::SyntheticRecording r = testing::MakeSyntheticRecording(rig, truth, 60.0, 11);
      IdentificationConfig ic;  // hexa_identify's defaults
      ic.min_speed_m_s = 0.05;
      ic.min_flow_pressure_difference_pa = 5000.0;
      if (noise) {
        // The rig's sensors: potentiometer sigma 0.05 mm + 12-bit quantisation, pressures 2 kPa.
        std::mt19937_64 rng(5);
        std::normal_distribution<double> n(0.0, 1.0);
        const double lsb = rig.cylinder.stroke_m / 4095.0;
        for (double& l : r.leg.length_m) {
          const double x = l - rig.cylinder.mid_stroke_length_m + rig.sensors.length_sigma_m * n(rng);
          l = rig.cylinder.mid_stroke_length_m + std::round(x / lsb) * lsb;
        }
        for (auto* p : {&r.leg.cap_pressure_pa, &r.leg.rod_pressure_pa, &r.leg.supply_pressure_pa})
          for (double& v : *p) v += rig.sensors.pressure_sigma_pa * n(rng);
        ic.pressure_noise_sigma_pa = rig.sensors.pressure_sigma_pa;
      }
      OfflineGaussianDifferentiator d(ic.differentiator, ic.period_s);
      std::vector<double> v, a;
      d.Derivative(r.leg.length_m, v);
      d.Derivative(v, a);
      std::array<StrokeDataset, 2> data;
      const DatasetReport rep = BuildStrokeDatasets(NominalLegModel::FromRig(rig), r.leg, v, a,
                                                    testing::SingleLegLoad(r, a), ic, 100, data);
      if (!rep.ok) {
        std::fprintf(stderr, "error: %s\n", rep.error.c_str());
        return 1;
      }
      for (int dir = 0; dir < 2; ++dir) {
        const StrokeParams t = StrokeParams::From(dir == 0 ? truth.friction.extend : truth.friction.retract,
                                                  dir == 0 ? truth.polytropic.extend : truth.polytropic.retract);
        const StrokeParams start = StrokeParams::From(dir == 0 ? rig.friction.extend : rig.friction.retract,
                                                      dir == 0 ? rig.polytropic.extend : rig.polytropic.retract);
        const identify::LsqResult fit = identify::FitStrokeLeastSquares(data[static_cast<std::size_t>(dir)], start);
        const CurvatureReport c = AnalyseCurvature(data[static_cast<std::size_t>(dir)], fit.params);
        std::printf("| %s | %s | %s", model == LegModelParams::FrictionModel::kLugre ? "LuGre" : "static eq 3",
                    noise ? "yes" : "no", ToString(static_cast<Stroke>(dir)));
        for (int i = 0; i < StrokeParams::kCount; ++i) {
          const double err = 100.0 * (fit.params.ToVector()[i] - t.ToVector()[i]) / t.ToVector()[i];
          if (c.identifiable[static_cast<std::size_t>(i)]) std::printf(" | %+.2f %%", err);
          else std::printf(" | n.i. (%+.1f %%)", err);
        }
        std::printf(" | %.4g |\n", fit.objective);
      }
    }
  }
  return 0;
}
