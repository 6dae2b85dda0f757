#include "report.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/platform_inverse_dynamics.hpp"
#include "hexa/services/json.hpp"

namespace hexa::identify {
namespace {

const char* MutationStepName(GaParams::MutationStep m) {
  return m == GaParams::MutationStep::kPopulationSpread ? "population"
         : m == GaParams::MutationStep::kSuccessRule    ? "success-rule"
                                                        : "range";
}

std::string Fmt(double v, int precision = 4) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", precision, v);
  return b;
}

std::string Pct(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%+.2f", v);
  return b;
}

double ErrorPct(double identified, double truth) {
  return truth != 0.0 ? 100.0 * (identified - truth) / std::abs(truth) : NAN;
}

// Targets: F_c, F_s, gamma_o, gamma_i, gamma_k within 5 %, v_s and B within 10 %.
double TargetPct(int i) { return i <= 1 ? 10.0 : 5.0; }

json::Value ParamsJson(const StrokeParams& p) {
  json::Value o = json::Value::object();
  const auto v = p.ToVector();
  for (int i = 0; i < StrokeParams::kCount; ++i) o[StrokeParams::Name(i)] = v[i];
  return o;
}

json::Value CurvatureJson(const CurvatureReport& c) {
  json::Value o = {{"objective", c.objective}};
  const auto list = [](const auto& a) {
    json::Value l = json::Value::array();
    for (int i = 0; i < StrokeParams::kCount; ++i) l.push_back(a[static_cast<std::size_t>(i)]);
    return l;
  };
  o["increase_alone_10pct"] = list(c.increase_alone_10pct);
  o["increase_profile_10pct"] = list(c.increase_profile_10pct);
  o["standard_error_pct"] = list(c.standard_error_pct);
  o["flat_threshold"] = c.flat_threshold;
  o["effective_samples"] = c.effective_samples;
  json::Value ident = json::Value::array();
  for (int i = 0; i < StrokeParams::kCount; ++i) ident.push_back(static_cast<bool>(c.identifiable[static_cast<std::size_t>(i)]));
  o["identifiable"] = ident;
  return o;
}

json::Value IdentificationJson(const Report& r) {
  json::Value js;
  js["recording"] = r.recording;
  js["payload_scale"] = r.payload_scale;
  js["payload_estimated"] = r.payload_estimated;
  js["true_payload_scale"] = r.truth ? json::Value(r.truth->payload_scale()) : json::Value(nullptr);
  js["payload_per_leg"] = json::Value::object();
  for (const auto& [leg, scale] : r.payload_per_leg) js["payload_per_leg"][std::to_string(leg)] = scale;
  js["threads"] = r.threads;
  js["ga_max_iterations"] = r.ga_params.max_iterations;
  js["ga_population"] = r.ga_params.population;
  js["ga_crossover"] = r.ga_params.crossover_per_pair ? "per-pair" : "per-gene";
  js["ga_mutation_step"] = MutationStepName(r.ga_params.mutation_step);
  js["flat_threshold"] = r.flat_threshold;
  js["pressure_noise_pa"] = r.pressure_noise_pa;
  js["overlay"] = r.overlay_refused ? json::Value(nullptr) : json::Value(r.overlay_path);
  js["strokes"] = json::Value::array();
  for (const StrokeReport& s : r.strokes) {
    json::Value o = {{"leg", s.leg}, {"stroke", ToString(s.stroke)}, {"samples", s.samples}};
    o["nominal"] = ParamsJson(s.nominal);
    o["nominal_objective"] = s.nominal_objective;
    if (r.truth) {
      if (const auto t = TrueStroke(*r.truth, s.leg, s.stroke)) o["truth"] = ParamsJson(*t);
    }
    if (s.lsq) {
      o["lsq"] = ParamsJson(*s.lsq);
      o["lsq_objective"] = s.lsq_objective;
      o["lsq_wall_s"] = s.lsq_wall_s;
      o["lsq_iterations"] = s.lsq_iterations;
      o["lsq_converged"] = s.lsq_converged;
      o["lsq_curvature"] = CurvatureJson(s.lsq_curvature);
    }
    if (s.ga) {
      o["ga"] = ParamsJson(*s.ga);
      o["ga_objective"] = s.ga_objective;
      o["ga_wall_s"] = s.ga_wall_s;
      o["ga_evaluations"] = s.ga_evaluations;
      o["ga_iterations"] = s.ga_iterations;
      o["ga_curvature"] = CurvatureJson(s.ga_curvature);
    }
    js["strokes"].push_back(o);
  }
  js["free_fall"] = json::Value::array();
  for (const FreeFallLeg& f : r.free_fall) {
    js["free_fall"].push_back({{"leg", f.leg},
                               {"ok", f.fit.ok},
                               {"coulomb_n", f.fit.coulomb_n},
                               {"viscous_n_s_m", f.fit.viscous_n_s_m},
                               {"rms_residual_m", f.fit.rms_residual_m},
                               {"samples", f.samples}});
  }
  return js;
}

}  // namespace

std::optional<StrokeParams> TrueStroke(const rec::PlantTruth& truth, int leg, Stroke stroke) {
  for (const rec::LegTruth& l : truth.leg()) {
    if (static_cast<int>(l.leg_id()) != leg) continue;
    const auto& f = stroke == Stroke::kExtend ? l.friction_extend() : l.friction_retract();
    const auto& g = stroke == Stroke::kExtend ? l.polytropic_extend() : l.polytropic_retract();
    StrokeParams p;
    p.stribeck_velocity_m_s = f.stribeck_velocity_m_s();
    p.viscous_n_s_m = f.viscous_n_s_m();
    p.static_n = f.static_n();
    p.coulomb_n = f.coulomb_n();
    p.outflow = g.outflow();
    p.inflow = g.inflow();
    p.volume = g.volume();
    return p;
  }
  return std::nullopt;
}

namespace {

void SetStroke(config::LegOverride& o, Stroke stroke, const StrokeParams& p,
               const std::array<bool, StrokeParams::kCount>& use) {
  config::FrictionDirectionOverride& f = stroke == Stroke::kExtend ? o.friction_extend : o.friction_retract;
  config::PolytropicOverride& g = stroke == Stroke::kExtend ? o.polytropic_extend : o.polytropic_retract;
  if (use[0]) f.stribeck_velocity_m_s = p.stribeck_velocity_m_s;
  if (use[1]) f.viscous_n_s_m = p.viscous_n_s_m;
  if (use[2]) f.static_n = p.static_n;
  if (use[3]) f.coulomb_n = p.coulomb_n;
  if (use[4]) g.outflow = p.outflow;
  if (use[5]) g.inflow = p.inflow;
  if (use[6]) g.volume = p.volume;
}

}  // namespace

LegArray<double> HomeGravityLoadN(const config::SystemConfig& cfg, double payload_scale) {
  Pose home;
  home.p_BP_B_m = cfg.rig.geometry.home_position_m;
  LegArray<double> length{}, zero{};
  InverseKinematics(cfg.rig.geometry, home, length);
  PlatformInverseDynamics dynamics(cfg.rig);
  PlatformDynamicsTerms t;
  LegArray<double> load{};
  if (dynamics.Decompose(length, zero, t) != KinStatus::kOk) return load;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    load[i] = t.fixed_rest[static_cast<int>(i)] + payload_scale * t.scaled_rest[static_cast<int>(i)];
  }
  return load;
}

config::RigOverlay MakeOverlay(const Report& report, const config::SystemConfig& cfg, bool from_ga,
                               bool with_gravity_load) {
  config::RigOverlay o;
  o.rig_name = cfg.rig_name;
  std::ostringstream method;
  method << (from_ga ? "genetic algorithm (Table 7" : "least squares (Ceres")
         << ") on the eq 8 residuals, NRMSE of eq 13; payload scale "
         << Fmt(report.payload_scale, 5) << (report.payload_estimated ? " (estimated)" : " (given)")
         << (with_gravity_load ? ", gravity loads from it" : "")
         << "; parameters with a flat objective not written";
  o.provenance.method = method.str();
  for (const StrokeReport& s : report.strokes) {
    const auto& params = from_ga ? s.ga : s.lsq;
    if (!params) continue;
    const CurvatureReport& c = from_ga ? s.ga_curvature : s.lsq_curvature;
    SetStroke(o.leg[static_cast<std::size_t>(s.leg - 1)], s.stroke, *params, c.identifiable);
  }
  if (with_gravity_load) {
    const LegArray<double> g = HomeGravityLoadN(cfg, report.payload_scale);
    for (const StrokeReport& s : report.strokes) o.leg[static_cast<std::size_t>(s.leg - 1)].gravity_load_n = g[static_cast<std::size_t>(s.leg - 1)];
  }
  return o;
}

config::RigOverlay MakeTruthOverlay(const rec::PlantTruth& truth, const config::SystemConfig& cfg,
                                    bool with_gravity_load) {
  config::RigOverlay o;
  o.rig_name = cfg.rig_name;
  o.provenance.method = "the simulated plant's true parameters (profile '" + truth.profile() +
                        "', seed " + std::to_string(truth.seed()) + "): evaluation reference";
  o.provenance.date = "-";
  o.provenance.tool = "hexa_identify --truth-overlay";
  std::array<bool, StrokeParams::kCount> all{};
  all.fill(true);
  for (int leg = 1; leg <= 6; ++leg) {
    for (Stroke s : {Stroke::kExtend, Stroke::kRetract}) {
      if (const auto p = TrueStroke(truth, leg, s)) SetStroke(o.leg[static_cast<std::size_t>(leg - 1)], s, *p, all);
    }
  }
  if (with_gravity_load) {
    const LegArray<double> g = HomeGravityLoadN(cfg, truth.payload_scale());
    for (std::size_t i = 0; i < kNumLegs; ++i) o.leg[i].gravity_load_n = g[i];
  }
  return o;
}

std::string WriteValidatedOverlay(const config::RigOverlay& overlay, const config::SystemConfig& cfg,
                                  const std::string& path, const std::string& header) {
  const std::string text = config::ToTextFormat(overlay);
  const config::OverlayResult parsed = config::ParseRigOverlay(text, path);
  std::string error = parsed.error;
  if (parsed.ok) {
    const config::ConfigResult applied = config::ApplyRigOverlay(cfg, parsed.overlay, text);
    error = applied.ok ? "" : applied.error;
  }
  std::error_code ec;
  if (error.empty()) {
    std::ofstream out(path);
    out << "# " << header << "\n" << text;
    out.close();
    if (out) return "";
    error = "cannot write " + path;
  }
  std::filesystem::remove(path, ec);
  return error.empty() ? "refused" : error;
}

void WriteReport(const Report& r, const std::map<int, std::array<StrokeDataset, 2>>& data,
                 const std::string& out_dir) {
  // ---- Markdown ---------------------------------------------------------------------------
  std::ofstream md(out_dir + "/identification.md");
  md << "# Identification of " << r.recording << "\n\n";
  md << "Rig file " << r.rig_file << "; Gaussian differentiator window " << r.config.differentiator.window
     << ", sigma " << Fmt(r.config.differentiator.sigma) << " samples; samples with |v| >= "
     << Fmt(r.config.min_speed_m_s) << " m/s; payload scale " << Fmt(r.payload_scale, 5)
     << (r.payload_estimated ? " (estimated: median over the legs)" : " (given)");
  if (r.truth) md << ", true " << Fmt(r.truth->payload_scale(), 5);
  md << ". GA: Table 7 (nVar 7, MaxIt " << r.ga_params.max_iterations << ", nPop " << r.ga_params.population
     << ", pc 0.8, pm 0.3, mu 0.02), seed " << r.ga_params.seed << ", " << r.threads << " threads, "
     << "search space " << r.ga_space
     << (r.ga_space == "around-nominal"
             ? " (v_s, B, F_s - F_c, F_c from the rig file's value / " + Fmt(r.ga_range_factor) + " to x " +
                   Fmt(r.ga_range_factor) + ")"
         : r.ga_space == "force-at-speeds"
             ? " (v_s and eq 3's friction force at 0.1, 0.5, 1.2 m/s from the rig file's value / " +
                   Fmt(r.ga_range_factor) + " to x " + Fmt(r.ga_range_factor) + ")"
             : std::string(" (fixed ranges)"))
     << ", crossover " << (r.ga_params.crossover_per_pair ? "per-pair" : "per-gene") << ", mutation step "
     << MutationStepName(r.ga_params.mutation_step)
     << ". Least squares: Ceres, from the rig file's values.\n\n";
  if (!r.payload_per_leg.empty()) {
    md << "Payload scale per leg:";
    for (const auto& [leg, s] : r.payload_per_leg) md << " leg " << leg << " " << Fmt(s, 5) << ";";
    md << "\n\n";
  }
  md << "Cells: identified value (error % against the plant's truth) [expected 1-sigma error from "
        "noise, %]. `n.i.` = not identifiable from this recording: a 10 % change of the parameter, "
        "the others re-fitted, raises its channels' share of the objective by less than the "
        "objective's noise level 1/n_eff (n_eff = independent noise samples; the number given is "
        "that rise, the objective's curvature along the parameter); no value is claimed for it.\n\n";
  auto cell = [&](const std::optional<StrokeParams>& p, const CurvatureReport& c, const std::optional<StrokeParams>& t,
                  int i) -> std::string {
    if (!p) return "-";
    const double v = p->ToVector()[i];
    std::string s = Fmt(v, 5);
    if (t) s += " (" + Pct(ErrorPct(v, t->ToVector()[i])) + ")";
    s += " [" + Fmt(c.standard_error_pct[i], 2) + "]";
    if (!c.identifiable[static_cast<std::size_t>(i)]) {
      s = "n.i. (" + Fmt(100.0 * c.increase_profile_10pct[i], 2) + " % < " + Fmt(100.0 * c.flat_threshold, 2) + " %)";
    }
    return s;
  };
  std::map<int, std::array<const StrokeReport*, 2>> by_leg;
  for (const StrokeReport& s : r.strokes) by_leg[s.leg][static_cast<std::size_t>(s.stroke)] = &s;
  for (const auto& [leg, pair] : by_leg) {
    md << "## Leg " << leg << "\n\n";
    md << "| parameter | dimension | up: truth | up: GA | up: LSQ | down: truth | down: GA | down: LSQ |\n";
    md << "|---|---|---|---|---|---|---|---|\n";
    for (int i = 0; i < StrokeParams::kCount; ++i) {
      md << "| " << StrokeParams::Name(i) << " | " << StrokeParams::Unit(i);
      for (const StrokeReport* s : pair) {
        if (s == nullptr) {
          md << " | - | - | -";
          continue;
        }
        const auto t = r.truth ? TrueStroke(*r.truth, leg, s->stroke) : std::nullopt;
        md << " | " << (t ? Fmt(t->ToVector()[i], 5) : "-") << " | " << cell(s->ga, s->ga_curvature, t, i)
           << " | " << cell(s->lsq, s->lsq_curvature, t, i);
      }
      md << " |\n";
    }
    md << "| Z of eq 13 (truth column: the rig file's values) | -";
    for (const StrokeReport* s : pair) {
      if (s == nullptr) {
        md << " | - | - | -";
        continue;
      }
      md << " | " << Fmt(s->nominal_objective) << " | " << (s->ga ? Fmt(s->ga_objective) : "-") << " | "
         << (s->lsq ? Fmt(s->lsq_objective) : "-");
    }
    md << " |\n\n";
  }

  // Worst error per parameter against the targets.
  if (r.truth) {
    md << "## Worst error over the legs and directions (targets: F_c, F_s, gamma_* 5 %, v_s, B 10 %)\n\n";
    md << "| parameter | target % | GA worst % | GA met | LSQ worst % | LSQ met | not identifiable (GA / LSQ) |\n";
    md << "|---|---|---|---|---|---|---|\n";
    for (int i = 0; i < StrokeParams::kCount; ++i) {
      double worst[2] = {0.0, 0.0};
      int ni[2] = {0, 0};
      bool any[2] = {false, false};
      for (const StrokeReport& s : r.strokes) {
        const auto t = TrueStroke(*r.truth, s.leg, s.stroke);
        if (!t) continue;
        const std::optional<StrokeParams>* fits[2] = {&s.ga, &s.lsq};
        const CurvatureReport* curv[2] = {&s.ga_curvature, &s.lsq_curvature};
        for (int m = 0; m < 2; ++m) {
          if (!*fits[m]) continue;
          if (!curv[m]->identifiable[static_cast<std::size_t>(i)]) {
            ++ni[m];
            continue;
          }
          any[m] = true;
          worst[m] = std::max(worst[m], std::abs(ErrorPct((*fits[m])->ToVector()[i], t->ToVector()[i])));
        }
      }
      md << "| " << StrokeParams::Name(i) << " | " << Fmt(TargetPct(i));
      for (int m = 0; m < 2; ++m) {
        md << " | " << (any[m] ? Fmt(worst[m], 3) : "-") << " | "
           << (any[m] ? (worst[m] <= TargetPct(i) ? "yes" : "NO") : "-");
      }
      md << " | " << ni[0] << " / " << ni[1] << " |\n";
    }
    md << "\n";
  }

  md << "## GA against least squares, same recording\n\n";
  md << "| leg | direction | samples | Z nominal | Z GA | Z LSQ | GA wall s (" << r.threads
     << " threads) | GA evaluations | LSQ wall s | LSQ iterations |";
  if (r.truth) md << " GA max err % | LSQ max err % |";
  md << "\n|---|---|---|---|---|---|---|---|---|---|" << (r.truth ? "---|---|" : "") << "\n";
  for (const StrokeReport& s : r.strokes) {
    md << "| " << s.leg << " | " << ToString(s.stroke) << " | " << s.samples << " | " << Fmt(s.nominal_objective)
       << " | " << (s.ga ? Fmt(s.ga_objective) : "-") << " | " << (s.lsq ? Fmt(s.lsq_objective) : "-") << " | "
       << (s.ga ? Fmt(s.ga_wall_s, 3) : "-") << " | " << (s.ga ? std::to_string(s.ga_evaluations) : "-") << " | "
       << (s.lsq ? Fmt(s.lsq_wall_s, 3) : "-") << " | " << (s.lsq ? std::to_string(s.lsq_iterations) : "-") << " |";
    if (r.truth) {
      const auto t = TrueStroke(*r.truth, s.leg, s.stroke);
      for (int m = 0; m < 2; ++m) {
        const auto& fit = m == 0 ? s.ga : s.lsq;
        const CurvatureReport& c = m == 0 ? s.ga_curvature : s.lsq_curvature;
        double worst = 0.0;
        if (fit && t) {
          for (int i = 0; i < StrokeParams::kCount; ++i)
            if (c.identifiable[static_cast<std::size_t>(i)])
              worst = std::max(worst, std::abs(ErrorPct(fit->ToVector()[i], t->ToVector()[i])));
        }
        md << " " << (fit && t ? Fmt(worst, 3) : "-") << " |";
      }
    }
    md << "\n";
  }
  if (!r.free_fall_recording.empty()) {
    md << "\n## Free fall (Appendix B, eq 67 and 72) from " << r.free_fall_recording << "\n\n"
       << "Falling mass " << Fmt(r.free_fall_mass_kg, 4)
       << " kg (load + piston), both chambers vented, x(t) = A (t + tau exp(-t/tau) - tau) fitted from the "
          "release; F_c = W (1 - A / (g tau)), B = (W - F_c) / A. The falling rod extends: compare with "
          "the extend stroke. Eq 66 has no Stribeck term: its F_c is an effective level between F_s and "
          "F_c.\n\n";
    md << "| leg | samples | fall m | F_c free fall N | F_c truth (up) N | err % | F_s truth (up) N | B free fall N s/m | "
          "B truth (up) N s/m | err % | rms residual mm |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const FreeFallLeg& f : r.free_fall) {
      const std::optional<StrokeParams> t = r.truth ? TrueStroke(*r.truth, f.leg, Stroke::kExtend) : std::nullopt;
      const StrokeParams truth = t.value_or(StrokeParams{});
      md << "| " << f.leg << " | " << f.samples << " | " << Fmt(f.fall_m, 3) << " | "
         << (f.fit.ok ? Fmt(f.fit.coulomb_n, 5) : "fit failed") << " | " << (t ? Fmt(truth.coulomb_n, 5) : "-")
         << " | " << (t && f.fit.ok ? Pct(ErrorPct(f.fit.coulomb_n, truth.coulomb_n)) : "-") << " | "
         << (t ? Fmt(truth.static_n, 5) : "-") << " | " << (f.fit.ok ? Fmt(f.fit.viscous_n_s_m, 5) : "-") << " | "
         << (t ? Fmt(truth.viscous_n_s_m, 5) : "-") << " | "
         << (t && f.fit.ok ? Pct(ErrorPct(f.fit.viscous_n_s_m, truth.viscous_n_s_m)) : "-") << " | "
         << Fmt(1e3 * f.fit.rms_residual_m, 3) << " |\n";
    }
  }
  md << "\nOverlay: " << (r.overlay_refused ? "REFUSED (nothing written): " + r.overlay_error : r.overlay_path) << "\n";

  // ---- JSON ------------------------------------------------------------------------------
  {
    std::string error;
    if (!json::WriteFile(out_dir + "/identification.json", IdentificationJson(r), 2, error))
      std::fprintf(stderr, "error: %s\n", error.c_str());
  }

  // ---- CSV for the plots ----------------------------------------------------------------------
  std::ofstream hist(out_dir + "/ga_history.csv");
  hist << "leg,stroke,iteration,best_z\n";
  for (const StrokeReport& s : r.strokes) {
    for (std::size_t it = 0; it < s.ga_history.size(); ++it)
      hist << s.leg << "," << ToString(s.stroke) << "," << it << "," << s.ga_history[it] << "\n";
  }
  for (const StrokeReport& s : r.strokes) {
    const auto it = data.find(s.leg);
    if (it == data.end()) continue;
    const StrokeDataset& d = it->second[static_cast<std::size_t>(s.stroke)];
    const StrokeParams p = s.lsq ? *s.lsq : (s.ga ? *s.ga : s.nominal);
    std::ofstream csv(out_dir + "/predictions_leg" + std::to_string(s.leg) + "_" + ToString(s.stroke) + ".csv");
    csv << "tick,velocity_m_s,accel_meas_m_s2,accel_model_m_s2,p1_rate_meas_pa_s,p1_rate_model_pa_s,"
           "p2_rate_meas_pa_s,p2_rate_model_pa_s\n";
    std::vector<double> a, p1, p2;
    d.Predict(p, a, p1, p2);
    for (std::size_t k = 0; k < d.samples.size(); k += 2) {
      const IdentSample& q = d.samples[k];
      csv << q.tick << "," << q.velocity_m_s << "," << q.accel_m_s2 << "," << a[k] << "," << q.p1_rate_pa_s
          << "," << p1[k] << "," << q.p2_rate_pa_s << "," << p2[k] << "\n";
    }
  }
}

}  // namespace hexa::identify
