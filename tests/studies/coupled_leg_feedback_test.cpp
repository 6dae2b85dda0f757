// The coupled leg feedback study (studies/coupled_leg_feedback) through the lockstep
// simulation's leg-runner hook: the figures of two paper sessions pinned to their known values
// (to 1e-12 relative: any change of the study's arithmetic shows), and the hook with the
// system's runner equal, to the bit, to no hook.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "coupled_leg_feedback.hpp"
#include "hexa/core/lockstep_simulation.hpp"

namespace {

struct Pinned {
  std::array<double, 6> rmse_vs_truth;  // m, rad
  std::array<double, 6> leg_rmse_m;
};

void ExpectPinned(const hexa::PaperSessionResult& r, const Pinned& pinned) {
  ASSERT_TRUE(r.completed);
  EXPECT_EQ(r.ticks, 23006u);
  const auto e = r.metrics.vs_truth.Rmse();
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(e[k], pinned.rmse_vs_truth[static_cast<std::size_t>(k)],
                1e-12 * pinned.rmse_vs_truth[static_cast<std::size_t>(k)])
        << "axis " << k;
  }
  for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
    EXPECT_NEAR(r.metrics.leg_length[i].Rmse(), pinned.leg_rmse_m[i], 1e-12 * pinned.leg_rmse_m[i])
        << "leg " << i + 1;
  }
}

TEST(CoupledLegFeedback, TrajectoryXKeepsItsFigures) {
  hexa::LockstepConfig config;
  hexa::study::CoupledLegFeedbackParams coupled;
  coupled.enabled = true;
  config.leg_runner = hexa::study::CoupledLegRunnerFactory(coupled);
  ExpectPinned(hexa::RunPaperSession(config, hexa::PaperMotion::kX),
               {{0.002767367091443128, 0.0028256897293196595, 0.0011045172330513165,
                 0.0043344427998127074, 0.0084115404055074925, 0.002924606434983836},
                {0.0042603123064085041, 0.0046074752661983513, 0.0039537346178543532,
                 0.0064751589605226787, 0.0064707625812726929, 0.0037968877574420666}});
}

TEST(CoupledLegFeedback, RaiseOnlyWithObserverVelocityKeepsItsFigures) {
  hexa::LockstepConfig config;
  config.seed = 2;
  hexa::study::CoupledLegFeedbackParams coupled;
  coupled.enabled = true;
  coupled.raise_only = true;
  coupled.observer_velocity = true;
  coupled.reference_mass_kg = 3.0;
  config.leg_runner = hexa::study::CoupledLegRunnerFactory(coupled);
  ExpectPinned(hexa::RunPaperSession(config, hexa::PaperMotion::kYaw),
               {{0.0010862348343942758, 0.0037736855996560385, 0.0020124234326701763,
                 0.0016410377781987018, 0.00091640745304059912, 0.0032510251092443508},
                {0.0032555441736212332, 0.003586562830847411, 0.0033136334263484291,
                 0.0037028407581944701, 0.0033425523252961727, 0.0035569814859411414}});
}

TEST(CoupledLegFeedback, DisabledGivesNoRunnerAndABadMassIsRejected) {
  hexa::study::CoupledLegFeedbackParams coupled;
  EXPECT_FALSE(hexa::study::CoupledLegRunnerFactory(coupled));
  coupled.enabled = true;
  coupled.reference_mass_kg = -1.0;
  try {
    hexa::study::CoupledLegRunnerFactory(coupled);
    FAIL() << "a negative reference mass was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("reference_mass_kg = -1"), std::string::npos) << e.what();
  }
}

// W = M_ls / m_ref row by row; raise_only with m_ref below every modal mass is the same W.
TEST(CoupledLegFeedback, CouplingMatrixRaiseOnlyBelowEveryModeIsThePlainMix) {
  hexa::Matrix6d a = hexa::Matrix6d::Random();
  const hexa::Matrix6d m_ls = a * a.transpose() + 2.0 * hexa::Matrix6d::Identity();
  const hexa::LegArray<double> mass_kg{1.0, 1.0, 1.0, 1.0, 1.0, 1.0};
  const hexa::Matrix6d plain = hexa::CouplingMatrix(m_ls, mass_kg, false);
  EXPECT_TRUE(plain.isApprox(m_ls, 1e-14));
  EXPECT_TRUE(hexa::CouplingMatrix(m_ls, mass_kg, true).isApprox(plain, 1e-12));
  const hexa::LegArray<double> heavy{1e3, 1e3, 1e3, 1e3, 1e3, 1e3};
  EXPECT_TRUE(hexa::CouplingMatrix(m_ls, heavy, true).isApprox(hexa::Matrix6d::Identity(), 1e-12));
}

// The pose runner (platform_study cl_pose) with W at home is the system's coupled law: one
// combined period gives the figures of the legs' own mix (LegController with
// params.coupled) to 1e-3 relative (only the fall-back ticks' arithmetic differs: Finish with
// the own part instead of FinishOwn); with W at the desired pose the figures move by more.
TEST(CoupledLegFeedback, PoseRunnerWithWAtHomeIsTheSystemsCoupledLaw) {
  hexa::LockstepConfig system;
  system.leg_controller.coupled.enabled = true;
  hexa::LockstepConfig home = system, desired = system;
  home.leg_runner = hexa::study::PoseCouplingRowRunnerFactory(hexa::study::CouplingPose::kHome);
  desired.leg_runner = hexa::study::PoseCouplingRowRunnerFactory(hexa::study::CouplingPose::kDesired);
  const auto a = hexa::RunPaperSession(system, hexa::PaperMotion::kCombined, 1);
  const auto b = hexa::RunPaperSession(home, hexa::PaperMotion::kCombined, 1);
  const auto c = hexa::RunPaperSession(desired, hexa::PaperMotion::kCombined, 1);
  ASSERT_TRUE(a.completed && b.completed && c.completed);
  const auto ea = a.metrics.vs_truth.Rmse(), eb = b.metrics.vs_truth.Rmse(), ec = c.metrics.vs_truth.Rmse();
  double moved = 0.0;
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(eb[k], ea[k], 1e-3 * ea[k]) << "axis " << k;
    moved = std::max(moved, std::abs(ec[k] - ea[k]) / ea[k]);
  }
  EXPECT_GT(moved, 1e-3);
}

// The hook itself: the system's runner supplied explicitly is the simulation without a hook.
TEST(LockstepLegRunner, TheSystemsRunnerAsAHookChangesNothing) {
  hexa::LockstepConfig plain;
  hexa::LockstepConfig hooked;
  hooked.leg_runner = [](const hexa::Supervisor&, const hexa::LegArray<std::unique_ptr<hexa::LegController>>&) {
    return std::make_unique<hexa::IndependentLegRunner>();
  };
  hexa::LockstepSimulation a(plain), b(hooked);
  for (int k = 0; k < 2000; ++k) {
    a.Tick();
    b.Tick();
    ASSERT_EQ(a.applied_valve_v(), b.applied_valve_v()) << "tick " << k;
  }
}

}  // namespace
