// Classical washout filter for motion cueing (docs/motion_stream.md "Motion cueing"): vehicle
// accelerations and angular rates -> a displacement of the pivot frame from neutral,
// [x y z roll pitch yaw] (m, rad, work-frame axes; user_frames.hpp applies it).
//
// Vehicle frame = work frame: x forward, y left, z up. Inputs: the vehicle's acceleration a
// (without gravity, m/s^2) and angular rate w (rad/s), both in the vehicle frame.
//   translational channel, each axis:  u = sat(k a, a_lim)
//       x(s) / u(s) = s / ((s^2 + 2 zeta wn s + wn^2)(s + wb))
//     = (1/s^2) * third-order high-pass s^3 / ((s^2 + 2 zeta wn s + wn^2)(s + wb)):
//     a sustained acceleration gives a displacement that returns to zero;
//   rotational channel, each axis:     u = sat(k w, w_lim)
//       theta(s) / u(s) = s / (s^2 + 2 zeta wn s + wn^2)   (second-order high-pass, then 1/s);
//   tilt coordination (surge -> pitch, sway -> roll):
//       y(s) / a(s) = k wn^2 / (s^2 + 2 zeta wn s + wn^2) / g,
//       pitch_tilt = -y_x, roll_tilt = +y_y (small angles: the tilted gravity g sin(theta) ~
//       g theta is felt as the sustained acceleration), then rate-limited:
//       |tilt_k - tilt_k-1| <= r_max T (the tilt must stay below the rotation threshold);
//   output: roll = theta_x + roll_tilt, pitch = theta_y + pitch_tilt, yaw = theta_z,
//       each component clamped to its limit.
// Discretisation: exact for inputs linear between samples (first-order hold; the state
// transition of the augmented system [x; u; du] computed once by the matrix exponential). So
// step and ramp responses equal the continuous filter's at every sample to rounding
// (tests/operate/washout_test.cpp compares them with the partial-fraction solution).
// The first Update only records its input (the output is the state at that sample: neutral).
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "hexa/core/param_checks.hpp"
#include "hexa/core/pose.hpp"

namespace hexa {

// Defaults: sized for the reference rig's +-8 cm (a 1.8 m/s^2 scaled step peaks near
// a / wn^2 = 72 mm; docs/operate.md's worked examples give the measured peaks).
struct WashoutTranslationParams {
  double scale = 0.3;                   // k
  double input_limit_m_s2 = 3.0;        // a_lim, after scaling
  double frequency_rad_s = 5.0;         // wn of the second-order high-pass
  double damping = 1.0;                 // zeta
  double break_frequency_rad_s = 1.0;   // wb of the first-order high-pass
  double displacement_limit_m = 0.08;
};

struct WashoutRotationParams {
  double scale = 0.5;
  double input_limit_rad_s = 1.0;
  double frequency_rad_s = 1.0;
  double damping = 1.0;
  double angle_limit_rad = 0.2;
};

struct WashoutTiltParams {
  double scale = 0.5;                   // of the acceleration fed to the tilt
  double frequency_rad_s = 3.0;         // wn of the low-pass
  double damping = 1.0;
  double rate_limit_rad_s = 0.0524;     // 3 deg/s: below the semicircular canals' threshold
  double angle_limit_rad = 0.17;        // 10 deg: about 0.17 g of sustained cue
};

struct WashoutConfig {
  double period_s = 0.005;              // Update period (the supervisor's)
  double gravity_m_s2 = 9.81;
  std::array<WashoutTranslationParams, 3> translation{};  // surge, sway, heave
  std::array<WashoutRotationParams, 3> rotation{};        // roll, pitch, yaw
  WashoutTiltParams tilt;
  // Throws std::invalid_argument naming field ("washout.translation.surge.damping"), value
  // and limit: non-finite, non-positive frequencies and scales, damping outside [0.1, 5],
  // period outside [0.0005, 0.1] s, limits <= 0.
  void Validate() const;
};
// The rules of Validate(), as issues on fields under `path` ("washout" -> "washout.tilt.scale";
// "" -> "tilt.scale", the field paths of the parameter file, config/ washout_file.hpp).
void CheckWashoutConfig(ParamChecker& c, const WashoutConfig& config, const std::string& path);

struct WashoutInput {
  Eigen::Vector3d acceleration_m_s2 = Eigen::Vector3d::Zero();  // vehicle frame, no gravity
  Eigen::Vector3d angular_rate_rad_s = Eigen::Vector3d::Zero();
};

struct WashoutOutput {
  Vector6d displacement = Vector6d::Zero();       // [x y z roll pitch yaw], limited
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();  // channels before the clamp
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();   // high-pass rotational part
  Eigen::Vector2d tilt_rad = Eigen::Vector2d::Zero();       // roll, pitch from tilt (limited)
  Eigen::Vector2d tilt_rate_rad_s = Eigen::Vector2d::Zero();
  bool tilt_rate_limited = false;
  bool input_limited = false;
  bool output_limited = false;
};

// x_{k+1} = Phi x_k + Gamma_u u_k + Gamma_du (u_{k+1} - u_k), y = C x: a SISO channel of the
// filter discretised exactly for a first-order-hold input.
template <int N>
struct DiscreteChannel {
  Eigen::Matrix<double, N, N> Phi = Eigen::Matrix<double, N, N>::Identity();
  Eigen::Matrix<double, N, 1> gamma_u = Eigen::Matrix<double, N, 1>::Zero();
  Eigen::Matrix<double, N, 1> gamma_du = Eigen::Matrix<double, N, 1>::Zero();
  Eigen::Matrix<double, 1, N> C = Eigen::Matrix<double, 1, N>::Zero();
};

class WashoutFilter {
 public:
  explicit WashoutFilter(const WashoutConfig& config);  // throws on an invalid config
  // One period. Neither throws nor allocates.
  void Update(const WashoutInput& input, WashoutOutput& output) noexcept;
  // Back to neutral (all states and the held input zero; the next Update is a first one).
  void Reset() noexcept;
  const WashoutConfig& config() const { return config_; }

 private:
  WashoutConfig config_;
  std::array<DiscreteChannel<3>, 3> translation_;
  std::array<DiscreteChannel<2>, 3> rotation_;
  DiscreteChannel<2> tilt_;  // same filter for surge and sway
  std::array<Eigen::Vector3d, 3> translation_state_{};
  std::array<Eigen::Vector2d, 3> rotation_state_{};
  std::array<Eigen::Vector2d, 2> tilt_state_{};  // 0: sway -> roll, 1: surge -> pitch
  Eigen::Vector3d previous_acceleration_ = Eigen::Vector3d::Zero();  // after scale and limit
  Eigen::Vector3d previous_rate_ = Eigen::Vector3d::Zero();
  Eigen::Vector2d previous_tilt_input_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d tilt_rad_ = Eigen::Vector2d::Zero();
  bool first_ = true;
};

// The worked examples of docs/operate.md, as vehicle motion at time t (s):
//   braking: 60 km/h to standstill at 6 m/s^2: onset ramp 1.0-1.5 s, full braking to 3.8 s,
//            release ramp to 4.3 s (12 m/s^3 both), then standing still;
//   lane change: at 20 m/s, a_y = 1.5 sin(2 pi (t - 1) / 4) m/s^2 for one period from t = 1 s
//            (3.8 m sideways: A T^2 / (2 pi)), yaw rate a_y / 20 m/s.
WashoutInput BrakingExample(double t_s);
WashoutInput LaneChangeExample(double t_s);

// exp(M) of a small square matrix (scaling and squaring of the Taylor series; relative error
// ~1e-15 for the filter's matrices). Used once per channel at construction.
Eigen::MatrixXd MatrixExponential(const Eigen::MatrixXd& M);

}  // namespace hexa
