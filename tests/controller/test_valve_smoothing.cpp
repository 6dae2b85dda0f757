// Valve-command smoothing of the BS-SMC (docs/controller.md "Valve chatter"): the linear band
// of the eq 43 inversion near null and the spool-command low-pass.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hexa/core/bssmc_controller.hpp"

namespace hexa {
namespace {

BsSmcConfig Config(double band, double tau_s) {
  BsSmcConfig c;
  c.model = NominalLegModel::FromRig(MakeReferenceRig());
  c.params.null_band_area_fraction = band;
  c.params.spool_filter_time_constant_s = tau_s;
  return c;
}

TEST(BsSmcValveSmoothing, NullBandIsAContinuousMonotoneChordOfTheSquareRoot) {
  const BsSmcController ctrl(Config(0.25, 0.0));
  // Inside the band: chord r / sqrt(r0), finite slope 2 at null (sqrt has infinite slope).
  EXPECT_DOUBLE_EQ(ctrl.SpoolFractionForArea(0.0), 0.0);
  EXPECT_NEAR(ctrl.SpoolFractionForArea(0.01), 0.02, 1e-12);
  // Continuous at r0 and the exact inverse of eq 43 above it.
  EXPECT_NEAR(ctrl.SpoolFractionForArea(0.25 - 1e-12), 0.5, 1e-9);
  EXPECT_DOUBLE_EQ(ctrl.SpoolFractionForArea(0.64), 0.8);
  EXPECT_DOUBLE_EQ(ctrl.SpoolFractionForArea(3.0), 1.0);
  double prev = -1.0;
  for (int i = 0; i <= 1000; ++i) {
    const double s = ctrl.SpoolFractionForArea(i / 1000.0);
    EXPECT_GE(s, prev);
    EXPECT_LE(s, std::sqrt(i / 1000.0) + 1e-12);  // never opens more than the exact inverse
    prev = s;
  }
  const BsSmcController paper(Config(0.0, 0.0));
  EXPECT_DOUBLE_EQ(paper.SpoolFractionForArea(0.01), 0.1);  // band 0 = the paper's sqrt
}

// Same noisy sensor sequence at rest: the smoothing must reduce the tick-to-tick voltage
// motion, and the long-run mean command must stay near null (no bias from the filter).
double MeanAbsStepV(double band, double tau_s, double& mean_v) {
  BsSmcController ctrl(Config(band, tau_s));
  std::mt19937_64 rng(3);
  std::normal_distribution<double> len(0.0, 0.05e-3), pr(0.0, 2e3);
  const double mid = ctrl.config().model.cylinder.mid_stroke_length_m;
  // Chamber pressures that balance the nominal load at rest (z ≈ 0).
  const double a1 = ctrl.config().model.cylinder.cap_area_m2, a2 = ctrl.config().model.cylinder.annulus_area_m2;
  BsSmcInput in;
  in.desired_length_m = mid;
  in.rod_pressure_pa = 4.0e5;
  BsSmcOutput out;
  in.length_m = mid;
  ctrl.Update(in, out);
  const double phi0 = out.desired_force_n;  // z = P1 A1 - P2 A2 - phi = 0 (eq 35)
  const double p1 = (phi0 + in.rod_pressure_pa * a2) / a1;
  ctrl.Reset();
  double sum = 0.0, prev = 0.0, sum_v = 0.0;
  const int n = 5000;
  for (int k = 0; k < n; ++k) {
    in.length_m = mid + len(rng);
    in.cap_pressure_pa = p1 + pr(rng);
    in.rod_pressure_pa = 4.0e5 + pr(rng);
    ctrl.Update(in, out);
    if (k > 100) sum += std::abs(out.valve_v - prev);
    if (k > 100) sum_v += out.valve_v;
    prev = out.valve_v;
  }
  mean_v = sum_v / (n - 101);
  return sum / (n - 101);
}

TEST(BsSmcValveSmoothing, BandAndFilterReduceTheNoiseDrivenValveMotionAtRest) {
  double m0 = 0, m1 = 0, m2 = 0;
  const double raw = MeanAbsStepV(0.0, 0.0, m0);
  const double band = MeanAbsStepV(0.25, 0.0, m1);
  const double both = MeanAbsStepV(0.25, 0.002, m2);
  std::printf("mean |du| at rest: sqrt %.3f, band %.3f, band + 2 ms filter %.3f V/tick\n", raw, band, both);
  EXPECT_LT(band, 0.8 * raw);
  EXPECT_LT(both, 0.5 * band);
  EXPECT_NEAR(m1, 5.0, 0.5);
  EXPECT_NEAR(m2, 5.0, 0.5);
}

TEST(BsSmcValveSmoothing, FilterIsAFirstOrderLagOnTheSpoolCommand) {
  // Constant large error: unfiltered the spool is at its limit on the first tick; filtered it
  // approaches it as 1 - (tau / (tau + h))^k.
  BsSmcController filtered(Config(0.25, 0.002));
  BsSmcInput in;
  const double mid = filtered.config().model.cylinder.mid_stroke_length_m;
  in.length_m = mid - 0.05;  // 50 mm short: full extend requested
  in.desired_length_m = mid;
  in.cap_pressure_pa = 2e5;
  in.rod_pressure_pa = 4e5;
  BsSmcOutput out;
  const double xmax = filtered.config().model.valve.max_spool_m;
  const double r = 0.002 / 0.003;
  for (int k = 1; k <= 10; ++k) {
    filtered.Update(in, out);
    EXPECT_NEAR(out.spool_m / xmax, 1.0 - std::pow(r, k), 1e-9) << "tick " << k;
  }
  filtered.Reset();
  filtered.Update(in, out);
  EXPECT_NEAR(out.spool_m / xmax, 1.0 - r, 1e-9);  // reset clears the filter state
}

TEST(BsSmcValveSmoothing, ValidateRejectsOutOfRangeSmoothingParameters) {
  EXPECT_THROW(BsSmcController(Config(-0.1, 0.0)), std::invalid_argument);
  EXPECT_THROW(BsSmcController(Config(1.5, 0.0)), std::invalid_argument);
  EXPECT_THROW(BsSmcController(Config(0.25, -1.0)), std::invalid_argument);
  EXPECT_THROW(BsSmcController(Config(0.25, std::nan(""))), std::invalid_argument);
}

}  // namespace
}  // namespace hexa
