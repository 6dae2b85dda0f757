// A lockstep session (six leg controllers, the plant, the supervisor; fixed seed) driven tick by
// tick for the supervisor's operator-mode tests, every supervisor tick's output at hand.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

#include "hexa/core/lockstep_simulation.hpp"
#include "hexa/core/operator_motion.hpp"

namespace hexa::modes_test {

constexpr double kTick_s = 0.001;

inline LockstepConfig Config() {
  LockstepConfig c;
  c.seed = 7;
  return c;
}

// A session driven tick by tick; every supervisor tick's output is looked at by the caller.
class ModesSession {
 public:
  explicit ModesSession(const LockstepConfig& config = Config()) : sim_(config) {
    sim_.Tick();  // tick 0: the rest pose is latched
    Run(0.1, nullptr);
  }

  // Runs `duration_s` of simulated time. Jog messages (when `jog` is set) every `every_s`,
  // starting at the first supervisor tick.
  void Run(double duration_s, const JogRequest* jog, double every_s = 0.02) {
    const std::uint64_t end = sim_.tick() + static_cast<std::uint64_t>(std::llround(duration_s / kTick_s));
    double next_jog_s = sim_.time_s();
    while (sim_.tick() < end) {
      if (!sim_.supervisor_due()) {
        Step(OperatorCommandKind::kNone);
        continue;
      }
      OperatorCommandKind cmd = OperatorCommandKind::kNone;
      if (jog != nullptr && sim_.time_s() >= next_jog_s - 1e-9) {
        cmd = OperatorCommandKind::kJog;
        next_jog_s += every_s;
        last_jog_s_ = sim_.time_s();
      }
      Step(cmd, jog);
    }
  }

  // One tick; a command waits for the next supervisor tick.
  void Tick(OperatorCommandKind cmd, const JogRequest* jog_request = nullptr) {
    while (!sim_.supervisor_due()) Step(OperatorCommandKind::kNone);
    Step(cmd, jog_request);
  }

  // Sends a command at the next supervisor tick and returns its output.
  const SupervisorOutput& Command(OperatorCommandKind cmd, const Pose* goal = nullptr,
                                  const UserFramesConfig* frames = nullptr) {
    while (!sim_.supervisor_due()) Step(OperatorCommandKind::kNone);
    Step(cmd, nullptr, goal, frames);
    return sim_.supervisor_output();
  }
  const SupervisorOutput& Frames(const UserFramesConfig& frames) {
    return Command(OperatorCommandKind::kFrames, nullptr, &frames);
  }
  const SupervisorOutput& Start(const StartRequest& request) {
    while (!sim_.supervisor_due()) Step(OperatorCommandKind::kNone);
    Step(OperatorCommandKind::kStart, nullptr, nullptr, nullptr, &request);
    return sim_.supervisor_output();
  }

  void SetJog(const JogRequest& jog) { jog_ = jog; }

  // Runs until the supervisor is IDLE (or `max_s` passes); the time it took.
  double RunUntilIdle(double max_s) {
    const double t0 = sim_.time_s();
    while (sim_.time_s() - t0 < max_s) {
      Tick(OperatorCommandKind::kNone);
      if (sim_.supervisor_output().state == SupervisorState::kIdle) break;
    }
    return sim_.time_s() - t0;
  }

  const LockstepSimulation& sim() const { return sim_; }
  Pose truth() const { return sim_.plant().truth().pose; }
  Pose setpoint() const { return sim_.supervisor_output().desired.pose; }
  double last_jog_s() const { return last_jog_s_; }
  // Largest |second difference| of the setpoint's position per supervisor tick, m/s^2.
  double peak_setpoint_acceleration() const { return peak_acceleration_; }
  void ResetPeaks() { peak_acceleration_ = 0.0; }

 private:
  void Step(OperatorCommandKind cmd, const JogRequest* jog_request = nullptr, const Pose* goal = nullptr,
            const UserFramesConfig* frames = nullptr, const StartRequest* start = nullptr) {
    const bool due = sim_.supervisor_due();
    const JogRequest* jog = cmd == OperatorCommandKind::kJog ? (jog_request ? jog_request : &jog_) : nullptr;
    ASSERT_EQ(sim_.Tick(cmd, start, jog, goal, nullptr, 0, frames), PlantStatus::kOk);
    if (!due) return;
    const Eigen::Vector3d p = sim_.supervisor_output().desired.pose.p_BP_B_m;
    if (samples_ >= 2) {
      const double dt = 0.005;
      peak_acceleration_ = std::max(peak_acceleration_, (p - 2 * p1_ + p2_).norm() / (dt * dt));
    }
    p2_ = p1_;
    p1_ = p;
    ++samples_;
  }

  LockstepSimulation sim_;
  JogRequest jog_;
  double last_jog_s_ = 0.0;
  Eigen::Vector3d p1_ = Eigen::Vector3d::Zero(), p2_ = Eigen::Vector3d::Zero();
  int samples_ = 0;
  double peak_acceleration_ = 0.0;
};

inline JogRequest Jog(JogFrame frame, double vx, double vy, double vz, double wx = 0, double wy = 0,
               double wz = 0) {
  JogRequest j;
  j.frame = frame;
  j.twist << vx, vy, vz, wx, wy, wz;
  return j;
}

}  // namespace hexa::modes_test
