// platform_study's shared parts (main.cpp describes the program): the paper session's start and
// tick, the tracking-window iteration, the first-harmonic fit, and one function per subcommand.
#pragma once

#include <cmath>
#include <vector>

#include "coupled_leg_feedback.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/lockstep_simulation.hpp"

namespace platform_study {

using hexa::PaperMotion;

// Per-axis scale of the combined motion's amplitudes (keys ax ay az; 1 = eq 49). Lets a run
// take one axis' content out of the combined motion (diagnosis of combined z).
extern hexa::Vector6d g_combined_axis_scale;

// The start request of a paper motion, the combined one with g_combined_axis_scale applied.
hexa::StartRequest PaperStart(const hexa::LockstepSimulation& sim, PaperMotion motion, int periods);

// The axes a paper motion moves (x..yaw = 0..5; combined: x, y, z).
std::vector<int> MovingAxes(PaperMotion m);

// One tick of a paper session: the start command goes with the first supervisor tick.
// Returns false when the plant reports an error.
bool TickSession(hexa::LockstepSimulation& sim, const hexa::StartRequest& start, bool due,
                 bool started);

// Runs a paper session on `sim` (already ticked once) and calls
// fn(plant, t, desired sample, desired leg lengths, desired leg rates) on every 1 ms tick of
// the tracking window: t from the start command, the trajectory at the CURRENT time (no
// setpoint lead), leg lengths and rates through eq 46 on `geometry`.
template <class Fn>
void ForEachTrackingTick(hexa::LockstepSimulation& sim, const hexa::StartRequest& start,
                         const hexa::GeometryParams& geometry, Fn&& fn) {
  bool started = false, left_idle = false;
  double t_start = 0.0;
  hexa::SupervisorState state = hexa::SupervisorState::kIdle;
  while (sim.time_s() < 600.0) {
    const bool due = sim.supervisor_due();
    if (due && !started) t_start = sim.time_s();
    if (!TickSession(sim, start, due, started)) break;
    if (due) {
      started = true;
      state = sim.supervisor_output().state;
      if (state != hexa::SupervisorState::kIdle) left_idle = true;
      if (state == hexa::SupervisorState::kHold || (left_idle && state == hexa::SupervisorState::kIdle)) break;
    }
    if (state != hexa::SupervisorState::kTracking) continue;
    const auto& p = sim.plant_before_step();
    const double tt = p.truth.time_s - t_start;
    hexa::TrajectorySample d;
    start.trajectory.Evaluate(tt, d);
    hexa::LegArray<double> ld{}, vd{}, ad{};
    hexa::LegKinematicsOf(geometry, d, ld, vd, ad);
    fn(p, tt, d, ld, vd);
  }
}

// Least-squares fit y ~ c + a sin(w t) + b cos(w t).
struct Harmonic {
  double c = 0, a = 0, b = 0;
  double amplitude() const { return std::hypot(a, b); }
  double phase_rad() const { return std::atan2(b, a); }
};
Harmonic FitHarmonic(const std::vector<double>& t, const std::vector<double>& y, double w);

// Angular frequency of a paper motion (rad/s) and an angle wrapped to (-pi, pi].
double MotionOmega(PaperMotion motion);
double WrapPi(double a);

// The subcommands (main.cpp's header says what each prints).
void Trace(const hexa::LockstepConfig& config, PaperMotion motion, int periods);
void Fit(const hexa::LockstepConfig& config, PaperMotion motion, int periods);
void Legs(const hexa::LockstepConfig& config, PaperMotion motion, int periods);
void Reversals(const hexa::LockstepConfig& config, PaperMotion motion, int periods);
void ZSplit(const hexa::LockstepConfig& config, PaperMotion motion, int periods);
void Modes(const hexa::LockstepConfig& config, const hexa::study::CoupledLegFeedbackParams& coupled);

// Without a subcommand: the idle valve activity, then per motion the RMSE against the truth,
// the legs' RMSE, the ratio to the paper's accuracy and the valve activity, then the score.
void Score(const hexa::LockstepConfig& config, const std::vector<PaperMotion>& motions, int periods);

}  // namespace platform_study
