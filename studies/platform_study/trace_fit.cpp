// platform_study trace and fit (main.cpp's header says what they print).
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "platform_study.hpp"

namespace platform_study {

void Trace(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  std::printf("t,state");
  for (int i = 1; i <= 6; ++i)
    std::printf(",ld%d,l%d,ltrue%d,vd%d,ad%d,u%d,phi%d,S%d,P1_%d,P2_%d,corr%d,v%d,z%d,phidot%d", i, i, i,
                i, i, i, i, i, i, i, i, i, i, i);
  std::printf("\n");
  bool started = false, left_idle = false;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  hexa::LegArray<double> corr{};
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    if (!TickSession(sim, start, due, started)) break;
    if (due) {
      started = true;
      state = sim.supervisor_output().state;
      for (std::size_t i = 0; i < 6; ++i) corr[i] = sim.supervisor_output().setpoint[i].correction_m;
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold) {
        std::fprintf(stderr, "HOLD at t=%.3f s: %s\n", sim.time_s(),
                     sim.supervisor_output().fault_detail.data());
        break;
      }
      if (left_idle && state == hexa::SupervisorState::kIdle) break;
    }
    const auto& p = sim.plant_before_step();
    std::printf("%.3f,%d", p.truth.time_s, static_cast<int>(state));
    for (std::size_t i = 0; i < 6; ++i) {
      const auto& o = sim.leg_outputs()[i];
      std::printf(",%.6f,%.6f,%.6f,%.4f,%.3f,%.3f,%.2f,%.4f,%.0f,%.0f,%.6f,%.4f,%.2f,%.1f", o.desired_length_m,
                  p.legs[i].length_m, p.truth.length_m[i], o.desired_velocity_m_s, 0.0,
                  sim.applied_valve_v()[i], o.desired_force_n, o.sliding_surface_m_s,
                  p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa, corr[i],
                  o.velocity_m_s, o.force_error_n, o.desired_force_rate_n_s);
    }
    std::printf("\n");
  }
}

void Fit(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const double f_hz = motion == PaperMotion::kCombined ? 1.0 : 0.1;
  const double w = MotionOmega(motion);
  std::vector<double> t;
  std::vector<double> des[6], tru[6], leg_des[6], leg_true[6], leg_corr[6];
  bool started = false, left_idle = false;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    auto cmd = (due && !started) ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr) !=
        hexa::PlantStatus::kOk)
      break;
    if (!due) continue;
    started = true;
    const auto& out = sim.supervisor_output();
    if (out.state != hexa::SupervisorState::kIdle) left_idle = true;
    if (out.state == hexa::SupervisorState::kHold || (left_idle && out.state == hexa::SupervisorState::kIdle)) break;
    if (out.state != hexa::SupervisorState::kTracking) continue;
    t.push_back(out.trajectory_time_s);
    // HEXA_FIT_THETA=1: the six legs' adapted friction scales every 0.2 s on stderr.
    if (std::getenv("HEXA_FIT_THETA") && t.size() % 40 == 1) {
      std::fprintf(stderr, "t %.2f theta", out.trajectory_time_s);
      for (int i = 0; i < 6; ++i) std::fprintf(stderr, " %.3f", sim.leg_outputs()[i].friction_scale);
      std::fprintf(stderr, "\n");
    }
    const hexa::Vector6d truth = hexa::VectorFromPose(sim.plant_before_step().truth.pose);
    for (int k = 0; k < 6; ++k) {
      des[k].push_back(out.desired_xyz_rpy[k]);
      tru[k].push_back(truth[k]);
      leg_des[k].push_back(out.setpoint[k].length_m);
      leg_true[k].push_back(sim.plant_before_step().truth.length_m[k]);
      leg_corr[k].push_back(out.setpoint[k].correction_m);
    }
  }
  const char* names[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
  // Per axis: the first harmonics of desired and true motion, and the residual (the error
  // minus its fitted first harmonic), used by both tables below.
  std::array<Harmonic, 6> fit_des, fit_true;
  std::array<std::vector<double>, 6> residual;
  for (int k = 0; k < 6; ++k) {
    const Harmonic hd = FitHarmonic(t, des[k], w), ht = FitHarmonic(t, tru[k], w);
    fit_des[k] = hd;
    fit_true[k] = ht;
    residual[k].resize(t.size());
    for (std::size_t s = 0; s < t.size(); ++s) {
      const double e = tru[k][s] - des[k][s];
      const double fit_e = (ht.c + ht.a * std::sin(w * t[s]) + ht.b * std::cos(w * t[s])) -
                           (hd.c + hd.a * std::sin(w * t[s]) + hd.b * std::cos(w * t[s]));
      residual[k][s] = e - fit_e;
    }
  }
  std::printf("axis   | desired amp | gain true/des | lag deg  lag ms | peak over | rmse | rmse w/o 1st harmonic\n");
  for (int k = 0; k < 6; ++k) {
    const double unit = k < 3 ? 100.0 : 57.29577951308232;
    const Harmonic& hd = fit_des[k];
    const Harmonic& ht = fit_true[k];
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    // Mean over periods of (max true - max desired) in each period window.
    const double period = 1.0 / f_hz;
    double over = 0.0;
    int n_periods = 0;
    for (double t0 = t.front(); t0 + period <= t.back() + 1e-9; t0 += period) {
      double md = -1e9, mt = -1e9;
      for (std::size_t s = 0; s < t.size(); ++s) {
        if (t[s] < t0 || t[s] >= t0 + period) continue;
        md = std::max(md, des[k][s] - hd.c);
        mt = std::max(mt, tru[k][s] - hd.c);
      }
      over += mt - md;
      ++n_periods;
    }
    over /= std::max(1, n_periods);
    double se = 0.0, sr = 0.0;
    for (std::size_t s = 0; s < t.size(); ++s) {
      const double e = tru[k][s] - des[k][s];
      se += e * e;
      sr += residual[k][s] * residual[k][s];
    }
    const double n = static_cast<double>(t.size());
    std::printf("%-6s | %10.4f | %12.4f | %7.2f %7.2f | %9.4f | %.4f | %.4f\n", names[k],
                unit * hd.amplitude(), hd.amplitude() > 1e-9 ? ht.amplitude() / hd.amplitude() : 0.0,
                lag * 57.29577951308232, 1000.0 * lag / w, unit * over, unit * std::sqrt(se / n),
                unit * std::sqrt(sr / n));
  }
  // Where the residual (error minus its fitted first harmonic) sits in frequency: RMS per band
  // of its DFT over the window (Parseval; 5 ms samples, so up to 100 Hz). "harmonics" = the
  // bins within 0.15 Hz of 2, 3, ... 10 x the motion's frequency, "other" the rest of the band.
  // The first harmonic's own share is split into amplitude (gain - 1) and timing (lag).
  std::printf("axis   | 1st harmonic: amplitude part, timing part | residual by band: < f | "
              "harmonics 2f-10f | other f-10 Hz | 10-30 Hz | > 30 Hz\n");
  for (int k = 0; k < 6; ++k) {
    const double unit = k < 3 ? 100.0 : 57.29577951308232;
    const Harmonic& hd = fit_des[k];
    const Harmonic& ht = fit_true[k];
    const std::size_t n = t.size();
    const std::vector<double>& r = residual[k];
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    const double span = dt * static_cast<double>(n);
    double band[5] = {};  // mean square per band
    for (std::size_t b = 0; b <= n / 2; ++b) {
      std::complex<double> x = 0.0;
      const double wb = 2.0 * 3.14159265358979323846 * static_cast<double>(b) / span;
      for (std::size_t s = 0; s < n; ++s) x += r[s] * std::polar(1.0, -wb * dt * static_cast<double>(s));
      // One-sided power, so the bins sum to the mean square (Parseval).
      const double edge = (b == 0 || 2 * b == n) ? 1.0 : 2.0;
      const double ms = edge * std::norm(x) / static_cast<double>(n * n);
      const double f = static_cast<double>(b) / span;
      const double h = f / f_hz;
      const bool harmonic = h > 1.5 && h < 10.5 && std::abs(h - std::round(h)) * f_hz < 0.15;
      const int i = f < 0.95 * f_hz ? 0 : harmonic ? 1 : f < 10.0 ? 2 : f < 30.0 ? 3 : 4;
      band[i] += ms;
      // HEXA_FIT_BINS=<axis 0-5>: every bin of that axis' residual on stderr (Hz, RMS).
      if (const char* bins = std::getenv("HEXA_FIT_BINS"); bins && ms > 1e-10 && k == std::atoi(bins)) {
        std::fprintf(stderr, "bin %.2f Hz rms %.4f\n", f, unit * std::sqrt(ms));
      }
    }
    // First harmonic of the error, split: amplitude error (|true| - |desired|, in phase) and
    // timing error (the perpendicular part). RMS of a sinusoid = amplitude / sqrt 2.
    const double amp_part = std::abs(ht.amplitude() - hd.amplitude()) / std::sqrt(2.0);
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    const double time_part = ht.amplitude() * std::abs(std::sin(lag)) / std::sqrt(2.0);
    std::printf("%-6s | %.4f %.4f | %.4f | %.4f | %.4f | %.4f | %.4f\n", names[k], unit * amp_part,
                unit * time_part, unit * std::sqrt(band[0]), unit * std::sqrt(band[1]),
                unit * std::sqrt(band[2]), unit * std::sqrt(band[3]), unit * std::sqrt(band[4]));
  }
  std::printf("leg | desired amp mm | gain true/des | lag ms | correction amp mm (lag ms vs desired)\n");
  for (int i = 0; i < 6; ++i) {
    const Harmonic hd = FitHarmonic(t, leg_des[i], w), ht = FitHarmonic(t, leg_true[i], w),
                   hc = FitHarmonic(t, leg_corr[i], w);
    const double lag = WrapPi(hd.phase_rad() - ht.phase_rad());
    const double lag_c = WrapPi(hd.phase_rad() - hc.phase_rad());
    std::printf("%d   | %8.3f | %8.4f | %7.2f | %7.3f (%7.2f)\n", i + 1, 1000 * hd.amplitude(),
                ht.amplitude() / hd.amplitude(), 1000.0 * lag / w, 1000 * hc.amplitude(),
                1000.0 * lag_c / w);
  }
}

}  // namespace platform_study
