// platform_study: tuning and diagnosis of the leg controllers ON THE FULL PLATFORM, in the
// in-process lockstep simulation (RunPaperSession, same protocol as the DDS system).
// Not a test. docs/tuning.md gives the grids run with it and the figures.
//
//   platform_study [--rig file|default] [--seed N] [--controller bssmc|pi] [--ideal] [--traj all|x,y,...]
//                  [--periods N] [key=value ...]
//   platform_study trace <traj> [options]      per-tick CSV of the legs (stdout)
//
// Overrides (key=value) start from the struct defaults (= deploy/rigs/hexataar_r.textproto):
// see kKeys below. Output: per trajectory the RMSE vs ground truth per axis (cm, deg), leg
// RMSE (mm), fraction of ticks with a saturated valve, and the score: the mean over the
// seven trajectories of (moving-axis RMSE / paper's value for that axis), i.e. 1.0 = the
// paper's Table 9 / Table 10 accuracy on average.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/lockstep_simulation.hpp"

namespace {

using hexa::PaperMotion;

struct Key {
  const char* name;
  std::function<void(hexa::LockstepConfig&, double)> set;
};

std::vector<Key> Keys() {
  return {
      {"lambda", [](auto& c, double v) { c.leg_controller.bssmc.lambda_1_s = v; }},
      {"K", [](auto& c, double v) { c.leg_controller.bssmc.switching_gain_n = v; }},
      {"xi", [](auto& c, double v) { c.leg_controller.bssmc.boundary_layer_xi_s_m = v; }},
      {"beta", [](auto& c, double v) { c.leg_controller.bssmc.backstepping_beta_1_s = v; }},
      {"M", [](auto& c, double v) { c.leg_controller.bssmc.effective_mass_kg = v; }},
      {"Fg", [](auto& c, double v) { c.leg_controller.bssmc.gravity_load_n = v; }},
      {"visc", [](auto& c, double v) { c.leg_controller.bssmc.viscous_estimate_scale = v; }},
      {"fric", [](auto& c, double v) { c.leg_controller.bssmc.friction_estimate_scale = v; }},
      {"ks", [](auto& c, double v) { c.leg_controller.bssmc.reaching_proportional_n_s_m = v; }},
      {"lag", [](auto& c, double v) { c.leg_controller.differentiator.centre_lag_samples = v; }},
      {"kp", [](auto& c, double v) { c.leg_controller.pi.proportional_v_m = v; }},
      {"ki", [](auto& c, double v) { c.leg_controller.pi.integral_v_m_s = v; }},
      {"ilim", [](auto& c, double v) { c.leg_controller.pi.integrator_limit_v = v; }},
      {"kv", [](auto& c, double v) { c.leg_controller.pi.velocity_feedforward_v_s_m = v; }},
      {"kd", [](auto& c, double v) { c.leg_controller.pi.rate_damping_v_s_m = v; }},
      {"ol", [](auto& c, double v) { c.supervisor.outer_loop.enabled = v != 0.0; }},
      {"ol_gain", [](auto& c, double v) { c.supervisor.outer_loop.gain = v; }},
      {"ol_pos", [](auto& c, double v) { c.supervisor.outer_loop.translation_gain_scale = v; }},
      {"ol_max", [](auto& c, double v) { c.supervisor.outer_loop.max_correction_m = v; }},
  };
}

// The paper's accuracy (Table 9 pure motions, Table 10 combined), cm and deg.
constexpr double kTable9[6] = {0.782, 0.841, 0.197, 1.012, 1.346, 1.836};
constexpr double kTable10[6] = {0.845, 1.205, 0.296, 1.193, 1.817, 2.433};

std::vector<int> MovingAxes(PaperMotion m) {
  switch (m) {
    case PaperMotion::kX: return {0};
    case PaperMotion::kY: return {1};
    case PaperMotion::kZ: return {2};
    case PaperMotion::kRoll: return {3};
    case PaperMotion::kPitch: return {4};
    case PaperMotion::kYaw: return {5};
    case PaperMotion::kCombined: return {0, 1, 2};
  }
  return {};
}

int Usage() {
  std::fprintf(stderr,
               "usage: platform_study [trace <traj>] [--rig file|default] [--seed N] [--controller bssmc|pi] [--ideal]\n"
               "       [--traj all|x,y,z,roll,pitch,yaw,combined] [--periods N] [key=value ...]\n"
               "keys:");
  for (const auto& k : Keys()) std::fprintf(stderr, " %s", k.name);
  std::fprintf(stderr, "\n");
  return 2;
}

void Trace(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = sim.supervisor().PreparePaperStart(motion, periods);
  std::printf("t,state");
  for (int i = 1; i <= 6; ++i)
    std::printf(",ld%d,l%d,ltrue%d,vd%d,ad%d,u%d,phi%d,S%d,P1_%d,P2_%d,corr%d", i, i, i, i, i, i, i,
                i, i, i, i);
  std::printf("\n");
  bool started = false, left_idle = false;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  hexa::LegArray<double> corr{};
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    auto cmd = (due && !started) ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    if (sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr) !=
        hexa::PlantStatus::kOk)
      break;
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
      std::printf(",%.6f,%.6f,%.6f,%.4f,%.3f,%.3f,%.2f,%.4f,%.0f,%.0f,%.6f", o.desired_length_m,
                  p.legs[i].length_m, p.truth.length_m[i], o.desired_velocity_m_s, 0.0,
                  sim.applied_valve_v()[i], o.desired_force_n, o.sliding_surface_m_s,
                  p.legs[i].chamber1_pressure_pa, p.legs[i].chamber2_pressure_pa, corr[i]);
    }
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  hexa::LockstepConfig config;
  config.seed = 1;
  std::vector<PaperMotion> motions = {PaperMotion::kX,    PaperMotion::kY,     PaperMotion::kZ,
                                      PaperMotion::kRoll, PaperMotion::kPitch, PaperMotion::kYaw,
                                      PaperMotion::kCombined};
  int periods = 0;
  bool trace = false;
  const auto keys = Keys();
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto next = [&]() -> std::string { return a + 1 < argc ? argv[++a] : std::string(); };
    if (arg == "trace") {
      trace = true;
      PaperMotion m;
      if (!hexa::ParsePaperMotion(next(), m)) return Usage();
      motions = {m};
    } else if (arg == "--seed") {
      config.seed = std::strtoull(next().c_str(), nullptr, 10);
    } else if (arg == "--controller") {
      const std::string c = next();
      config.controller = c == "pi" ? hexa::LegControllerKind::kPi : hexa::LegControllerKind::kBsSmc;
    } else if (arg == "--rig") {
      // Start from a rig file (as hexa_sim does) instead of the struct defaults; overrides
      // given AFTER --rig apply on top of it.
      std::string path = next();
      if (path == "default") path = hexa::config::DefaultRigFile();
      const auto loaded = hexa::config::LoadSystemConfig(path);
      if (!loaded.ok) {
        std::fprintf(stderr, "%s\n", loaded.error.c_str());
        return 1;
      }
      config.rig = loaded.config.rig;
      config.leg_controller = loaded.config.leg_controller;
      config.supervisor = loaded.config.supervisor;
      config.disturbance = loaded.config.profiles.at(loaded.config.default_profile);
    } else if (arg == "--ideal") {
      config.disturbance = hexa::MakeIdealDisturbanceProfile();
    } else if (arg == "--periods") {
      periods = std::atoi(next().c_str());
    } else if (arg == "--traj") {
      const std::string list = next();
      if (list != "all") {
        motions.clear();
        std::size_t pos = 0;
        while (pos <= list.size()) {
          const std::size_t comma = list.find(',', pos);
          const std::string name = list.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
          PaperMotion m;
          if (!hexa::ParsePaperMotion(name, m)) return Usage();
          motions.push_back(m);
          if (comma == std::string::npos) break;
          pos = comma + 1;
        }
      }
    } else if (const auto eq = arg.find('='); eq != std::string::npos) {
      const std::string k = arg.substr(0, eq);
      bool found = false;
      for (const auto& key : keys) {
        if (k == key.name) {
          key.set(config, std::strtod(arg.c_str() + eq + 1, nullptr));
          found = true;
        }
      }
      if (!found) return Usage();
    } else {
      return Usage();
    }
  }
  if (trace) {
    Trace(config, motions.front(), periods);
    return 0;
  }
  double score = 0.0;
  int incomplete = 0;
  for (const auto motion : motions) {
    const auto r = hexa::RunPaperSession(config, motion, periods);
    const auto e = r.metrics.vs_truth.Rmse();
    double v[6];
    for (int k = 0; k < 6; ++k) v[k] = k < 3 ? 100.0 * e[k] : e[k] * 57.29577951308232;
    const double* paper = motion == PaperMotion::kCombined ? kTable10 : kTable9;
    double ratio = 0.0;
    const auto axes = MovingAxes(motion);
    for (int k : axes) ratio += v[k] / paper[k];
    ratio /= static_cast<double>(axes.size());
    if (!r.completed) {
      ++incomplete;
      ratio = 100.0;  // a session that went to HOLD scores badly whatever its partial RMSE
    }
    score += ratio;
    double leg_max = 0.0;
    std::printf("%-8s %s | %7.4f %7.4f %7.4f cm | %7.4f %7.4f %7.4f deg | legs mm", hexa::ToString(motion),
                r.completed ? "ok  " : "HOLD", v[0], v[1], v[2], v[3], v[4], v[5]);
    for (const auto& leg : r.metrics.leg_length) {
      std::printf(" %6.2f", 1000 * leg.Rmse());
      leg_max = std::max(leg_max, leg.Rmse());
    }
    std::printf(" | /paper %.3f\n", ratio);
  }
  std::printf("SCORE %.4f incomplete %d\n", score / static_cast<double>(motions.size()), incomplete);
  return 0;
}
