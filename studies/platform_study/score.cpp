// platform_study without a subcommand: accuracy per paper motion against the paper's tables,
// and the valve activity (main.cpp's header defines du, sat and flip).
#include <cmath>
#include <cstdio>

#include "platform_study.hpp"

namespace platform_study {
namespace {

// The paper's accuracy (Table 9 pure motions, Table 10 combined), cm and deg.
constexpr double kTable9[6] = {0.782, 0.841, 0.197, 1.012, 1.346, 1.836};
constexpr double kTable10[6] = {0.845, 1.205, 0.296, 1.193, 1.817, 2.433};

// Valve activity accumulator (see the header).
struct ValveActivity {
  double sum_du_v = 0.0;
  long saturated = 0;
  long reversals = 0;
  long samples = 0;
  hexa::LegArray<double> prev_v{};
  hexa::LegArray<int> side{};  // -1 extend, +1 retract, 0 not yet
  bool primed = false;
  void Add(const hexa::LegArray<double>& u) {
    for (std::size_t i = 0; i < 6; ++i) {
      if (primed) {
        sum_du_v += std::abs(u[i] - prev_v[i]);
        saturated += (u[i] < 0.05 || u[i] > 9.95) ? 1 : 0;
        const int s = u[i] < 3.0 ? -1 : (u[i] > 7.0 ? 1 : 0);
        if (s != 0 && side[i] != 0 && s != side[i]) ++reversals;
        if (s != 0) side[i] = s;
        ++samples;
    }
      prev_v[i] = u[i];
    }
    primed = true;
  }
  double MeanDu() const { return samples ? sum_du_v / samples : 0.0; }
  double SatFraction() const { return samples ? static_cast<double>(saturated) / samples : 0.0; }
  // reversals per leg per second (1 ms ticks)
  double FlipsPerS() const { return samples ? 1000.0 * reversals / samples : 0.0; }
};

ValveActivity IdleActivity(const hexa::LockstepConfig& config) {
  hexa::LockstepSimulation sim(config);
  ValveActivity a;
  for (int k = 0; k < 3500; ++k) {
    sim.Tick();
    if (k >= 500) a.Add(sim.applied_valve_v());
  }
  return a;
}

// RunPaperSession (same loop and metrics) plus the valve activity of the tracking window.
hexa::PaperSessionResult RunSession(const hexa::LockstepConfig& config, PaperMotion motion, int periods,
                                    ValveActivity& activity) {
  hexa::PaperSessionResult result;
  hexa::LockstepSimulation sim(config);
  result.plant_status = sim.Tick();
  if (result.plant_status != hexa::PlantStatus::kOk) return result;
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  bool started = false, left_idle = false;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    auto cmd = (due && !started) ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone;
    result.plant_status = sim.Tick(cmd, cmd == hexa::OperatorCommandKind::kStart ? &start : nullptr);
    if (result.plant_status != hexa::PlantStatus::kOk) break;
    if (due) {
      started = true;
      const hexa::SupervisorOutput& out = sim.supervisor_output();
      state = out.state;
      if (state == hexa::SupervisorState::kTracking) {
        result.metrics.AddPose(out.desired_xyz_rpy, out.estimate.xyz_rpy,
                               hexa::VectorFromPose(sim.plant_before_step().truth.pose));
    }
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold || (left_idle && state == hexa::SupervisorState::kIdle)) break;
    }
    if (state == hexa::SupervisorState::kTracking) {
      for (std::size_t i = 0; i < 6; ++i) {
        result.metrics.leg_length[i].Add(sim.leg_outputs()[i].desired_length_m,
                                         sim.plant_before_step().legs[i].length_m);
    }
      activity.Add(sim.applied_valve_v());
    }
  }
  result.final_state = state;
  result.completed = left_idle && state == hexa::SupervisorState::kIdle &&
                     result.plant_status == hexa::PlantStatus::kOk;
  result.ticks = sim.tick();
  return result;
}

}  // namespace

void Score(const hexa::LockstepConfig& config, const std::vector<PaperMotion>& motions, int periods) {
  double score = 0.0;
  int incomplete = 0;
  {
    const ValveActivity idle = IdleActivity(config);
    std::printf("idle     valve du %.3f V/tick sat %.1f %% flip %.1f /s\n", idle.MeanDu(),
                100.0 * idle.SatFraction(), idle.FlipsPerS());
  }
  for (const auto motion : motions) {
    ValveActivity act;
    const auto r = RunSession(config, motion, periods, act);
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
    std::printf("%-8s %s | %7.4f %7.4f %7.4f cm | %7.4f %7.4f %7.4f deg | legs mm", hexa::ToString(motion),
                r.completed ? "ok  " : "HOLD", v[0], v[1], v[2], v[3], v[4], v[5]);
    for (const auto& leg : r.metrics.leg_length) {
      std::printf(" %6.2f", 1000 * leg.Rmse());
    }
    std::printf(" | /paper %.3f | du %.3f sat %.1f%% flip %.1f\n", ratio, act.MeanDu(),
                100.0 * act.SatFraction(), act.FlipsPerS());
  }
  std::printf("SCORE %.4f incomplete %d\n", score / static_cast<double>(motions.size()), incomplete);
}

}  // namespace platform_study
