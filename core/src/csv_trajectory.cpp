// User trajectory rows (see csv_trajectory.hpp): clamped cubic spline.
#include "hexa/core/csv_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hexa {
namespace {

// Thomas algorithm for the clamped spline moments (diagonally dominant, no pivoting).
std::vector<Vector6d> ClampedSplineMoments(const std::vector<double>& t,
                                           const std::vector<Vector6d>& y) {
  const std::size_t n = t.size();
  std::vector<double> lower(n, 0.0), diag(n, 0.0), upper(n, 0.0);
  std::vector<Vector6d> rhs(n, Vector6d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0) {
      const double h = t[1] - t[0];
      diag[i] = 2.0 * h;
      upper[i] = h;
      rhs[i] = 6.0 * ((y[1] - y[0]) / h);  // f'(t_0) = 0
    } else if (i == n - 1) {
      const double h = t[i] - t[i - 1];
      lower[i] = h;
      diag[i] = 2.0 * h;
      rhs[i] = -6.0 * ((y[i] - y[i - 1]) / h);  // f'(t_n) = 0
    } else {
      const double h0 = t[i] - t[i - 1], h1 = t[i + 1] - t[i];
      lower[i] = h0;
      diag[i] = 2.0 * (h0 + h1);
      upper[i] = h1;
      rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
    }
  }
  for (std::size_t i = 1; i < n; ++i) {
    const double m = lower[i] / diag[i - 1];
    diag[i] -= m * upper[i - 1];
    rhs[i] -= m * rhs[i - 1];
  }
  std::vector<Vector6d> moments(n, Vector6d::Zero());
  moments[n - 1] = rhs[n - 1] / diag[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) {
    moments[i] = (rhs[i] - upper[i] * moments[i + 1]) / diag[i];
  }
  return moments;
}

}  // namespace

CsvMotion::CsvMotion(std::vector<double> time_s, std::vector<Vector6d> xyz_rpy)
    : time_s_(std::move(time_s)), q_(std::move(xyz_rpy)) {
  if (time_s_.size() < 2 || time_s_.size() != q_.size()) {
    throw std::invalid_argument("CsvMotion: need at least two rows of equal count");
  }
  for (std::size_t i = 0; i < time_s_.size(); ++i) {
    if (!std::isfinite(time_s_[i]) || !q_[i].allFinite()) {
      throw std::invalid_argument("CsvMotion: row " + std::to_string(i) + " is not finite");
    }
  }
  for (std::size_t i = 1; i < time_s_.size(); ++i) {
    if (!(time_s_[i] > time_s_[i - 1])) {
      throw std::invalid_argument("CsvMotion: times must be strictly increasing");
    }
  }
  second_derivative_ = ClampedSplineMoments(time_s_, q_);
}

void CsvMotion::Evaluate(double tau_s, PoseVectorState& state) const noexcept {
  if (tau_s <= time_s_.front() || tau_s >= time_s_.back()) {
    state.q = tau_s <= time_s_.front() ? q_.front() : q_.back();
    state.q_dot.setZero();  // clamped ends: the spline arrives at rest
    state.q_ddot.setZero();
    return;
  }
  // Segment i with t_i <= tau < t_{i+1}; upper_bound is a binary search, no allocation.
  const auto it = std::upper_bound(time_s_.begin(), time_s_.end(), tau_s);
  const std::size_t i = static_cast<std::size_t>(it - time_s_.begin()) - 1;
  const double h = time_s_[i + 1] - time_s_[i];
  const double a = (time_s_[i + 1] - tau_s) / h;
  const double b = 1.0 - a;
  const Vector6d& m0 = second_derivative_[i];
  const Vector6d& m1 = second_derivative_[i + 1];
  state.q = a * q_[i] + b * q_[i + 1] + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * (h * h / 6.0);
  state.q_dot = (q_[i + 1] - q_[i]) / h - ((3.0 * a * a - 1.0) * h / 6.0) * m0 +
                ((3.0 * b * b - 1.0) * h / 6.0) * m1;
  state.q_ddot = a * m0 + b * m1;
}

Trajectory MakeCsvTrajectory(std::shared_ptr<const CsvMotion> motion,
                             const Vector6d& start_xyz_rpy, const Vector6d& rest_xyz_rpy,
                             const TrajectoryTiming& timing) {
  return Trajectory(std::move(motion), start_xyz_rpy, rest_xyz_rpy, timing);
}

}  // namespace hexa
