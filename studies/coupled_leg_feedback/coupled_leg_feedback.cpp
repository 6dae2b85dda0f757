#include "coupled_leg_feedback.hpp"

#include <Eigen/Cholesky>

#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "hexa/core/coupled_legs.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/platform_dynamics.hpp"

namespace hexa::study {

void CoupledLegFeedbackParams::Validate() const {
  if (!(reference_mass_kg >= 0.0 && reference_mass_kg < 1000.0)) {
    throw std::invalid_argument("CoupledLegFeedbackParams.reference_mass_kg = " +
                                std::to_string(reference_mass_kg) +
                                " kg: must be in [0, 1000) (0: the BS-SMC's effective mass)");
  }
}

namespace {

class CoupledLegRunner final : public LegRunner {
 public:
  CoupledLegRunner(const CoupledLegFeedbackParams& params, const Supervisor& supervisor,
                   const LegArray<std::unique_ptr<LegController>>& legs)
      : params_(params), rig_(supervisor.rig()) {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      mass_kg_[i] = params_.reference_mass_kg > 0.0 ? params_.reference_mass_kg
                                                    : legs[i]->config().params.bssmc.effective_mass_kg;
    }
    Pose home;
    home.p_BP_B_m = rig_.geometry.home_position_m;
    home.R_BP.setIdentity();
    UpdateCoupling(home);
  }

  void Run(const SupervisorOutput* supervisor_output, LegArray<std::unique_ptr<LegController>>& legs,
           const LegArray<LegControllerInput>& in, LegArray<LegControllerOutput>& out) override {
    if (supervisor_output != nullptr && supervisor_output->estimate.status == KinStatus::kOk)
      UpdateCoupling(supervisor_output->estimate.pose);
    // Two passes: every leg's own feedback part, then each running BS-SMC completes with
    // sum_j W_ij f_j over the legs that run it (a holding leg contributes nothing).
    // The observers see the legs' accelerations on the coupled platform: m_obs (M_ls^-1 F)_i.
    Vector6d force_n;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const NominalLegModel& m = legs[i]->config().model;
      force_n[static_cast<int>(i)] = in[i].cap_pressure_pa * m.cylinder.cap_area_m2 -
                                     in[i].rod_pressure_pa * m.cylinder.annulus_area_m2 -
                                     m.air.atmosphere_pressure_pa * m.cylinder.rod_area_m2;
    }
    const Vector6d acceleration_m_s2 = inverse_mass_ * force_n;
    LegArray<std::optional<BsSmcFeedback>> own{};
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double m_obs = legs[i]->config().params.bssmc.observer_mass_kg;
      own[i] = legs[i]->BeginCoupled(in[i], out[i], m_obs * acceleration_m_s2[static_cast<int>(i)],
                                     params_.observer_velocity);
    }
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      if (!own[i]) continue;
      BsSmcFeedback mixed;
      for (std::size_t j = 0; j < kNumLegs; ++j) {
        if (!own[j]) continue;
        const double w = coupling_(static_cast<int>(i), static_cast<int>(j));
        mixed.force_n += w * own[j]->force_n;
        mixed.rate_n_s += w * own[j]->rate_n_s;
      }
      legs[i]->FinishCoupled(mixed, out[i]);
    }
  }

 private:
  void UpdateCoupling(const Pose& pose) {
    Matrix6d m_ls;
    if (LegSpaceMassMatrix(rig_.geometry, PlatformInertialParams::FromRig(rig_), pose, m_ls) !=
        KinStatus::kOk) {
      return;  // keep the last matrix
    }
    coupling_ = CouplingMatrix(m_ls, mass_kg_, params_.raise_only);
    inverse_mass_ = m_ls.ldlt().solve(Matrix6d::Identity());
  }

  CoupledLegFeedbackParams params_;
  RigParams rig_;  // the supervisor's
  LegArray<double> mass_kg_{};
  Matrix6d coupling_ = Matrix6d::Identity();       // W
  Matrix6d inverse_mass_ = Matrix6d::Identity();   // M_ls^-1 (the observers' force)
};

class PoseCouplingRowRunner final : public LegRunner {
 public:
  PoseCouplingRowRunner(CouplingPose pose, const Supervisor& supervisor,
                        const LegArray<std::unique_ptr<LegController>>& legs)
      : pose_(pose), rig_(supervisor.rig()), params_(legs[0]->config().params.coupled) {
    for (std::size_t i = 0; i < kNumLegs; ++i)
      mass_kg_[i] = legs[i]->config().params.bssmc.effective_mass_kg;
    if (params_.cutoff_hz > 0.0)
      alpha_ = 1.0 - std::exp(-2.0 * 3.14159265358979323846 * params_.cutoff_hz * legs[0]->config().period_s);
    Pose home;
    home.p_BP_B_m = rig_.geometry.home_position_m;
    home.R_BP.setIdentity();
    SetW(home);
    LegJacobian(rig_.geometry, home, j_);
  }

  // What the coupling adds at the platform over the tracking window: the RMS of the wrench
  // J(q)^T of the applied increments and of the legs' own feedback parts (q: the pose estimate).
  ~PoseCouplingRowRunner() override {
    if (n_ == 0) return;
    const double n = static_cast<double>(n_);
    std::fprintf(stderr, "coupling wrench RMS over %ld tracking ticks (x y z N, roll pitch yaw N m): "
                 "increment %.2f %.2f %.2f %.3f %.3f %.3f; own parts %.2f %.2f %.2f %.3f %.3f %.3f\n",
                 n_, std::sqrt(sq_inc_[0] / n), std::sqrt(sq_inc_[1] / n), std::sqrt(sq_inc_[2] / n),
                 std::sqrt(sq_inc_[3] / n), std::sqrt(sq_inc_[4] / n), std::sqrt(sq_inc_[5] / n),
                 std::sqrt(sq_own_[0] / n), std::sqrt(sq_own_[1] / n), std::sqrt(sq_own_[2] / n),
                 std::sqrt(sq_own_[3] / n), std::sqrt(sq_own_[4] / n), std::sqrt(sq_own_[5] / n));
  }

  void Run(const SupervisorOutput* supervisor_output, LegArray<std::unique_ptr<LegController>>& legs,
           const LegArray<LegControllerInput>& in, LegArray<LegControllerOutput>& out) override {
    if (supervisor_output != nullptr) {
      tracking_ = supervisor_output->state == SupervisorState::kTracking;
      if (supervisor_output->estimate.status == KinStatus::kOk)
        LegJacobian(rig_.geometry, supervisor_output->estimate.pose, j_);
      if (pose_ == CouplingPose::kDesired) SetW(supervisor_output->desired.pose);
      if (pose_ == CouplingPose::kEstimate && supervisor_output->estimate.status == KinStatus::kOk)
        SetW(supervisor_output->estimate.pose);
    }
    // CoupledFeedbackMix::Apply (coupled_legs.cpp) with this runner's W.
    Vector6d increment_n = Vector6d::Zero(), own_n = Vector6d::Zero();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      out[i].feedback = FeedbackPart{};
      out[i].coupled = false;
      const std::optional<BsSmcFeedback> own = legs[i]->BeginCoupled(in[i], out[i]);
      if (!own) {
        lpf_[i] = BsSmcFeedback{};
        continue;
      }
      const RelayedFeedback& relay = in[i].relayed;
      BsSmcFeedback applied = *own;
      if (in[i].tick != 0 && relay.AllValid() && relay.tick + 1 == in[i].tick) {
        double force_n = -relay.parts[i].force_n, rate_n_s = -relay.parts[i].rate_n_s;
        for (std::size_t j = 0; j < kNumLegs; ++j) {
          force_n += w_(static_cast<int>(i), static_cast<int>(j)) * relay.parts[j].force_n;
          rate_n_s += w_(static_cast<int>(i), static_cast<int>(j)) * relay.parts[j].rate_n_s;
        }
        lpf_[i].force_n += alpha_ * (force_n - lpf_[i].force_n);
        lpf_[i].rate_n_s += alpha_ * (rate_n_s - lpf_[i].rate_n_s);
        applied.force_n += params_.gain * lpf_[i].force_n;
        increment_n[static_cast<int>(i)] = params_.gain * lpf_[i].force_n;
        applied.rate_n_s += params_.gain * lpf_[i].rate_n_s;
        out[i].coupled = true;
      } else {
        lpf_[i] = BsSmcFeedback{};
      }
      own_n[static_cast<int>(i)] = own->force_n;
      legs[i]->FinishCoupled(applied, out[i]);
      out[i].feedback = FeedbackPart{std::isfinite(own->force_n) && std::isfinite(own->rate_n_s),
                                     own->force_n, own->rate_n_s};
    }
    if (tracking_) {
      const Vector6d inc = j_.transpose() * increment_n, own = j_.transpose() * own_n;
      for (int k = 0; k < 6; ++k) {
        sq_inc_[static_cast<std::size_t>(k)] += inc[k] * inc[k];
        sq_own_[static_cast<std::size_t>(k)] += own[k] * own[k];
      }
      ++n_;
    }
  }

 private:
  void SetW(const Pose& pose) {
    Matrix6d m_ls;
    if (LegSpaceMassMatrix(rig_.geometry, PlatformInertialParams::FromRig(rig_), pose, m_ls) == KinStatus::kOk)
      w_ = CouplingMatrix(m_ls, mass_kg_, params_.raise_only);
  }

  CouplingPose pose_;
  RigParams rig_;  // the supervisor's
  CoupledLegsParams params_;
  LegArray<double> mass_kg_{};
  double alpha_ = 1.0;
  Matrix6d w_ = Matrix6d::Identity();
  LegArray<BsSmcFeedback> lpf_{};  // low-passed increments
  Matrix6d j_ = Matrix6d::Identity();  // J at the pose estimate
  bool tracking_ = false;
  long n_ = 0;
  std::array<double, 6> sq_inc_{}, sq_own_{};
};

}  // namespace

LegRunnerFactory PoseCouplingRowRunnerFactory(CouplingPose pose) {
  return [pose](const Supervisor& supervisor, const LegArray<std::unique_ptr<LegController>>& legs) {
    return std::make_unique<PoseCouplingRowRunner>(pose, supervisor, legs);
  };
}

LegRunnerFactory CoupledLegRunnerFactory(const CoupledLegFeedbackParams& params) {
  params.Validate();
  if (!params.enabled) return {};
  return [params](const Supervisor& supervisor, const LegArray<std::unique_ptr<LegController>>& legs) {
    return std::make_unique<CoupledLegRunner>(params, supervisor, legs);
  };
}

}  // namespace hexa::study
