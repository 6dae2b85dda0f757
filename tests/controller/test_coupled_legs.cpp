// Coupled leg feedback as the distributed system runs it (hexa/core/coupled_legs.hpp): the
// coupling matrix's physics, the mix's fall-back to the decoupled law on the tick a relayed
// part is missing, the plant's relay rule, and the leg controller with the relay.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>

#include "hexa/core/coupled_legs.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/platform_dynamics.hpp"

namespace hexa {
namespace {

Matrix6d HomeMassMatrix(const RigParams& rig) {
  Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  home.R_BP.setIdentity();
  Matrix6d m_ls;
  EXPECT_EQ(LegSpaceMassMatrix(rig.geometry, PlatformInertialParams::FromRig(rig), home, m_ls),
            KinStatus::kOk);
  return m_ls;
}

RelayedFeedback AllValid(std::uint64_t tick, const LegArray<double>& force_n) {
  RelayedFeedback r;
  r.present = true;
  r.tick = tick;
  for (std::size_t j = 0; j < kNumLegs; ++j) r.parts[j] = FeedbackPart{true, force_n[j], 10.0 * force_n[j]};
  return r;
}

// On a mode of the platform (an eigenvector v_k of M_ls, modal mass m_k) the mix gives every
// leg (max(m_k, M) / M) times its own part: the mode is driven as one mass M (the paper's
// single-leg design, eq 25) when it is heavier, and keeps the uncoupled gain when lighter.
TEST(CoupledLegs, OnEachPlatformModeTheMixScalesByTheRaisedModalMassOverM) {
  const RigParams rig = MakeReferenceRig();
  const double mass_kg = LegControllerParams{}.bssmc.effective_mass_kg;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(HomeMassMatrix(rig));
  CoupledLegsParams params;  // the plain coupled law: no gain below 1, no low-pass
  params.enabled = true;
  params.gain = 1.0;
  params.cutoff_hz = 0.0;
  int raised = 0, kept = 0;
  for (int k = 0; k < 6; ++k) {
    const Vector6d v = eig.eigenvectors().col(k) * 10.0;  // N
    const double expected_scale = std::max(eig.eigenvalues()[k], mass_kg) / mass_kg;
    (expected_scale > 1.0 + 1e-9 ? raised : kept)++;
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      CoupledFeedbackMix mix(params, CouplingRowAtHome(rig, i, mass_kg, true), i, 0.001);
      LegArray<double> parts{};
      for (std::size_t j = 0; j < kNumLegs; ++j) parts[j] = v[static_cast<int>(j)];
      const BsSmcFeedback own{parts[i], 10.0 * parts[i]};
      BsSmcFeedback applied;
      ASSERT_TRUE(mix.Apply(own, 8, AllValid(7, parts), applied));
      EXPECT_NEAR(applied.force_n, expected_scale * own.force_n, 1e-9) << "mode " << k << " leg " << i;
      EXPECT_NEAR(applied.rate_n_s, expected_scale * own.rate_n_s, 1e-8) << "mode " << k << " leg " << i;
    }
  }
  // The reference rig at home: roll / pitch lighter than M (0.877 kg), heave equal to it to
  // within its rounding, yaw and x / y heavier (docs/measurements/control_coupled_feedback.md, modal table).
  EXPECT_GE(raised, 3);
  EXPECT_GE(kept, 2);
}

TEST(CoupledLegs, PlainMatrixIsTheMassMatrixOverMAndRaiseOnlyNeverLowersAMode) {
  const Matrix6d m_ls = HomeMassMatrix(MakeReferenceRig());
  LegArray<double> mass{};
  mass.fill(1.5);
  const Matrix6d plain = CouplingMatrix(m_ls, mass, false);
  EXPECT_TRUE((plain * 1.5).isApprox(m_ls, 1e-12));
  const Matrix6d raised = CouplingMatrix(m_ls, mass, true);
  EXPECT_TRUE(raised.isApprox(raised.transpose(), 1e-12));  // same M on every row: symmetric
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(raised);
  for (int k = 0; k < 6; ++k) EXPECT_GE(eig.eigenvalues()[k], 1.0 - 1e-12) << k;
}

TEST(CoupledLegs, MixFallsBackToTheOwnPartOnTheTickAnyPartIsMissingOrStale) {
  const RigParams rig = MakeReferenceRig();
  CoupledLegsParams params;
  params.enabled = true;
  CoupledFeedbackMix mix(params, CouplingRowAtHome(rig, 2, 1.5, true), 2, 0.001);
  const LegArray<double> parts{3.0, -2.0, 5.0, 1.0, -4.0, 2.5};
  const BsSmcFeedback own{5.0, 50.0};
  BsSmcFeedback applied;
  ASSERT_TRUE(mix.Apply(own, 11, AllValid(10, parts), applied));
  EXPECT_NE(applied.force_n, own.force_n);
  for (std::size_t missing = 0; missing < kNumLegs; ++missing) {
    RelayedFeedback r = AllValid(11, parts);
    r.parts[missing].valid = false;
    EXPECT_FALSE(mix.Apply(own, 12, r, applied)) << "leg " << missing + 1 << " missing";
    EXPECT_EQ(applied.force_n, own.force_n);
    EXPECT_EQ(applied.rate_n_s, own.rate_n_s);
  }
  EXPECT_FALSE(mix.Apply(own, 13, AllValid(11, parts), applied)) << "relay of an older tick";
  EXPECT_EQ(applied.force_n, own.force_n);
  EXPECT_FALSE(mix.Apply(own, 14, RelayedFeedback{}, applied)) << "nothing relayed";
  RelayedFeedback nan = AllValid(14, parts);
  nan.parts[0].force_n = std::nan("");
  EXPECT_FALSE(mix.Apply(own, 15, nan, applied)) << "non-finite part";
  EXPECT_EQ(applied.force_n, own.force_n);
  EXPECT_TRUE(mix.Apply(own, 16, AllValid(15, parts), applied)) << "back once all six are there";
}

TEST(CoupledLegs, LowPassAndGainShapeTheIncrementOnly) {
  const RigParams rig = MakeReferenceRig();
  const LegArray<double> row = CouplingRowAtHome(rig, 0, 1.5, true);
  const LegArray<double> parts{4.0, -1.0, 2.0, 3.0, -2.0, 1.0};
  const BsSmcFeedback own{4.0, 40.0};
  double increment = -parts[0];  // sum_j W_0j f_j(n - 1) - f_0(n - 1)
  for (std::size_t j = 0; j < kNumLegs; ++j) increment += row[j] * parts[j];
  ASSERT_GT(std::abs(increment), 0.1);
  CoupledLegsParams params;
  params.enabled = true;
  params.gain = 0.5;
  params.cutoff_hz = 20.0;
  CoupledFeedbackMix mix(params, row, 0, 0.001);
  const double alpha = 1.0 - std::exp(-2.0 * M_PI * 20.0 * 0.001);
  BsSmcFeedback applied;
  for (int n = 1; n <= 50; ++n) {
    ASSERT_TRUE(mix.Apply(own, 100 + n, AllValid(99 + n, parts), applied));
    const double filtered = (1.0 - std::pow(1.0 - alpha, n)) * increment;
    EXPECT_NEAR(applied.force_n, own.force_n + 0.5 * filtered, 1e-9) << n;
  }
  // A missing part resets the filter: the coupling ramps in again from zero.
  ASSERT_FALSE(mix.Apply(own, 151, RelayedFeedback{}, applied));
  ASSERT_TRUE(mix.Apply(own, 152, AllValid(151, parts), applied));
  EXPECT_NEAR(applied.force_n, own.force_n + 0.5 * alpha * increment, 1e-9);
}

TEST(FeedbackRelay, APartIsValidOnlyWhenItsCommandAnsweredTheTickAndTheLegIsNotForced) {
  FeedbackRelay relay;
  LegArray<bool> forced{};
  for (int leg = 1; leg <= 6; ++leg) relay.Offer(leg, 20, FeedbackPart{true, 1.0 * leg, 0.0});
  RelayedFeedback r = relay.For(20, forced);
  EXPECT_TRUE(r.AllValid());
  EXPECT_EQ(r.tick, 20u);
  EXPECT_EQ(r.parts[3].force_n, 4.0);
  // Tick 21: leg 4 does not answer (crashed, hung, silent or late): its part of tick 20 is
  // not relayed as tick 21's.
  for (int leg = 1; leg <= 6; ++leg)
    if (leg != 4) relay.Offer(leg, 21, FeedbackPart{true, 1.0, 0.0});
  r = relay.For(21, forced);
  EXPECT_FALSE(r.AllValid());
  EXPECT_FALSE(r.parts[3].valid);
  EXPECT_TRUE(r.parts[0].valid);
  // A forced leg (dead, interlocked) does not count even with a fresh answer.
  relay.Offer(4, 21, FeedbackPart{true, 1.0, 0.0});
  forced[3] = true;
  EXPECT_FALSE(relay.For(21, forced).parts[3].valid);
  forced[3] = false;
  EXPECT_TRUE(relay.For(21, forced).AllValid());
  // A leg that says its part is not valid (held, PI) is not relayed as valid.
  relay.Offer(2, 21, FeedbackPart{false, 0.0, 0.0});
  EXPECT_FALSE(relay.For(21, forced).parts[1].valid);
}

LegControllerInput MovingInput(std::uint64_t k, double mid) {
  const double t = 0.001 * static_cast<double>(k);
  LegControllerInput in;
  in.tick = k;
  in.time_s = t;
  in.length_m = mid + 0.03 * std::sin(2.0 * M_PI * t) + 2e-5 * std::sin(7.0 * static_cast<double>(k));
  in.cap_pressure_pa = 4.0e5 + 0.5e5 * std::sin(2.0 * M_PI * t + 0.3);
  in.rod_pressure_pa = 4.0e5 - 0.5e5 * std::sin(2.0 * M_PI * t + 0.3);
  in.supply_pressure_pa = 7.0e5;
  in.has_setpoint = true;
  in.setpoint_tick = 5 * (k / 5);
  in.setpoint_time_s = 0.001 * static_cast<double>(in.setpoint_tick);
  const double ts = in.setpoint_time_s;
  in.setpoint_length_m = mid + 0.032 * std::sin(2.0 * M_PI * ts);
  in.setpoint_velocity_m_s = 0.032 * 2.0 * M_PI * std::cos(2.0 * M_PI * ts);
  in.setpoint_acceleration_m_s2 = -0.032 * 4.0 * M_PI * M_PI * std::sin(2.0 * M_PI * ts);
  return in;
}

// A leg controller with the coupling on runs the decoupled law bit for bit on every tick the
// relay is incomplete (here: one leg never relayed), and the coupled one when it is complete.
TEST(LegControllerCoupledLegs, IncompleteRelayIsTheDecoupledLawBitForBit) {
  const RigParams rig = MakeReferenceRig();
  LegControllerParams params;
  LegControllerConfig plain = LegControllerConfig::FromRig(rig, params, LegControllerKind::kBsSmc);
  params.coupled.enabled = true;
  LegControllerConfig coupled_config = LegControllerConfig::FromRig(rig, params, LegControllerKind::kBsSmc);
  AssignCouplingRow(rig, 1, coupled_config);
  LegController decoupled(plain), with_gap(coupled_config), complete(coupled_config);
  const double mid = plain.model.cylinder.mid_stroke_length_m;
  int coupled_ticks = 0, differing = 0;
  for (std::uint64_t k = 0; k < 3000; ++k) {
    LegControllerInput in = MovingInput(k, mid);
    LegControllerOutput a, b, c;
    decoupled.Update(in, a);
    LegArray<double> parts{};
    for (std::size_t j = 0; j < kNumLegs; ++j) parts[j] = 20.0 * std::sin(0.01 * static_cast<double>(k) + j);
    in.relayed = AllValid(k - 1, parts);
    complete.Update(in, c);
    in.relayed.parts[4].valid = false;  // leg 5 silent
    with_gap.Update(in, b);
    ASSERT_EQ(a.valve_v, b.valve_v) << "tick " << k;
    ASSERT_EQ(a.desired_force_n, b.desired_force_n) << "tick " << k;
    EXPECT_FALSE(b.coupled);
    EXPECT_TRUE(b.feedback.valid);
    coupled_ticks += c.coupled ? 1 : 0;
    differing += c.valve_v != a.valve_v ? 1 : 0;
  }
  EXPECT_EQ(coupled_ticks, 2999);  // every tick but tick 0 (no previous tick to relay)
  EXPECT_GT(differing, 2500);
}

TEST(LegControllerCoupledLegs, HoldingLegPublishesNoPart) {
  LegControllerParams params;
  params.coupled.enabled = true;
  LegControllerConfig config = LegControllerConfig::FromRig(MakeReferenceRig(), params, LegControllerKind::kBsSmc);
  AssignCouplingRow(MakeReferenceRig(), 0, config);
  LegController c(config);
  LegControllerInput in = MovingInput(1, config.model.cylinder.mid_stroke_length_m);
  in.has_setpoint = false;
  LegControllerOutput out;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldNoSetpoint);
  EXPECT_FALSE(out.feedback.valid);
  EXPECT_FALSE(out.coupled);
}

}  // namespace
}  // namespace hexa
