#include "hexa/core/leg_observer.hpp"

#include "hexa/core/param_checks.hpp"

#include <cmath>
#include <vector>

namespace hexa {

void LegObserverConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.Positive("period_s", period_s, "observer period");
  c.Positive("mass_kg", mass_kg, "observer mass");
  c.Positive("length_sigma_m", length_sigma_m, "position noise");
  c.NonNegative("force_sigma_n", force_sigma_n, "force noise");
  c.Positive("disturbance_rate_m_s3", disturbance_rate_m_s3, "disturbance random walk");
  ThrowIfIssues(issues, "LegObserverConfig");
}

LegObserver::LegObserver(const LegObserverConfig& config) : config_((config.Validate(), config)) {
  const double h = config_.period_s;
  // Exact discretisation of x' = v, v' = u + d, d' = 0 over one period (u, d constant).
  a_ << 1.0, h, 0.5 * h * h,
        0.0, 1.0, h,
        0.0, 0.0, 1.0;
  b_ << 0.5 * h * h, h, 0.0;
  // Process noise: the force noise enters as an input disturbance (b sigma_u^2 b^T), the
  // disturbance's random walk as a continuous white noise integrated over the period.
  const double su = config_.force_sigma_n / config_.mass_kg;
  const double qd = config_.disturbance_rate_m_s3 * config_.disturbance_rate_m_s3;
  Eigen::Matrix3d q = b_ * b_.transpose() * su * su;
  Eigen::Matrix3d qc = Eigen::Matrix3d::Zero();
  // integral over [0, h] of g(t) g(t)^T qd, g(t) = [t^2/2, t, 1] (d's noise through the chain)
  qc(0, 0) = h * h * h * h * h / 20.0;
  qc(0, 1) = qc(1, 0) = h * h * h * h / 8.0;
  qc(0, 2) = qc(2, 0) = h * h * h / 6.0;
  qc(1, 1) = h * h * h / 3.0;
  qc(1, 2) = qc(2, 1) = h * h / 2.0;
  qc(2, 2) = h;
  q += qd * qc;
  const double r = config_.length_sigma_m * config_.length_sigma_m;
  // Steady-state gain: iterate the Riccati recursion (prior covariance) to convergence.
  Eigen::Matrix3d p = Eigen::Matrix3d::Identity();
  for (int it = 0; it < 100000; ++it) {
    const double s = p(0, 0) + r;
    const Eigen::Vector3d k = p.col(0) / s;
    const Eigen::Matrix3d post = p - k * p.row(0);
    const Eigen::Matrix3d next = a_ * post * a_.transpose() + q;
    const double change = (next - p).cwiseAbs().maxCoeff();
    p = next;
    gain_ = k;
    if (change <= 1e-14 * p.cwiseAbs().maxCoeff()) break;
  }
  gain_ = p.col(0) / (p(0, 0) + r);
}

void LegObserver::Reset() {
  q_.setZero();
  previous_input_m_s2_ = 0.0;
  acceleration_m_s2_ = 0.0;
  primed_ = false;
}

void LegObserver::Update(double position_m, double pneumatic_force_n) {
  const double u = pneumatic_force_n / config_.mass_kg;
  if (!primed_) {
    q_ << position_m, 0.0, 0.0;
    primed_ = std::isfinite(position_m);
  } else {
    const Eigen::Vector3d prior = a_ * q_ + b_ * previous_input_m_s2_;
    q_ = prior + gain_ * (position_m - prior[0]);
  }
  previous_input_m_s2_ = std::isfinite(u) ? u : 0.0;
  acceleration_m_s2_ = previous_input_m_s2_ + q_[2];
  if (!q_.allFinite()) Reset();
}

}  // namespace hexa
