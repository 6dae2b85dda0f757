// platform_study legs and reversals (main.cpp's header says what they print).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "hexa/core/bssmc_controller.hpp"

#include "platform_study.hpp"

namespace platform_study {

// Per-leg analysis of the tracking window, every 1 ms tick. The desired leg
// motion is the trajectory's at the CURRENT time (no setpoint lead), from the desired pose
// through eq 46. Per leg: first-harmonic gain / lag of the true length against it, RMSE;
// the force budget along the leg (N RMS and 1st-harmonic amplitude / phase against the
// desired leg velocity, + = leads): F_ff the feed-forward used, z = P1 A1 - P2 A2 - phi
// (eq 35, the pressure loop's tracking error), the friction mismatch (plant friction on
// the rod + the controller's estimate F_f(v_d) + B v_d), the feedback part of phi
// (phi - phi_model); valve saturation and the share of ticks inside the null band.
void Legs(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  const double w = MotionOmega(motion);
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  hexa::BsSmcConfig bc;
  bc.params = config.leg_controller.bssmc;
  bc.differentiator = config.leg_controller.differentiator;
  bc.model = hexa::NominalLegModel::FromRig(config.rig);
  const hexa::BsSmcController estimate(bc);
  const double pa_ar = config.rig.air.atmosphere_pressure_pa * config.rig.cylinder.rod_area_m2;
  // HEXA_LEGS_TRACE=<leg 1-6>: per-tick CSV of that leg on stderr.
  const char* trace_env = std::getenv("HEXA_LEGS_TRACE");
  const int trace_leg = trace_env ? std::atoi(trace_env) - 1 : -1;
  if (trace_leg >= 0)
    std::fprintf(stderr, "t,ld_now,l_true,vd_now,v_true,vd_cmd,v_hat,fric_est,fric_plant,z,fb,ff,u,p1,p2\n");
  std::vector<double> t;
  enum { kLd, kL, kVd, kFf, kZ, kFric, kFb, kVhat, kVtrue, kN };
  std::vector<double> s[6][kN];
  long sat[6] = {}, band[6] = {}, n_ticks = 0;
  ForEachTrackingTick(sim, start, config.rig.geometry, [&](const hexa::PlatformPlantOutput& p, double tt,
                                                          const hexa::TrajectorySample&,
                                                          const hexa::LegArray<double>& ld,
                                                          const hexa::LegArray<double>& vd) {
    t.push_back(tt);
    ++n_ticks;
    for (std::size_t i = 0; i < 6; ++i) {
      const auto& o = sim.leg_outputs()[i];
      const auto& f = p.leg_forces[i];
      const double vdi = o.desired_velocity_m_s;
      const auto& fd = vdi >= 0.0 ? bc.model.friction.extend : bc.model.friction.retract;
      const double fric_est = estimate.FrictionEstimateN(vdi) + bc.params.viscous_estimate_scale * fd.viscous_n_s_m * vdi;
      // phi_model = F_ff + B v_d + Pa Ar + F_f(v_d) (bssmc_controller.cpp)
      const double phi_model = o.feedforward_force_n + fric_est + pa_ar;
      s[i][kLd].push_back(ld[i]);
      s[i][kL].push_back(p.truth.length_m[i]);
      s[i][kVd].push_back(vd[i]);
      s[i][kFf].push_back(o.feedforward_force_n);
      s[i][kZ].push_back(o.force_error_n);
      s[i][kFric].push_back(f.friction_n + fric_est);
      s[i][kFb].push_back(o.desired_force_n - phi_model);
      s[i][kVhat].push_back(o.velocity_m_s);
      s[i][kVtrue].push_back(p.truth.piston_velocity_m_s[i]);
      const double u = sim.applied_valve_v()[i];
      if (static_cast<int>(i) == trace_leg) {
        std::fprintf(stderr, "%.3f,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f,%.2f,%.2f,%.2f,%.2f,%.2f,%.3f,%.0f,%.0f\n", tt,
                     ld[i], p.truth.length_m[i], vd[i], p.truth.piston_velocity_m_s[i], vdi,
                     o.velocity_m_s, fric_est, f.friction_n, o.force_error_n,
                     o.desired_force_n - phi_model, o.feedforward_force_n, u,
                     p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa);
      }
      sat[i] += (u < 0.05 || u > 9.95) ? 1 : 0;
      band[i] += std::abs(u - 5.0) < 2.5 ? 1 : 0;
    }
  });
  const auto wrap = WrapPi;
  auto rms = [](const std::vector<double>& v) {
    double q = 0.0;
    for (double x : v) q += x * x;
    return v.empty() ? 0.0 : std::sqrt(q / static_cast<double>(v.size()));
  };
  std::printf("leg | amp mm | gain | lag ms | rmse mm | vhat lag ms | F_ff amp N (ph deg) | z rms N, amp (ph) | "
              "fric mismatch rms N, amp (ph) | feedback rms N, amp (ph) | sat %% | band %%\n");
  for (int i = 0; i < 6; ++i) {
    const Harmonic hd = FitHarmonic(t, s[i][kLd], w), ht = FitHarmonic(t, s[i][kL], w);
    const Harmonic hv = FitHarmonic(t, s[i][kVd], w);
    const Harmonic hvh = FitHarmonic(t, s[i][kVhat], w), hvt = FitHarmonic(t, s[i][kVtrue], w);
    std::vector<double> e(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) e[k] = s[i][kL][k] - s[i][kLd][k];
    auto force = [&](int q) {
      const Harmonic h = FitHarmonic(t, s[i][q], w);
      std::vector<double> c = s[i][q];
      for (double& x : c) x -= h.c;
      std::printf(" | %6.1f %6.1f (%5.0f)", rms(c), h.amplitude(),
                  wrap(h.phase_rad() - hv.phase_rad()) * 57.29577951308232);
    };
    std::printf("%d | %6.2f | %6.4f | %6.2f | %6.3f | %6.2f", i + 1, 1000 * hd.amplitude(),
                ht.amplitude() / hd.amplitude(), 1000 * wrap(hd.phase_rad() - ht.phase_rad()) / w,
                1000 * rms(e), 1000 * wrap(hvt.phase_rad() - hvh.phase_rad()) / w);
    const Harmonic hf = FitHarmonic(t, s[i][kFf], w);
    std::printf(" | %6.1f (%5.0f)", hf.amplitude(), wrap(hf.phase_rad() - hv.phase_rad()) * 57.29577951308232);
    force(kZ);
    force(kFric);
    force(kFb);
    std::printf(" | %5.2f | %5.1f\n", 100.0 * sat[i] / std::max(1L, n_ticks), 100.0 * band[i] / std::max(1L, n_ticks));
  }
}

// Where the moving axis' error is made (pure z). Every 1 ms tick of the tracking
// window: e = true pose - desired pose of NOW (the trajectory at the current time, no setpoint
// lead) on the moving axis of a pure motion. Printed: RMSE; bias (mean), the first harmonic
// at the motion's frequency and the rest, and the rest's share above 1 Hz (a centred 1 s
// moving average is the part below); the share of the squared error and the RMS within
// +-N ms of the reversals of the desired motion (zero crossings of its rate). Per leg: the
// share of ticks the piston is stuck (|true piston speed| < 2 mm/s while the desired leg speed
// is above 5 mm/s), the number of stick events per second (a stuck run of >= 10 ms), and the
// RMS of the piston speed error v_true - v_d. HEXA_REVERSALS_TRACE=<file> writes the per-tick
// CSV (t, desired and true moving axis, each leg's desired and true speed) to that file.
void Reversals(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  const auto axes = MovingAxes(motion);
  if (axes.size() != 1) {
    std::fprintf(stderr, "reversals: a pure motion (x y z roll pitch yaw)\n");
    return;
  }
  const int ax = axes.front();
  const double unit = ax < 3 ? 100.0 : 57.29577951308232;  // cm, deg
  const double w = MotionOmega(motion);
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const char* trace_path = std::getenv("HEXA_REVERSALS_TRACE");
  std::FILE* trace = trace_path ? std::fopen(trace_path, "w") : nullptr;
  if (trace) {
    std::fprintf(trace, "t,desired,true");
    for (int i = 1; i <= 6; ++i) std::fprintf(trace, ",vd%d,v%d", i, i);
    std::fprintf(trace, "\n");
  }
  std::vector<double> t, e, rate;
  std::vector<double> vd[6], vt[6];
  ForEachTrackingTick(sim, start, config.rig.geometry, [&](const hexa::PlatformPlantOutput& p, double tt,
                                                          const hexa::TrajectorySample& d,
                                                          const hexa::LegArray<double>&,
                                                          const hexa::LegArray<double>& vdl) {
    const double truth = hexa::VectorFromPose(p.truth.pose)[ax];
    t.push_back(tt);
    e.push_back(unit * (truth - d.vector.q[ax]));
    rate.push_back(d.vector.q_dot[ax]);
    if (trace) std::fprintf(trace, "%.3f,%.7f,%.7f", tt, d.vector.q[ax], truth);
    for (std::size_t i = 0; i < 6; ++i) {
      vd[i].push_back(vdl[i]);
      vt[i].push_back(p.truth.piston_velocity_m_s[i]);
      if (trace) std::fprintf(trace, ",%.5f,%.5f", vdl[i], p.truth.piston_velocity_m_s[i]);
    }
    if (trace) std::fprintf(trace, "\n");
  });
  if (trace) std::fclose(trace);
  const std::size_t n = t.size();
  if (n < 2000) {
    std::fprintf(stderr, "reversals: tracking window too short (%zu ticks)\n", n);
    return;
  }
  auto rms = [](const std::vector<double>& v) {
    double q = 0.0;
    for (double x : v) q += x * x;
    return std::sqrt(q / static_cast<double>(v.size()));
  };
  double mean = 0.0;
  for (double x : e) mean += x / static_cast<double>(n);
  const Harmonic h = FitHarmonic(t, e, w);
  std::vector<double> rest(n), slow(n), fast(n);
  for (std::size_t k = 0; k < n; ++k) rest[k] = e[k] - (h.c + h.a * std::sin(w * t[k]) + h.b * std::cos(w * t[k]));
  const std::size_t half = 500;  // 1 s centred moving average at 1 ms
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t a = k > half ? k - half : 0, b = std::min(n - 1, k + half);
    double sum = 0.0;
    for (std::size_t j = a; j <= b; ++j) sum += rest[j];
    slow[k] = sum / static_cast<double>(b - a + 1);
    fast[k] = rest[k] - slow[k];
  }
  std::printf("moving axis RMSE %.4f %s: bias %+.4f, 1st harmonic %.4f (lag %.1f ms), rest %.4f of which "
              "above 1 Hz %.4f\n",
              rms(e), ax < 3 ? "cm" : "deg", mean, h.amplitude() / std::sqrt(2.0),
              1000.0 * WrapPi(-h.phase_rad()) / w, rms(rest), rms(fast));
  std::vector<double> rev;
  for (std::size_t k = 1; k < n; ++k)
    if ((rate[k] > 0.0) != (rate[k - 1] > 0.0)) rev.push_back(t[k]);
  double sq_all = 0.0;
  for (double x : e) sq_all += x * x;
  std::printf("reversals at");
  for (double r : rev) std::printf(" %.3f", r);
  std::printf(" s\n+-N ms | time share | squared-error share | RMS inside | RMS outside\n");
  for (double win_ms : {100.0, 250.0, 500.0, 1000.0}) {
    double sq_in = 0.0;
    long in = 0;
    for (std::size_t k = 0; k < n; ++k) {
      bool near = false;
      for (double r : rev) near = near || std::abs(t[k] - r) <= win_ms / 1000.0;
      if (near) {
        sq_in += e[k] * e[k];
        ++in;
      }
    }
    const long out = static_cast<long>(n) - in;
    std::printf("%6.0f | %.3f | %.3f | %.4f | %.4f\n", win_ms, static_cast<double>(in) / static_cast<double>(n),
                sq_all > 0.0 ? sq_in / sq_all : 0.0, in ? std::sqrt(sq_in / static_cast<double>(in)) : 0.0,
                out ? std::sqrt((sq_all - sq_in) / static_cast<double>(out)) : 0.0);
  }
  std::printf("leg | stuck share (|v| < 2 mm/s, |v_d| > 5 mm/s) | stick events /s | v error RMS m/s\n");
  for (int i = 0; i < 6; ++i) {
    long moving = 0, stuck = 0, events = 0, run = 0;
    std::vector<double> ve(n);
    for (std::size_t k = 0; k < n; ++k) {
      ve[k] = vt[i][k] - vd[i][k];
      const bool mv = std::abs(vd[i][k]) > 0.005;
      const bool st = mv && std::abs(vt[i][k]) < 0.002;
      moving += mv ? 1 : 0;
      stuck += st ? 1 : 0;
      run = st ? run + 1 : 0;
      events += run == 10 ? 1 : 0;
    }
    std::printf("%d | %.3f | %.2f | %.4f\n", i + 1, moving ? static_cast<double>(stuck) / static_cast<double>(moving) : 0.0,
                static_cast<double>(events) / (t.back() - t.front()), rms(ve));
  }
}

}  // namespace platform_study
