// Trajectories of the task-space supervisor: blend, tracking, stop (see trajectory.hpp and
// docs/trajectories.md for the formulas).
#include "hexa/core/trajectory.hpp"
#include "hexa/core/math_constants.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hexa {
namespace {

// Minimum-jerk ramp sigma(s) = 10 s^3 - 15 s^4 + 6 s^5 on [0, 1] and its derivatives in s,
// plus W(s) = integral_0^s sigma = 2.5 s^4 - 3 s^5 + s^6 (the warped reference time).
struct Ramp {
  double sigma, d1, d2, integral;
};

Ramp MinimumJerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  const double s2 = s * s, s3 = s2 * s, s4 = s3 * s;
  return {10.0 * s3 - 15.0 * s4 + 6.0 * s4 * s,
          30.0 * s2 - 60.0 * s3 + 30.0 * s4,
          60.0 * s - 180.0 * s2 + 120.0 * s3,
          2.5 * s4 - 3.0 * s4 * s + s4 * s2};
}

// q = q_f + lambda (r - q_f) where r is evaluated at a warped time with rate tau_dot and
// tau_ddot; r's derivatives are with respect to its own time. Chain and product rules.
void Mix(const Vector6d& q_f, double lambda, double lambda_dot, double lambda_ddot,
         const PoseVectorState& r, double tau_dot, double tau_ddot, PoseVectorState& out) {
  const Vector6d diff = r.q - q_f;
  out.q = q_f + lambda * diff;
  out.q_dot = lambda_dot * diff + lambda * tau_dot * r.q_dot;
  out.q_ddot = lambda_ddot * diff + 2.0 * lambda_dot * tau_dot * r.q_dot +
               lambda * (tau_dot * tau_dot * r.q_ddot + tau_ddot * r.q_dot);
}

bool AllFinite(const Vector6d& v) { return v.allFinite(); }

}  // namespace

const char* ToString(TrajectoryPhase phase) {
  switch (phase) {
    case TrajectoryPhase::kBlend: return "blend";
    case TrajectoryPhase::kTracking: return "tracking";
    case TrajectoryPhase::kStop: return "stop";
    case TrajectoryPhase::kDone: return "done";
  }
  return "?";
}

SinusoidMotion::SinusoidMotion(const Vector6d& centre, const Vector6d& amplitude,
                               const Vector6d& phase_rad, double frequency_hz, int periods)
    : centre_(centre),
      amplitude_(amplitude),
      phase_rad_(phase_rad),
      frequency_hz_(frequency_hz),
      periods_(periods) {
  if (!AllFinite(centre) || !AllFinite(amplitude) || !AllFinite(phase_rad)) {
    throw std::invalid_argument("SinusoidMotion: non-finite centre, amplitude or phase");
  }
  if (!(frequency_hz > 0.0) || !std::isfinite(frequency_hz)) {
    throw std::invalid_argument("SinusoidMotion: frequency_hz = " + std::to_string(frequency_hz) +
                                " must be finite and > 0");
  }
  if (periods < 1) {
    throw std::invalid_argument("SinusoidMotion: periods = " + std::to_string(periods) +
                                " must be >= 1");
  }
}

void SinusoidMotion::Evaluate(double tau_s, PoseVectorState& state) const noexcept {
  const double omega = 2.0 * kPi * frequency_hz_;
  for (int k = 0; k < 6; ++k) {
    const double angle = omega * tau_s + phase_rad_[k];
    const double s = std::sin(angle), c = std::cos(angle);
    state.q[k] = centre_[k] + amplitude_[k] * s;
    state.q_dot[k] = amplitude_[k] * omega * c;
    state.q_ddot[k] = -amplitude_[k] * omega * omega * s;
  }
}

TrajectoryTiming TimingFrom(const SupervisorParams& params) {
  TrajectoryTiming timing;
  timing.blend_duration_s = params.blend_duration_s;
  timing.stop_duration_s = params.stop_duration_s;
  return timing;
}

Trajectory::Trajectory(std::shared_ptr<const ReferenceMotion> motion,
                       const Vector6d& start_xyz_rpy, const Vector6d& rest_xyz_rpy,
                       const TrajectoryTiming& timing)
    : motion_(std::move(motion)), start_(start_xyz_rpy), rest_(rest_xyz_rpy), timing_(timing) {
  if (motion_ == nullptr) throw std::invalid_argument("Trajectory: no reference motion");
  if (!AllFinite(start_) || !AllFinite(rest_)) {
    throw std::invalid_argument("Trajectory: non-finite start or rest pose");
  }
  if (!(timing_.blend_duration_s > 0.0) || !std::isfinite(timing_.blend_duration_s)) {
    throw std::invalid_argument("Trajectory: blend_duration_s = " +
                                std::to_string(timing_.blend_duration_s) + " must be > 0");
  }
  if (!(timing_.stop_duration_s >= 0.0) || !std::isfinite(timing_.stop_duration_s)) {
    throw std::invalid_argument("Trajectory: stop_duration_s = " +
                                std::to_string(timing_.stop_duration_s) + " must be >= 0");
  }
  const double span_s = motion_->end_time_s() - motion_->start_time_s();
  if (!(span_s >= 0.0) || !std::isfinite(span_s)) {
    throw std::invalid_argument("Trajectory: reference motion span must be finite and >= 0");
  }
  stop_start_s_ = timing_.blend_duration_s + span_s;
}

void Trajectory::EvaluateNominal(double u_s, PoseVectorState& state) const noexcept {
  const double t_b = timing_.blend_duration_s;
  const double tau_0 = motion_->start_time_s();
  if (u_s >= t_b) {
    motion_->Evaluate(tau_0 + (u_s - t_b), state);
    return;
  }
  // Blend: the reference time runs at rate sigma(s), so the reference starts at rest and
  // reaches tau_0 with unit rate exactly when the blend weight reaches 1.
  const double s = std::max(u_s, 0.0) / t_b;
  const Ramp ramp = MinimumJerk(s);
  const double tau = tau_0 + t_b * (ramp.integral - 0.5);  // W(1) = 0.5
  PoseVectorState r;
  motion_->Evaluate(tau, r);
  Mix(start_, ramp.sigma, ramp.d1 / t_b, ramp.d2 / (t_b * t_b), r, ramp.sigma, ramp.d1 / t_b,
      state);
}

void Trajectory::EvaluateStop(double t_s, double t_stop_s, PoseVectorState& state) const noexcept {
  const double t_s_dur = timing_.stop_duration_s;
  if (t_s_dur <= 0.0) {
    // Allowed only for motions that end at rest (checked by continuity tests): jump to rest.
    state.q = rest_;
    state.q_dot.setZero();
    state.q_ddot.setZero();
    return;
  }
  const double s = (t_s - t_stop_s) / t_s_dur;
  const Ramp ramp = MinimumJerk(s);
  // Warped time u = t_stop + T_s (s - W(s)): rate 1 - sigma, decelerating to rest.
  const double sc = std::clamp(s, 0.0, 1.0);
  const double u = t_stop_s + t_s_dur * (sc - ramp.integral);
  PoseVectorState nominal;
  EvaluateNominal(u, nominal);
  Mix(rest_, 1.0 - ramp.sigma, -ramp.d1 / t_s_dur, -ramp.d2 / (t_s_dur * t_s_dur), nominal,
      1.0 - ramp.sigma, -ramp.d1 / t_s_dur, state);
}

void Trajectory::Evaluate(double t_s, TrajectorySample& sample) const noexcept {
  EvaluateStopped(t_s, stop_start_s_, sample);
}

double Trajectory::StoppedDuration(double t_stop_s) const {
  return std::min(std::max(t_stop_s, 0.0), stop_start_s_) + timing_.stop_duration_s;
}

void Trajectory::EvaluateStopped(double t_s, double t_stop_s,
                                 TrajectorySample& sample) const noexcept {
  if (motion_ == nullptr) {
    sample = TrajectorySample{};
    return;
  }
  t_stop_s = std::min(std::max(t_stop_s, 0.0), stop_start_s_);
  if (t_s < t_stop_s) {
    sample.phase = t_s < timing_.blend_duration_s ? TrajectoryPhase::kBlend
                                                  : TrajectoryPhase::kTracking;
    EvaluateNominal(t_s, sample.vector);
  } else {
    sample.phase = t_s < t_stop_s + timing_.stop_duration_s ? TrajectoryPhase::kStop
                                                            : TrajectoryPhase::kDone;
    EvaluateStop(t_s, t_stop_s, sample.vector);
  }
  sample.pose = PoseFromVector(sample.vector.q);
  TwistFromPoseVector(sample.vector, sample.twist_B, sample.twist_rate_B);
}

void TwistFromPoseVector(const PoseVectorState& state, Vector6d& twist_B,
                         Vector6d& twist_rate_B) {
  const double roll = state.q[3], pitch = state.q[4], yaw = state.q[5];
  const double rd = state.q_dot[3], pd = state.q_dot[4], yd = state.q_dot[5];
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d Ry =
      Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  (void)roll;  // R = Rz Ry Rx: the roll axis Rz Ry e_x does not depend on roll itself
  // Axes of the three elementary rotations, expressed in B.
  const Eigen::Vector3d axis_roll = Rz * Ry * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d axis_pitch = Rz * Eigen::Vector3d::UnitY();
  const Eigen::Vector3d axis_yaw = Eigen::Vector3d::UnitZ();
  twist_B.head<3>() = state.q_dot.head<3>();
  twist_B.tail<3>() = rd * axis_roll + pd * axis_pitch + yd * axis_yaw;
  // alpha = sum(axis * angle_ddot) + sum(angle_dot * d(axis)/dt); each axis rotates with the
  // angular velocity of the rotations applied after it (yaw, then pitch).
  const Eigen::Vector3d w_yaw = yd * axis_yaw;
  const Eigen::Vector3d w_yaw_pitch = w_yaw + pd * axis_pitch;
  twist_rate_B.head<3>() = state.q_ddot.head<3>();
  twist_rate_B.tail<3>() = state.q_ddot[3] * axis_roll + state.q_ddot[4] * axis_pitch +
                           state.q_ddot[5] * axis_yaw + rd * w_yaw_pitch.cross(axis_roll) +
                           pd * w_yaw.cross(axis_pitch);
}

const char* ToString(PaperMotion motion) {
  switch (motion) {
    case PaperMotion::kX: return "x";
    case PaperMotion::kY: return "y";
    case PaperMotion::kZ: return "z";
    case PaperMotion::kRoll: return "roll";
    case PaperMotion::kPitch: return "pitch";
    case PaperMotion::kYaw: return "yaw";
    case PaperMotion::kCombined: return "combined";
  }
  return "?";
}

bool ParsePaperMotion(std::string_view name, PaperMotion& motion) {
  for (PaperMotion m : {PaperMotion::kX, PaperMotion::kY, PaperMotion::kZ, PaperMotion::kRoll,
                        PaperMotion::kPitch, PaperMotion::kYaw, PaperMotion::kCombined}) {
    if (name == ToString(m)) {
      motion = m;
      return true;
    }
  }
  return false;
}

int DefaultPeriods(PaperMotion motion) { return motion == PaperMotion::kCombined ? 10 : 2; }

std::shared_ptr<const SinusoidMotion> MakePaperMotion(PaperMotion motion,
                                                      const Vector6d& home_xyz_rpy, int periods,
                                                      double amplitude_scale) {
  constexpr double kTranslationAmplitude_m = 0.08;               // 8 cm (Sec. 4.2, eq 49)
  constexpr double kRotationAmplitude_rad = 15.0 * kPi / 180.0;  // 15 deg (Sec. 4.2)
  constexpr double kPureFrequency_hz = 0.1;                       // Sec. 4.2
  constexpr double kCombinedFrequency_hz = 1.0;                   // eq 49
  if (periods <= 0) periods = DefaultPeriods(motion);
  if (!std::isfinite(amplitude_scale)) {
    throw std::invalid_argument("MakePaperMotion: amplitude_scale must be finite");
  }
  Vector6d amplitude = Vector6d::Zero();
  Vector6d phase = Vector6d::Zero();
  double frequency_hz = kPureFrequency_hz;
  switch (motion) {
    case PaperMotion::kX: amplitude[0] = kTranslationAmplitude_m; break;
    case PaperMotion::kY: amplitude[1] = kTranslationAmplitude_m; break;
    case PaperMotion::kZ: amplitude[2] = kTranslationAmplitude_m; break;
    case PaperMotion::kRoll: amplitude[3] = kRotationAmplitude_rad; break;
    case PaperMotion::kPitch: amplitude[4] = kRotationAmplitude_rad; break;
    case PaperMotion::kYaw: amplitude[5] = kRotationAmplitude_rad; break;
    case PaperMotion::kCombined:
      // eq 49: x = 8 sin(2 pi t), y = 8 cos(2 pi t) = 8 sin(2 pi t + pi/2), z = 8 sin(2 pi t).
      amplitude.head<3>().setConstant(kTranslationAmplitude_m);
      phase[1] = kPi / 2.0;
      frequency_hz = kCombinedFrequency_hz;
      break;
  }
  return std::make_shared<const SinusoidMotion>(home_xyz_rpy, amplitude * amplitude_scale, phase,
                                                frequency_hz, periods);
}

Trajectory MakePaperTrajectory(PaperMotion motion, const Vector6d& start_xyz_rpy,
                               const Vector6d& home_xyz_rpy, const TrajectoryTiming& timing,
                               int periods, double amplitude_scale) {
  return Trajectory(MakePaperMotion(motion, home_xyz_rpy, periods, amplitude_scale),
                    start_xyz_rpy, home_xyz_rpy, timing);
}

Vector6d HomePoseVector(const Eigen::Vector3d& home_position_m) {
  Vector6d v = Vector6d::Zero();
  v.head<3>() = home_position_m;
  return v;
}

}  // namespace hexa
