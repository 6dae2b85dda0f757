// Classical washout filter (see washout.hpp, docs/motion_stream.md "Motion cueing").
#include "hexa/core/washout.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

const char* const kTranslationNames[3] = {"surge", "sway", "heave"};
const char* const kRotationNames[3] = {"roll", "pitch", "yaw"};

// Exact first-order-hold discretisation of x' = A x + B u, y = C x over `period_s`.
template <int N>
DiscreteChannel<N> Discretise(const Eigen::Matrix<double, N, N>& A,
                              const Eigen::Matrix<double, N, 1>& B,
                              const Eigen::Matrix<double, 1, N>& C, double period_s) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(N + 2, N + 2);
  M.topLeftCorner(N, N) = A * period_s;
  M.block(0, N, N, 1) = B * period_s;
  M(N, N + 1) = 1.0;  // u' = du / T over the period
  const Eigen::MatrixXd E = MatrixExponential(M);
  DiscreteChannel<N> channel;
  channel.Phi = E.topLeftCorner(N, N);
  channel.gamma_u = E.block(0, N, N, 1);
  channel.gamma_du = E.block(0, N + 1, N, 1);
  channel.C = C;
  return channel;
}

template <int N>
double Step(const DiscreteChannel<N>& channel, Eigen::Matrix<double, N, 1>& state, double u_previous,
            double u) {
  state = channel.Phi * state + channel.gamma_u * u_previous + channel.gamma_du * (u - u_previous);
  return channel.C * state;
}

double Saturate(double value, double limit, bool& limited) {
  if (value > limit) {
    limited = true;
    return limit;
  }
  if (value < -limit) {
    limited = true;
    return -limit;
  }
  return value;
}

}  // namespace

Eigen::MatrixXd MatrixExponential(const Eigen::MatrixXd& M) {
  // Scale until the norm is below 1/2, 30 Taylor terms (remainder < 0.5^30 / 30!), square back.
  const double norm = M.cwiseAbs().rowwise().sum().maxCoeff();
  int squarings = 0;
  if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
  const Eigen::MatrixXd S = M / std::ldexp(1.0, squarings);
  Eigen::MatrixXd result = Eigen::MatrixXd::Identity(M.rows(), M.cols());
  Eigen::MatrixXd term = result;
  for (int k = 1; k <= 30; ++k) {
    term = term * S / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

void CheckWashoutConfig(ParamChecker& c, const WashoutConfig& w, const std::string& path) {
  const auto at = [&path](const std::string& field) {
    return path.empty() ? field : path + "." + field;
  };
  c.InClosed(at("period_s"), w.period_s, 0.0005, 0.1, "update period");
  c.InClosed(at("gravity_m_s2"), w.gravity_m_s2, 9.0, 10.0, "gravity");
  for (int i = 0; i < 3; ++i) {
    const std::string p = at(std::string("translation.") + kTranslationNames[i] + ".");
    const WashoutTranslationParams& t = w.translation[i];
    c.InClosed(p + "scale", t.scale, 0.0, 2.0, "scale");
    c.Positive(p + "input_limit_m_s2", t.input_limit_m_s2, "input limit");
    c.Positive(p + "frequency_rad_s", t.frequency_rad_s, "high-pass frequency");
    c.InClosed(p + "damping", t.damping, 0.1, 5.0, "damping");
    c.Positive(p + "break_frequency_rad_s", t.break_frequency_rad_s, "break frequency");
    c.Positive(p + "displacement_limit_m", t.displacement_limit_m, "displacement limit");
    const std::string r = at(std::string("rotation.") + kRotationNames[i] + ".");
    const WashoutRotationParams& o = w.rotation[i];
    c.InClosed(r + "scale", o.scale, 0.0, 2.0, "scale");
    c.Positive(r + "input_limit_rad_s", o.input_limit_rad_s, "input limit");
    c.Positive(r + "frequency_rad_s", o.frequency_rad_s, "high-pass frequency");
    c.InClosed(r + "damping", o.damping, 0.1, 5.0, "damping");
    c.InClosed(r + "angle_limit_rad", o.angle_limit_rad, 1e-4, 0.5, "angle limit");
  }
  c.InClosed(at("tilt.scale"), w.tilt.scale, 0.0, 2.0, "scale");
  c.Positive(at("tilt.frequency_rad_s"), w.tilt.frequency_rad_s, "low-pass frequency");
  c.InClosed(at("tilt.damping"), w.tilt.damping, 0.1, 5.0, "damping");
  c.InClosed(at("tilt.rate_limit_rad_s"), w.tilt.rate_limit_rad_s, 1e-4, 1.0, "tilt rate limit");
  c.InClosed(at("tilt.angle_limit_rad"), w.tilt.angle_limit_rad, 1e-4, 0.5, "tilt angle limit");
}

void WashoutConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckWashoutConfig(c, *this, "washout");
  ThrowIfIssues(issues, "washout");
}

WashoutFilter::WashoutFilter(const WashoutConfig& config) : config_(config) {
  config_.Validate();
  const double T = config_.period_s;
  for (int i = 0; i < 3; ++i) {
    const WashoutTranslationParams& t = config_.translation[i];
    const double wn = t.frequency_rad_s, z = t.damping, wb = t.break_frequency_rad_s;
    // Denominator (s^2 + 2 z wn s + wn^2)(s + wb) = s^3 + a2 s^2 + a1 s + a0, numerator s:
    // controllable canonical form, y = x2.
    const double a2 = 2 * z * wn + wb, a1 = wn * wn + 2 * z * wn * wb, a0 = wn * wn * wb;
    Eigen::Matrix3d A;
    A << 0, 1, 0, 0, 0, 1, -a0, -a1, -a2;
    translation_[i] = Discretise<3>(A, Eigen::Vector3d(0, 0, 1), Eigen::RowVector3d(0, 1, 0), T);
    const WashoutRotationParams& o = config_.rotation[i];
    Eigen::Matrix2d Ar;
    Ar << 0, 1, -o.frequency_rad_s * o.frequency_rad_s, -2 * o.damping * o.frequency_rad_s;
    rotation_[i] = Discretise<2>(Ar, Eigen::Vector2d(0, 1), Eigen::RowVector2d(0, 1), T);
  }
  const double wt = config_.tilt.frequency_rad_s;
  Eigen::Matrix2d At;
  At << 0, 1, -wt * wt, -2 * config_.tilt.damping * wt;
  tilt_ = Discretise<2>(At, Eigen::Vector2d(0, 1), Eigen::RowVector2d(wt * wt, 0), T);
  Reset();
}

void WashoutFilter::Reset() noexcept {
  for (auto& s : translation_state_) s.setZero();
  for (auto& s : rotation_state_) s.setZero();
  for (auto& s : tilt_state_) s.setZero();
  previous_acceleration_.setZero();
  previous_rate_.setZero();
  previous_tilt_input_.setZero();
  tilt_rad_.setZero();
  first_ = true;
}

void WashoutFilter::Update(const WashoutInput& input, WashoutOutput& output) noexcept {
  output = WashoutOutput{};
  const double T = config_.period_s;
  // A non-finite sample is treated as zero motion; the stream decoder refuses such packets
  // before they get here.
  const Eigen::Vector3d raw_a = input.acceleration_m_s2.allFinite() ? input.acceleration_m_s2
                                                                    : Eigen::Vector3d::Zero();
  Eigen::Vector3d a = raw_a;
  Eigen::Vector3d w = input.angular_rate_rad_s.allFinite() ? input.angular_rate_rad_s
                                                           : Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    a[i] = Saturate(config_.translation[i].scale * a[i], config_.translation[i].input_limit_m_s2,
                    output.input_limited);
    w[i] = Saturate(config_.rotation[i].scale * w[i], config_.rotation[i].input_limit_rad_s,
                    output.input_limited);
  }
  // Tilt input: sway -> roll (+), surge -> pitch (-), as angles (small angles: g theta = a).
  const double g = config_.gravity_m_s2, k = config_.tilt.scale;
  const Eigen::Vector2d tilt_in(k * raw_a.y() / g, -k * raw_a.x() / g);
  if (first_) {
    // The first sample starts the input's first-order hold: the state is that of this instant.
    previous_acceleration_ = a;
    previous_rate_ = w;
    previous_tilt_input_ = tilt_in;
    first_ = false;
    return;
  }
  for (int i = 0; i < 3; ++i) {
    output.translation_m[i] =
        Step<3>(translation_[i], translation_state_[i], previous_acceleration_[i], a[i]);
    output.rotation_rad[i] = Step<2>(rotation_[i], rotation_state_[i], previous_rate_[i], w[i]);
  }
  const double max_step = config_.tilt.rate_limit_rad_s * T;
  for (int j = 0; j < 2; ++j) {
    const double low_passed = Step<2>(tilt_, tilt_state_[j], previous_tilt_input_[j], tilt_in[j]);
    const double target = std::clamp(low_passed, -config_.tilt.angle_limit_rad,
                                     config_.tilt.angle_limit_rad);
    const double step = std::clamp(target - tilt_rad_[j], -max_step, max_step);
    if (step != target - tilt_rad_[j]) output.tilt_rate_limited = true;
    tilt_rad_[j] += step;
    output.tilt_rate_rad_s[j] = step / T;
  }
  previous_acceleration_ = a;
  previous_rate_ = w;
  previous_tilt_input_ = tilt_in;
  output.tilt_rad = tilt_rad_;
  for (int i = 0; i < 3; ++i) {
    output.displacement[i] = Saturate(output.translation_m[i],
                                      config_.translation[i].displacement_limit_m,
                                      output.output_limited);
  }
  const Eigen::Vector3d angles(output.rotation_rad[0] + tilt_rad_[0],
                               output.rotation_rad[1] + tilt_rad_[1], output.rotation_rad[2]);
  for (int i = 0; i < 3; ++i) {
    output.displacement[3 + i] =
        Saturate(angles[i], config_.rotation[i].angle_limit_rad, output.output_limited);
  }
}

WashoutInput BrakingExample(double t_s) {
  WashoutInput in;
  const double onset = std::clamp((t_s - 1.0) / 0.5, 0.0, 1.0);
  const double release = std::clamp((t_s - 3.8) / 0.5, 0.0, 1.0);
  in.acceleration_m_s2.x() = -6.0 * (onset - release);
  return in;
}

WashoutInput LaneChangeExample(double t_s) {
  WashoutInput in;
  const double tau = t_s - 1.0;
  if (tau > 0.0 && tau < 4.0) {
    in.acceleration_m_s2.y() = 1.5 * std::sin(2.0 * 3.14159265358979323846 * tau / 4.0);
    in.angular_rate_rad_s.z() = in.acceleration_m_s2.y() / 20.0;
  }
  return in;
}

}  // namespace hexa
