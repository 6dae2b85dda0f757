#include "coupled_leg_feedback.hpp"

#include <Eigen/Cholesky>

#include <optional>
#include <stdexcept>
#include <string>

#include "hexa/core/coupled_legs.hpp"
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

}  // namespace

LegRunnerFactory CoupledLegRunnerFactory(const CoupledLegFeedbackParams& params) {
  params.Validate();
  if (!params.enabled) return {};
  return [params](const Supervisor& supervisor, const LegArray<std::unique_ptr<LegController>>& legs) {
    return std::make_unique<CoupledLegRunner>(params, supervisor, legs);
  };
}

}  // namespace hexa::study
