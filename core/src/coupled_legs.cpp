#include "hexa/core/coupled_legs.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <stdexcept>
#include <string>

#include "hexa/core/math_constants.hpp"
#include "hexa/core/platform_dynamics.hpp"

namespace hexa {

bool RelayedFeedback::AllValid() const {
  if (!present) return false;
  for (const FeedbackPart& p : parts)
    if (!p.valid) return false;
  return true;
}

Matrix6d CouplingMatrix(const Matrix6d& m_ls, const LegArray<double>& mass_kg, bool raise_only) {
  Matrix6d w;
  if (!raise_only) {
    for (std::size_t i = 0; i < kNumLegs; ++i)
      w.row(static_cast<int>(i)) = m_ls.row(static_cast<int>(i)) / mass_kg[i];
    return w;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(m_ls);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const Vector6d raised = eig.eigenvalues().cwiseMax(mass_kg[i]);
    const Matrix6d shaped = eig.eigenvectors() * raised.asDiagonal() * eig.eigenvectors().transpose();
    w.row(static_cast<int>(i)) = shaped.row(static_cast<int>(i)) / mass_kg[i];
  }
  return w;
}

LegArray<double> CouplingRowAtHome(const RigParams& rig, std::size_t leg_index, double mass_kg,
                                   bool raise_only) {
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  home.R_BP.setIdentity();
  Matrix6d m_ls;
  if (leg_index >= kNumLegs || !(mass_kg > 0.0) ||
      LegSpaceMassMatrix(rig.geometry, PlatformInertialParams::FromRig(rig), home, m_ls) != KinStatus::kOk) {
    throw std::invalid_argument("coupled leg feedback: no leg-space mass matrix at the home pose "
                                "for leg index " + std::to_string(leg_index) + ", mass " +
                                std::to_string(mass_kg) + " kg");
  }
  LegArray<double> mass{};
  mass.fill(mass_kg);
  const Matrix6d w = CouplingMatrix(m_ls, mass, raise_only);
  LegArray<double> row{};
  for (std::size_t j = 0; j < kNumLegs; ++j) row[j] = w(static_cast<int>(leg_index), static_cast<int>(j));
  return row;
}

CoupledFeedbackMix::CoupledFeedbackMix(const CoupledLegsParams& params, const LegArray<double>& row,
                                       std::size_t leg_index, double period_s)
    : params_(params), row_(row), leg_(leg_index) {
  // Exact discretisation of the first-order low-pass at the control period.
  if (params_.cutoff_hz > 0.0) alpha_ = 1.0 - std::exp(-2.0 * kPi * params_.cutoff_hz * period_s);
}

void CoupledFeedbackMix::Reset() {
  force_n_ = 0.0;
  rate_n_s_ = 0.0;
}

bool CoupledFeedbackMix::Apply(const BsSmcFeedback& own, std::uint64_t own_tick,
                               const RelayedFeedback& relay, BsSmcFeedback& applied) {
  applied = own;
  if (!params_.enabled || own_tick == 0 || !relay.AllValid() || relay.tick + 1 != own_tick) {
    Reset();
    return false;
  }
  // Every part of the increment from the same tick n - 1, this leg's own included: on a
  // motion that is a mode of W the increment is then (lambda_k - 1) f(n - 1), with no
  // (W_ii - 1) (f_i(n) - f_i(n - 1)) term that would differentiate this leg's noise.
  double force_n = -relay.parts[leg_].force_n;
  double rate_n_s = -relay.parts[leg_].rate_n_s;
  for (std::size_t j = 0; j < kNumLegs; ++j) {
    force_n += row_[j] * relay.parts[j].force_n;
    rate_n_s += row_[j] * relay.parts[j].rate_n_s;
  }
  if (!std::isfinite(force_n) || !std::isfinite(rate_n_s)) {
    Reset();
    return false;
  }
  force_n_ += alpha_ * (force_n - force_n_);
  rate_n_s_ += alpha_ * (rate_n_s - rate_n_s_);
  applied.force_n = own.force_n + params_.gain * force_n_;
  applied.rate_n_s = own.rate_n_s + params_.gain * rate_n_s_;
  return true;
}

void FeedbackRelay::Offer(int leg, std::uint64_t answered_tick, const FeedbackPart& part) {
  if (leg < 1 || leg > static_cast<int>(kNumLegs)) return;
  const std::size_t i = static_cast<std::size_t>(leg - 1);
  offered_[i] = true;
  answered_tick_[i] = answered_tick;
  parts_[i] = part;
}

RelayedFeedback FeedbackRelay::For(std::uint64_t tick, const LegArray<bool>& forced) const {
  RelayedFeedback r;
  r.present = true;
  r.tick = tick;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    r.parts[i] = parts_[i];
    r.parts[i].valid = parts_[i].valid && offered_[i] && answered_tick_[i] == tick && !forced[i];
  }
  return r;
}

}  // namespace hexa
