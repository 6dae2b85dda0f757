// Prints the single-leg closed-loop figures of docs/controller.md:
//   leg_tracking_report            BS-SMC and PI (defaults) on the realistic 0.1 Hz +-50 mm sine
//   leg_tracking_report pi-grid    the PI tuning grid (same run, same seed)
//   leg_tracking_report bssmc-grid a BS-SMC sensitivity grid
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <vector>

#include "leg_tracking_harness.hpp"

using namespace hexa;
using namespace hexa::test;

namespace {

TrackingResult Run(LegControllerKind kind, const LegControllerParams& p, const TrackingScenario& sc) {
  const RigParams rig = MakeReferenceRig();
  return RunTracking(sc, SingleLegControllerConfig(rig, kind, p, sc), rig);
}

void Print(const char* name, const TrackingResult& r) {
  std::printf("%-28s rmse %.4f mm  (measured %.4f mm)  max %.3f mm  valve [%.2f, %.2f] V  non-ok %d  finite %d\n",
              name, r.rmse_m * 1e3, r.rmse_measured_m * 1e3, r.max_abs_error_m * 1e3, r.valve_min_v,
              r.valve_max_v, r.non_ok_ticks, r.finite ? 1 : 0);
}

}  // namespace

int main(int argc, char** argv) {
  TrackingScenario sc;
  const LegControllerParams defaults;
  const char* mode = argc > 1 ? argv[1] : "";
  if (std::strcmp(mode, "pi-grid") == 0) {
    sc.seed = 7;  // tune on another seed than the test's (seed 1)
    for (double kp : {50.0, 100.0, 200.0, 400.0, 600.0, 800.0, 1200.0, 1600.0, 2400.0}) {
      for (double ki : {0.0, 250.0, 1000.0, 2000.0, 4000.0, 8000.0, 16000.0}) {
        LegControllerParams p = defaults;
        p.pi.proportional_v_m = kp;
        p.pi.integral_v_m_s = ki;
        const TrackingResult r = Run(LegControllerKind::kPi, p, sc);
        std::printf("pi kp %6.1f ki %7.1f rmse %.4f mm max %.3f mm\n", kp, ki, r.rmse_m * 1e3,
                    r.max_abs_error_m * 1e3);
      }
    }
    return 0;
  }
  if (std::strcmp(mode, "bssmc-grid") == 0) {
    sc.seed = 7;  // tune on another seed than the test's (seed 1)
    for (double lambda : {40.0, 80.0, 120.0, 160.0}) {
      for (double k : {20.0, 30.0, 60.0, 120.0}) {
        for (double xi : {10.0, 30.0, 100.0}) {
          for (double beta : {10.0, 20.0, 30.0, 60.0, 100.0}) {
            LegControllerParams p = defaults;
            p.bssmc.lambda_1_s = lambda;
            p.bssmc.switching_gain_n = k;
            p.bssmc.boundary_layer_xi_s_m = xi;
            p.bssmc.backstepping_beta_1_s = beta;
            const TrackingResult r = Run(LegControllerKind::kBsSmc, p, sc);
            std::printf("bssmc lambda %5.1f K %6.1f xi %6.1f beta %6.1f rmse %.4f mm max %.3f mm\n", lambda,
                        k, xi, beta, r.rmse_m * 1e3, r.max_abs_error_m * 1e3);
          }
        }
      }
    }
    return 0;
  }
  if (std::strcmp(mode, "fast") == 0) {
    // Robustness check at the combined trajectory's leg motion (docs/design.md: +-107 mm, 1 Hz).
    sc.seed = 7;
    TrackingScenario fast = sc;
    fast.frequency_hz = 1.0;
    fast.amplitude_m = 0.1;
    fast.duration_s = 13.0;
    struct Candidate { double lambda, k, xi, beta; };
    std::vector<Candidate> candidates;
    for (double lambda : {40.0, 80.0, 120.0, 160.0})
      for (double k : {15.0, 30.0, 60.0, 120.0})
        for (double xi : {10.0, 30.0})
          for (double beta : {50.0, 100.0, 150.0, 200.0}) candidates.push_back({lambda, k, xi, beta});
    for (const Candidate& c : candidates) {
      LegControllerParams p = defaults;
      p.bssmc.lambda_1_s = c.lambda;
      p.bssmc.switching_gain_n = c.k;
      p.bssmc.boundary_layer_xi_s_m = c.xi;
      p.bssmc.backstepping_beta_1_s = c.beta;
      const TrackingResult slow_r = Run(LegControllerKind::kBsSmc, p, sc);
      const TrackingResult fast_r = Run(LegControllerKind::kBsSmc, p, fast);
      std::printf("bssmc lambda %5.1f K %6.1f xi %6.1f beta %6.1f  0.1Hz rmse %.4f mm  1Hz rmse %.4f mm max %.3f mm\n",
                  c.lambda, c.k, c.xi, c.beta, slow_r.rmse_m * 1e3, fast_r.rmse_m * 1e3, fast_r.max_abs_error_m * 1e3);
    }
    for (double kp : {400.0, 800.0, 1200.0, 1600.0}) {
      LegControllerParams p = defaults;
      p.pi.proportional_v_m = kp;
      p.pi.integral_v_m_s = 250.0;
      const TrackingResult slow_r = Run(LegControllerKind::kPi, p, sc);
      const TrackingResult fast_r = Run(LegControllerKind::kPi, p, fast);
      std::printf("pi kp %6.1f ki 250  0.1Hz rmse %.4f mm  1Hz rmse %.4f mm max %.3f mm\n", kp, slow_r.rmse_m * 1e3,
                  fast_r.rmse_m * 1e3, fast_r.max_abs_error_m * 1e3);
    }
    return 0;
  }
  if (std::strcmp(mode, "trace") == 0) {
    const RigParams rig = MakeReferenceRig();
    const LegControllerKind kind =
        argc > 2 && std::strcmp(argv[2], "pi") == 0 ? LegControllerKind::kPi : LegControllerKind::kBsSmc;
    if (argc > 3 && std::strcmp(argv[3], "ideal") == 0) {
      sc.sensor_noise = false;
      sc.friction_scale = sc.polytropic_scale = sc.load_scale = 1.0;
    }
    std::printf("t,l,ld,valve,s,phi,v,p1,p2,vtrue,friction\n");
    RunTracking(sc, SingleLegControllerConfig(rig, kind, defaults, sc), rig,
                [](double t, double l, double ld, const LegControllerOutput& o, const SingleLegPlant& p) {
                  std::printf("%.3f,%.6f,%.6f,%.4f,%.5f,%.3f,%.5f,%.0f,%.0f,%.5f,%.3f\n", t, l, ld, o.valve_v,
                              o.sliding_surface_m_s, o.desired_force_n, o.velocity_m_s,
                              p.chamber1_pressure_pa(), p.chamber2_pressure_pa(), p.velocity_m_s(),
                              p.last_forces().friction_n);
                });
    return 0;
  }
  Print("BS-SMC realistic", Run(LegControllerKind::kBsSmc, defaults, sc));
  Print("PI realistic", Run(LegControllerKind::kPi, defaults, sc));
  TrackingScenario ideal = sc;
  ideal.sensor_noise = false;
  ideal.friction_scale = ideal.polytropic_scale = ideal.load_scale = 1.0;
  Print("BS-SMC ideal", Run(LegControllerKind::kBsSmc, defaults, ideal));
  Print("PI ideal", Run(LegControllerKind::kPi, defaults, ideal));
  return 0;
}
