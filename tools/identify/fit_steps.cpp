// hexa_identify's steps (fit_steps.hpp).
#include "fit_steps.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>

#include "hexa/core/free_fall.hpp"
#include "hexa/core/genetic_algorithm.hpp"
#include "hexa/core/platform_inverse_dynamics.hpp"
#include "lsq.hpp"

namespace hexa::identify {
namespace {

// The GA's fitness evaluations of one iteration spread over `threads` threads (each genome's
// cost is independent of the others, so the result does not depend on the thread count).
GaBatchCost ParallelCost(const StrokeDataset& data, const StrokeSearchSpace& space, int threads) {
  return [&data, &space, threads](const std::vector<Genome>& genomes, std::vector<double>& costs) {
    auto work = [&](int t) {
      for (std::size_t i = static_cast<std::size_t>(t); i < genomes.size(); i += static_cast<std::size_t>(threads))
        costs[i] = data.NrmseForSearch(space.Decode(genomes[i]));  // = FitObjective, tabulated
    };
    if (threads <= 1) return work(0);
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& th : pool) th.join();
  };
}

}  // namespace

LegArray<LoadSeries> ComputeLegLoads(const IdentificationRecording& rec, const ControllerModel& model,
                                     const config::SystemConfig& cfg, const IdentificationConfig& ic,
                                     const OfflineGaussianDifferentiator& diff,
                                     const LegArray<std::vector<double>>& accel) {
  // The force each leg must exert (platform inverse dynamics with the rig file's geometry
  // and masses): the terms that multiply the accelerations use D[D[l]] (= S[S[l'']]); the
  // rest (weights, velocity products) is evaluated tick by tick with the narrow derivative
  // and smoothed twice, as x'' is (docs/identification.md).
  const OfflineGaussianDifferentiator narrow(ic.regressor_differentiator, kTickS);
  LegArray<std::vector<double>> v_narrow;
  for (std::size_t i = 0; i < kNumLegs; ++i) narrow.Derivative(rec.legs[i].length_m, v_narrow[i]);
  LegArray<LoadSeries> load;
  LegArray<std::vector<double>> rest_fixed, rest_scaled;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LoadSeries& l = load[i];
    for (auto* v : {&l.force_fixed_n, &l.force_scaled_n, &l.mass_fixed_kg, &l.mass_scaled_kg}) v->assign(rec.ticks, nan);
    rest_fixed[i].assign(rec.ticks, nan);
    rest_scaled[i].assign(rec.ticks, nan);
  }
  {
    PlatformInverseDynamics dynamics(model.SupervisorRig(cfg.rig));
    std::size_t failed = 0;
    for (std::size_t k = 0; k < rec.ticks; ++k) {
      LegArray<double> l{}, v{};
      bool ok = true;
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        l[i] = rec.legs[i].length_m[k];
        v[i] = v_narrow[i][k];
        ok = ok && std::isfinite(l[i]) && std::isfinite(v[i]);
      }
      if (!ok) continue;
      PlatformDynamicsTerms t;
      if (dynamics.Decompose(l, v, t) != KinStatus::kOk) {
        ++failed;
        continue;
      }
      Vector6d ldd;
      for (std::size_t i = 0; i < kNumLegs; ++i) ldd[static_cast<int>(i)] = accel[i][k];
      const Vector6d inertial = t.inertia_scaled * ldd;  // NaN where D[D[l]] is
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        const int ii = static_cast<int>(i);
        rest_fixed[i][k] = t.fixed_rest[ii];
        rest_scaled[i][k] = t.scaled_rest[ii];
        load[i].force_fixed_n[k] = t.leg_mass_kg * accel[i][k];
        load[i].force_scaled_n[k] = inertial[ii];
        load[i].mass_fixed_kg[k] = t.leg_mass_kg;
        load[i].mass_scaled_kg[k] = t.inertia_scaled(ii, ii);
      }
    }
    if (failed > 0) std::printf("platform forward kinematics failed at %zu ticks (left out)\n", failed);
    std::vector<double> once, twice;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      diff.Smooth(rest_fixed[i], once);
      diff.Smooth(once, twice);
      for (std::size_t k = 0; k < rec.ticks; ++k) load[i].force_fixed_n[k] += twice[k];
      diff.Smooth(rest_scaled[i], once);
      diff.Smooth(once, twice);
      for (std::size_t k = 0; k < rec.ticks; ++k) load[i].force_scaled_n[k] += twice[k];
    }
  }
  return load;
}

StrokeReport FitStroke(StrokeDataset& d, int leg, int dir, const config::SystemConfig& cfg, const Report& report,
                       bool run_lsq, bool run_ga, double flat) {
  d.Bind(report.payload_scale);
  const Stroke stroke = static_cast<Stroke>(dir);
  const StrokeParams start = StrokeParams::From(
      dir == 0 ? cfg.rig.friction.extend : cfg.rig.friction.retract,
      dir == 0 ? cfg.rig.polytropic.extend : cfg.rig.polytropic.retract);
  StrokeReport sr;
  sr.leg = leg;
  sr.stroke = stroke;
  sr.samples = d.samples.size();
  sr.nominal = start;
  sr.nominal_objective = d.Nrmse(start);
  const StrokeSearchSpace space =
      report.ga_space == "around-nominal"    ? StrokeSearchSpace::AroundNominal(start, report.ga_range_factor)
      : report.ga_space == "force-at-speeds" ? StrokeSearchSpace::ForceAtSpeeds(start, report.ga_range_factor,
                                                                                 {0.1, 0.5, 1.2})
                                             : StrokeSearchSpace::Default();
  if (run_lsq) {
    const LsqResult lsq = FitStrokeLeastSquares(d, start);
    sr.lsq = lsq.params;
    sr.lsq_objective = lsq.objective;
    sr.lsq_fit_objective = d.FitObjective(lsq.params);
    sr.lsq_wall_s = lsq.wall_s;
    sr.lsq_iterations = lsq.iterations;
    sr.lsq_converged = lsq.converged;
    sr.lsq_curvature = AnalyseCurvature(d, lsq.params, flat);
    std::printf("leg %d %-7s LSQ: Z %.5f (nominal %.5f), %d iterations, %.3f s, %s\n", leg,
                ToString(stroke), lsq.objective, sr.nominal_objective, lsq.iterations, lsq.wall_s,
                lsq.converged ? "converged" : "NOT converged");
  }
  if (run_ga) {
    // The Stribeck term tabulated over the GA's v_s range (the exact Z is recomputed
    // at the GA's result below).
    d.PrepareSearch(space.lower[0], space.upper[0]);
    GaParams gp = report.ga_params;
    gp.seed = report.ga_params.seed + static_cast<std::uint64_t>(10 * leg + dir);
    const auto t0 = std::chrono::steady_clock::now();
    auto last_print = t0;
    const GaResult ga = RunGeneticAlgorithm(
        gp, ParallelCost(d, space, report.threads), [&](const GaProgress& p) {
          const auto now = std::chrono::steady_clock::now();
          if (p.iteration == gp.max_iterations || now - last_print > std::chrono::seconds(2)) {
            last_print = now;
            std::printf("\rleg %d %-7s GA: iteration %4d/%d, best Z %.5f, mean %.5f, gene spread %.1e, "
                        "selection ratio %.2f, %llu evaluations, %.1f s   ",
                        leg, ToString(stroke), p.iteration, gp.max_iterations, p.best_cost, p.mean_cost,
                        p.max_gene_spread, p.selection_ratio, static_cast<unsigned long long>(p.evaluations),
                        std::chrono::duration<double>(now - t0).count());
            std::fflush(stdout);
          }
          return true;
        });
    sr.ga = space.Decode(ga.best);
    sr.ga_objective = d.Nrmse(*sr.ga);
    sr.ga_fit_objective = d.FitObjective(*sr.ga);
    sr.ga_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sr.ga_evaluations = ga.evaluations;
    sr.ga_iterations = ga.iterations;
    sr.ga_history = ga.best_cost_history;
    sr.ga_curvature = AnalyseCurvature(d, *sr.ga, flat);
    std::printf("\nleg %d %-7s GA: Z %.5f after %d iterations, %llu evaluations, %.1f s on %d threads\n",
                leg, ToString(stroke), sr.ga_objective, ga.iterations,
                static_cast<unsigned long long>(ga.evaluations), sr.ga_wall_s, report.threads);
  }
  return sr;
}

void EvaluateFreeFall(const std::string& path, const config::SystemConfig& cfg, const std::vector<int>& legs,
                      Report& report) {
  const IdentificationRecording ff = ReadIdentificationRecording(path);
  if (!ff.session || ff.session->experiment() != "free-fall") {
    throw IdentificationInputError(path + ": not a free-fall recording (hexa_SessionInfo "
                                   "experiment 'free-fall' with the load and release time is missing)");
  }
  if (ff.session->rig_name() != cfg.rig_name) {
    throw IdentificationInputError(path + ": recorded on rig '" + ff.session->rig_name() +
                                   "', the rig file describes '" + cfg.rig_name + "'");
  }
  const double mass = ff.session->free_fall_load_kg() + cfg.rig.cylinder.moving_mass_kg;
  const auto release = static_cast<std::size_t>(std::llround(ff.session->free_fall_release_s() / kTickS));
  report.free_fall_recording = path;
  report.free_fall_mass_kg = mass;
  const double bottom = cfg.rig.cylinder.mid_stroke_length_m + 0.5 * cfg.rig.cylinder.stroke_m - 0.005;
  for (int leg : legs) {
    const LegSeries& s = ff.legs[static_cast<std::size_t>(leg - 1)];
    if (release >= s.size() || !std::isfinite(s.length_m[release])) {
      throw IdentificationInputError(path + ": leg " + std::to_string(leg) +
                                     " has no sample at the release tick");
    }
    std::vector<double> t, x;
    for (std::size_t k = release; k < s.size() && std::isfinite(s.length_m[k]) && s.length_m[k] < bottom; ++k) {
      t.push_back(static_cast<double>(k - release) * kTickS);
      x.push_back(s.length_m[k] - s.length_m[release]);
    }
    FreeFallLeg f;
    f.leg = leg;
    f.samples = t.size();
    f.fall_m = x.empty() ? 0.0 : x.back();
    f.duration_s = t.empty() ? 0.0 : t.back();
    f.fit = FitFreeFall(t.data(), x.data(), t.size(), mass, cfg.rig.platform.gravity_m_s2);
    std::printf("leg %d free fall: %zu samples, %.3f m in %.3f s: F_c %.2f N, B %.2f N s/m (rms residual %.3f mm)\n",
                leg, f.samples, f.fall_m, f.duration_s, f.fit.coulomb_n, f.fit.viscous_n_s_m,
                1e3 * f.fit.rms_residual_m);
    report.free_fall.push_back(f);
  }
}

}  // namespace hexa::identify
