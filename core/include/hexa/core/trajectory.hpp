// Desired platform trajectories for the task-space supervisor (paper Sec. 4.2, 4.3).
//
// A Trajectory is a reference motion r(tau) (the paper's sinusoids of Sec. 4.2 / eq 49, a
// constant pose, or a user CSV) wrapped in three phases, all C2 in the pose vector
// q = [x y z roll pitch yaw] (m, rad; roll/pitch/yaw as in pose.hpp):
//
//   blend     t in [0, T_b)       q = q_start + sigma(s) (r(tau(t)) - q_start),  s = t / T_b
//                                 tau_dot = sigma(s): the reference starts at rest and
//                                 reaches full speed when the blend ends.
//   tracking  t in [T_b, T_e)     q = r(tau), tau = tau_0 + (t - T_b)  (metrics window)
//   stop      t in [T_e, T_e+T_s] q = q_rest + (1 - sigma(s)) (Q(u(t)) - q_rest),
//                                 u_dot = 1 - sigma(s): the motion decelerates while it
//                                 fades to the rest pose, which it reaches at rest.
//
// sigma is the quintic minimum-jerk ramp 10 s^3 - 15 s^4 + 6 s^5 (sigma, sigma', sigma''
// vanish at the ends), so position, velocity and acceleration are continuous at every phase
// boundary and zero at both ends. Derivation and formulas: docs/trajectories.md.
//
// Evaluate() neither throws nor allocates: it may run inside the 5 ms supervisor cycle.
#pragma once

#include <memory>
#include <string_view>

#include "hexa/core/control_params.hpp"
#include "hexa/core/pose.hpp"

namespace hexa {

// Pose vector q = [x y z roll pitch yaw] (m, rad) and its first two time derivatives.
struct PoseVectorState {
  Vector6d q = Vector6d::Zero();
  Vector6d q_dot = Vector6d::Zero();
  Vector6d q_ddot = Vector6d::Zero();
};

// A reference motion r(tau) defined for every tau (constant outside its own span is fine).
// Tracking covers tau in [start_time_s(), end_time_s()].
class ReferenceMotion {
 public:
  virtual ~ReferenceMotion() = default;
  // Derivatives are with respect to tau. Must neither throw nor allocate.
  virtual void Evaluate(double tau_s, PoseVectorState& state) const noexcept = 0;
  virtual double start_time_s() const noexcept = 0;
  virtual double end_time_s() const noexcept = 0;
};

// q(tau) = centre + amplitude .* sin(2 pi f tau + phase), per component, for `periods`
// periods starting at tau = 0 (the paper's t = 0 is the start of the tracking window).
class SinusoidMotion final : public ReferenceMotion {
 public:
  // Throws std::invalid_argument for non-finite values, f <= 0 or periods < 1.
  SinusoidMotion(const Vector6d& centre, const Vector6d& amplitude, const Vector6d& phase_rad,
                 double frequency_hz, int periods);
  void Evaluate(double tau_s, PoseVectorState& state) const noexcept override;
  double start_time_s() const noexcept override { return 0.0; }
  double end_time_s() const noexcept override { return periods_ / frequency_hz_; }
  double frequency_hz() const { return frequency_hz_; }
  const Vector6d& amplitude() const { return amplitude_; }
  const Vector6d& centre() const { return centre_; }

 private:
  Vector6d centre_;
  Vector6d amplitude_;
  Vector6d phase_rad_;
  double frequency_hz_;
  int periods_;
};

// A fixed pose (the operator's "home" move: blend to it, no tracking span).
class ConstantMotion final : public ReferenceMotion {
 public:
  explicit ConstantMotion(const Vector6d& xyz_rpy) : q_(xyz_rpy) {}
  void Evaluate(double, PoseVectorState& state) const noexcept override {
    state.q = q_;
    state.q_dot.setZero();
    state.q_ddot.setZero();
  }
  double start_time_s() const noexcept override { return 0.0; }
  double end_time_s() const noexcept override { return 0.0; }

 private:
  Vector6d q_;
};

enum class TrajectoryPhase { kBlend, kTracking, kStop, kDone };
const char* ToString(TrajectoryPhase phase);

struct TrajectorySample {
  TrajectoryPhase phase = TrajectoryPhase::kDone;
  PoseVectorState vector;                      // q, q_dot, q_ddot
  Pose pose;                                   // desired X_BP
  Vector6d twist_B = Vector6d::Zero();         // [v_BP_B; w_BP_B]
  Vector6d twist_rate_B = Vector6d::Zero();    // [a_BP_B; alpha_BP_B]
};

struct TrajectoryTiming {
  double blend_duration_s = 2.0;  // T_b > 0
  double stop_duration_s = 1.0;   // T_s >= 0 (0 only for motions that end at rest)
};
TrajectoryTiming TimingFrom(const SupervisorParams& params);

class Trajectory {
 public:
  Trajectory() = default;  // empty: valid() is false
  // Throws std::invalid_argument for a null motion, non-finite poses or T_b <= 0, T_s < 0.
  Trajectory(std::shared_ptr<const ReferenceMotion> motion, const Vector6d& start_xyz_rpy,
             const Vector6d& rest_xyz_rpy, const TrajectoryTiming& timing);

  bool valid() const { return motion_ != nullptr; }
  double duration_s() const { return stop_start_s_ + timing_.stop_duration_s; }
  // Tracking window [T_b, T_e): where the reference is followed exactly; metrics go here.
  double tracking_start_s() const { return timing_.blend_duration_s; }
  double tracking_end_s() const { return stop_start_s_; }
  const Vector6d& start_xyz_rpy() const { return start_; }
  const Vector6d& rest_xyz_rpy() const { return rest_; }
  const TrajectoryTiming& timing() const { return timing_; }
  const ReferenceMotion* motion() const { return motion_.get(); }

  // Desired pose, twist and its rate at trajectory time t (t < 0 -> start pose, at rest;
  // t >= duration -> rest pose, at rest).
  void Evaluate(double t_s, TrajectorySample& sample) const noexcept;
  // Same trajectory with an operator stop at t_stop_s: the stop law of the header starts
  // there instead of at tracking_end_s(). t_stop_s >= tracking_end_s() is the normal stop.
  void EvaluateStopped(double t_s, double t_stop_s, TrajectorySample& sample) const noexcept;
  double StoppedDuration(double t_stop_s) const;

 private:
  // Blend + tracking continued forever (no stop), at trajectory time u >= 0.
  void EvaluateNominal(double u_s, PoseVectorState& state) const noexcept;
  void EvaluateStop(double t_s, double t_stop_s, PoseVectorState& state) const noexcept;

  std::shared_ptr<const ReferenceMotion> motion_;
  Vector6d start_ = Vector6d::Zero();
  Vector6d rest_ = Vector6d::Zero();
  TrajectoryTiming timing_;
  double stop_start_s_ = 0.0;
};

// Twist and its rate from the pose-vector derivatives (roll/pitch/yaw about fixed axes:
// w = rdot Rz Ry e_x + pdot Rz e_y + ydot e_z).
void TwistFromPoseVector(const PoseVectorState& state, Vector6d& twist_B, Vector6d& twist_rate_B);

// The paper's trajectories (Sec. 4.2: pure motions, 8 cm / 15 deg, 0.1 Hz; Sec. 4.3, eq 49:
// combined x = 8 sin, y = 8 cos, z = 8 sin cm at 1 Hz), centred on the home pose.
enum class PaperMotion { kX, kY, kZ, kRoll, kPitch, kYaw, kCombined };
const char* ToString(PaperMotion motion);  // "x" "y" "z" "roll" "pitch" "yaw" "combined"
bool ParsePaperMotion(std::string_view name, PaperMotion& motion);
int DefaultPeriods(PaperMotion motion);  // 2 for the 0.1 Hz pure motions, 10 for combined

// periods <= 0 -> DefaultPeriods. amplitude_scale multiplies the paper's amplitudes.
std::shared_ptr<const SinusoidMotion> MakePaperMotion(PaperMotion motion,
                                                      const Vector6d& home_xyz_rpy,
                                                      int periods = 0,
                                                      double amplitude_scale = 1.0);
// The full trajectory from `start_xyz_rpy` (the current pose) back to rest at home.
Trajectory MakePaperTrajectory(PaperMotion motion, const Vector6d& start_xyz_rpy,
                               const Vector6d& home_xyz_rpy, const TrajectoryTiming& timing,
                               int periods = 0, double amplitude_scale = 1.0);

// Home pose vector of a rig geometry: [home_position_m, 0, 0, 0].
Vector6d HomePoseVector(const Eigen::Vector3d& home_position_m);

}  // namespace hexa
