// LegController / BS-SMC / PI: randomized property tests (fixed seeds), hold logic,
// setpoint interpolation, sign conventions, anti-windup.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include "hexa/core/leg_controller.hpp"

namespace hexa {
namespace {

LegControllerConfig MakeConfig(LegControllerKind kind) {
  return LegControllerConfig::FromRig(MakeReferenceRig(), LegControllerParams{}, kind);
}

LegControllerInput RestInput(double length_m, double desired_m) {
  LegControllerInput in;
  in.tick = 0;
  in.time_s = 0.0;
  in.length_m = length_m;
  in.cap_pressure_pa = 4.0e5;
  in.rod_pressure_pa = 4.0e5;
  in.supply_pressure_pa = 7.0e5;
  in.has_setpoint = true;
  in.setpoint_time_s = 0.0;
  in.setpoint_length_m = desired_m;
  return in;
}

// At least 100,000 random cases per controller: pressures 1-7 bar abs (supply 4-7 bar), the full stroke,
// leg speeds +-1 m/s, random setpoints (length in the stroke, velocity +-1 m/s, acceleration
// +-20 m/s^2, correction +-5 mm). Each case is a burst of ticks of a leg moving at constant
// speed (with sensor-like noise) so that the differentiator sees realistic and extreme
// histories. Every output must be finite, within 0-10 V, status ok.
void RunProperty(LegControllerKind kind, std::uint64_t seed) {
  const LegControllerConfig config = MakeConfig(kind);
  LegController controller(config);
  const CylinderParams& cyl = config.model.cylinder;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
  const double lo_m = cyl.mid_stroke_length_m - 0.5 * cyl.stroke_m;
  const double hi_m = cyl.mid_stroke_length_m + 0.5 * cyl.stroke_m;
  const int kCases = 100000;
  const int kTicksPerCase = 4;
  int checked = 0;
  std::uint64_t tick = 0;
  for (int c = 0; c < kCases; ++c) {
    const double speed = uniform(-1.0, 1.0);
    double length = uniform(lo_m, hi_m);
    LegControllerInput in;
    in.has_setpoint = true;
    in.setpoint_tick = tick;
    in.setpoint_time_s = tick * 0.001;
    in.setpoint_length_m = uniform(lo_m, hi_m);
    in.setpoint_velocity_m_s = uniform(-1.0, 1.0);
    in.setpoint_acceleration_m_s2 = uniform(-20.0, 20.0);
    in.correction_m = uniform(-0.005, 0.005);
    // keep the interpolated setpoint inside the plausible range for an "ok" case
    in.setpoint_length_m = std::clamp(in.setpoint_length_m, lo_m + 0.015, hi_m - 0.015);
    in.hold = u01(rng) < 0.02;
    for (int k = 0; k < kTicksPerCase; ++k, ++tick) {
      in.tick = tick;
      in.time_s = tick * 0.001;
      length = std::clamp(length + speed * 0.001 + uniform(-1e-4, 1e-4), lo_m, hi_m);
      in.length_m = length;
      in.cap_pressure_pa = uniform(1.0e5, 7.0e5);
      in.rod_pressure_pa = uniform(1.0e5, 7.0e5);
      // Down to the lowest supply the controller works with (below: a held fault, not a case).
      in.supply_pressure_pa = uniform(config.min_supply_pressure_pa, 7.0e5);
      LegControllerOutput out;
      controller.Update(in, out);
      ASSERT_TRUE(std::isfinite(out.valve_v)) << "case " << c;
      ASSERT_GE(out.valve_v, 0.0) << "case " << c;
      ASSERT_LE(out.valve_v, 10.0) << "case " << c;
      ASSERT_TRUE(std::isfinite(out.desired_length_m));
      ASSERT_TRUE(std::isfinite(out.sliding_surface_m_s));
      ASSERT_EQ(out.status, in.hold ? LegControlStatus::kHoldSupervisor : LegControlStatus::kOk)
          << "case " << c << " " << ToString(out.status);
      ++checked;
    }
  }
  EXPECT_EQ(checked, kCases * kTicksPerCase);
}

TEST(LegControllerProperty, BsSmcOutputFiniteAndInRangeOver100kRandomCases) {
  RunProperty(LegControllerKind::kBsSmc, 20240601);
}

TEST(LegControllerProperty, PiOutputFiniteAndInRangeOver100kRandomCases) {
  RunProperty(LegControllerKind::kPi, 20240602);
}

// Any non-finite or out-of-range input field -> hold_bad_input, valve exactly at null, and
// the controller recovers on the next good sample. 100,000 random cases per controller.
void RunBadInputProperty(LegControllerKind kind, std::uint64_t seed) {
  const LegControllerConfig config = MakeConfig(kind);
  LegController controller(config);
  const double mid = config.model.cylinder.mid_stroke_length_m;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double bad_values[] = {std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity(), 1e12, -1e12};
  for (int c = 0; c < 100000; ++c) {
    LegControllerInput in = RestInput(mid + 0.1 * (u01(rng) - 0.5), mid + 0.1 * (u01(rng) - 0.5));
    in.tick = static_cast<std::uint64_t>(c);
    in.time_s = 0.001 * c;
    in.setpoint_time_s = in.time_s;
    in.cap_pressure_pa = 1e5 + 6e5 * u01(rng);
    in.rod_pressure_pa = 1e5 + 6e5 * u01(rng);
    double* fields[] = {&in.length_m, &in.cap_pressure_pa, &in.rod_pressure_pa,
                        &in.supply_pressure_pa, &in.setpoint_length_m, &in.setpoint_velocity_m_s,
                        &in.setpoint_acceleration_m_s2, &in.correction_m, &in.time_s};
    const int field = static_cast<int>(u01(rng) * 9) % 9;
    const double bad = bad_values[static_cast<int>(u01(rng) * 5) % 5];
    *fields[field] = bad;
    LegControllerOutput out;
    controller.Update(in, out);
    // A finite sensor time far after the setpoint makes the setpoint stale instead.
    const LegControlStatus expected = (field == 8 && bad == 1e12) ? LegControlStatus::kHoldStaleSetpoint
                                                                  : LegControlStatus::kHoldBadInput;
    ASSERT_EQ(out.status, expected) << "case " << c << " field " << field;
    ASSERT_EQ(out.valve_v, config.model.valve.null_voltage_v);
    ASSERT_TRUE(std::isfinite(out.desired_length_m));
    ASSERT_TRUE(std::isfinite(out.sliding_surface_m_s));
    // next sample is good again -> ok and finite
    *fields[field] = field == 8 ? 0.001 * c : (field == 0 || field == 4) ? mid
                     : (field >= 1 && field <= 3) ? 4e5 : 0.0;
    if (field == 8) in.setpoint_time_s = in.time_s;
    controller.Update(in, out);
    ASSERT_EQ(out.status, LegControlStatus::kOk) << "case " << c << " field " << field;
    ASSERT_TRUE(std::isfinite(out.valve_v));
  }
}

TEST(LegControllerProperty, BsSmcBadInputsHoldAtNull) { RunBadInputProperty(LegControllerKind::kBsSmc, 7); }
TEST(LegControllerProperty, PiBadInputsHoldAtNull) { RunBadInputProperty(LegControllerKind::kPi, 8); }

// Supply pressure below half the nominal gauge pressure: the valve cannot deliver the flow
// the controller's model assumes; it holds (valve closed) and says which input (docs/faults.md).
TEST(LegController, LowSupplyHoldsAndNamesTheInput) {
  const LegControllerConfig config = MakeConfig(LegControllerKind::kBsSmc);
  EXPECT_DOUBLE_EQ(config.min_supply_pressure_pa, 4.0e5);  // P_a + (P_s - P_a) / 2, HexaTaar-R
  // The services build their configuration from the controller model (rig + overlay): same limit.
  const ControllerModel model = ControllerModel::FromRig(MakeReferenceRig(), LegControllerParams{});
  for (std::size_t i = 0; i < kNumLegs; ++i)
    EXPECT_DOUBLE_EQ(LegControllerConfig::FromModel(model, i, LegControllerKind::kBsSmc)
                         .min_supply_pressure_pa, 4.0e5) << "leg " << i + 1;
  LegController controller(config);
  const double mid = config.model.cylinder.mid_stroke_length_m;
  LegControllerInput in = RestInput(mid, mid + 0.01);
  LegControllerOutput out;
  controller.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kOk);
  EXPECT_EQ(out.input_fault, LegInputFault::kNone);
  in.supply_pressure_pa = 3.9e5;
  controller.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldBadInput);
  EXPECT_EQ(out.input_fault, LegInputFault::kSupplyLow);
  EXPECT_EQ(out.input_fault_value, 3.9e5);
  EXPECT_EQ(out.valve_v, config.model.valve.null_voltage_v);
  in.supply_pressure_pa = 7.0e5;
  in.cap_pressure_pa = 0.0;  // a dead transducer
  controller.Update(in, out);
  EXPECT_EQ(out.input_fault, LegInputFault::kCapPressure);
  EXPECT_STREQ(ToString(out.input_fault), "cap pressure");
  in.cap_pressure_pa = 4.0e5;
  controller.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kOk);
  EXPECT_EQ(out.input_fault, LegInputFault::kNone);
}

TEST(LegController, HoldsWithoutSetpoint) {
  LegController c(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5, 0.52);
  in.has_setpoint = false;
  LegControllerOutput out;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldNoSetpoint);
  EXPECT_EQ(out.valve_v, 5.0);
}

TEST(LegController, HoldsOnStaleSetpointAndResumesOnAFreshOne) {
  const LegControllerConfig config = MakeConfig(LegControllerKind::kBsSmc);
  LegController c(config);
  LegControllerInput in = RestInput(0.5, 0.52);
  LegControllerOutput out;
  in.time_s = config.params.setpoint_timeout_s * 0.99;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kOk);
  in.time_s = config.params.setpoint_timeout_s * 1.01;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldStaleSetpoint);
  EXPECT_EQ(out.valve_v, config.model.valve.null_voltage_v);
  in.setpoint_time_s = in.time_s;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kOk);
}

TEST(LegController, SetpointFromTheFutureIsBadInput) {
  LegController c(MakeConfig(LegControllerKind::kPi));
  LegControllerInput in = RestInput(0.5, 0.5);
  in.setpoint_time_s = 0.01;
  LegControllerOutput out;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldBadInput);
}

TEST(LegController, InterpolatesTheSetpointInsideItsPeriodAndAddsTheCorrection) {
  LegController c(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5, 0.5);
  in.setpoint_time_s = 1.000;
  in.setpoint_length_m = 0.51;
  in.setpoint_velocity_m_s = 0.3;
  in.setpoint_acceleration_m_s2 = -2.0;
  in.correction_m = 0.001;
  LegControllerOutput out;
  for (int k = 0; k < 5; ++k) {
    in.time_s = 1.000 + 0.001 * k;
    c.Update(in, out);
    const double dt = 0.001 * k;
    EXPECT_EQ(out.status, LegControlStatus::kOk);
    EXPECT_NEAR(out.desired_length_m, 0.51 + 0.3 * dt - 1.0 * dt * dt + 0.001, 1e-12);
    EXPECT_NEAR(out.desired_velocity_m_s, 0.3 - 2.0 * dt, 1e-12);
  }
}

TEST(LegController, FeedforwardIsInterpolatedAndMovesPhiByTheLoad) {
  // BS-SMC: with the feed-forward valid, phi carries the known load (force + rate * dt)
  // instead of M a_d + F_g; the difference of phi between two otherwise identical
  // controllers is exactly the load difference.
  for (LegControllerKind kind : {LegControllerKind::kBsSmc, LegControllerKind::kPi}) {
    LegController with(MakeConfig(kind)), without(MakeConfig(kind)), heavier(MakeConfig(kind));
    LegControllerInput in = RestInput(0.5, 0.5);
    in.setpoint_time_s = 1.000;
    in.setpoint_acceleration_m_s2 = 0.0;
    in.feedforward_valid = true;
    in.feedforward_force_n = 40.0;
    in.feedforward_force_rate_n_s = 500.0;
    LegControllerInput in_none = in;
    in_none.feedforward_valid = false;
    LegControllerInput in_heavier = in;
    in_heavier.feedforward_force_n = 50.0;
    LegControllerOutput out, out_none, out_heavier;
    for (int k = 0; k < 5; ++k) {
      in.time_s = in_none.time_s = in_heavier.time_s = 1.000 + 0.001 * k;
      with.Update(in, out);
      without.Update(in_none, out_none);
      heavier.Update(in_heavier, out_heavier);
      ASSERT_EQ(out.status, LegControlStatus::kOk);
      EXPECT_NEAR(out.feedforward_force_n, 40.0 + 500.0 * 0.001 * k, 1e-12);
      EXPECT_EQ(out_none.feedforward_force_n, 0.0);
      if (kind == LegControllerKind::kBsSmc) {
        const double gravity = LegControllerParams{}.bssmc.gravity_load_n;
        EXPECT_NEAR(out.desired_force_n - out_none.desired_force_n,
                    out.feedforward_force_n - gravity, 1e-9);
        EXPECT_NEAR(out_heavier.desired_force_n - out.desired_force_n, 10.0, 1e-9);
      } else {
        // PI: a larger load asks for more extension (a voltage below null, eq 42).
        EXPECT_LT(out_heavier.valve_v, out.valve_v);
      }
    }
  }
}

TEST(LegController, NonFiniteOrHugeFeedforwardIsBadInput) {
  LegController c(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5, 0.5);
  in.feedforward_valid = true;
  in.feedforward_force_n = std::numeric_limits<double>::quiet_NaN();
  LegControllerOutput out;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldBadInput);
  EXPECT_EQ(out.valve_v, 5.0);
  in.feedforward_force_n = 1e6;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldBadInput);
  in.feedforward_valid = false;  // ignored when not valid
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kOk);
}

TEST(LegController, SupervisorHoldKeepsTheLengthAtRest) {
  LegController c(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5, 0.51);
  in.setpoint_velocity_m_s = 0.3;
  in.correction_m = -0.002;
  in.hold = true;
  in.time_s = 0.004;
  LegControllerOutput out;
  c.Update(in, out);
  EXPECT_EQ(out.status, LegControlStatus::kHoldSupervisor);
  EXPECT_NEAR(out.desired_length_m, 0.508, 1e-12);
  EXPECT_EQ(out.desired_velocity_m_s, 0.0);
}

// Sign convention (ValveParams, eq 42): a leg shorter than its setpoint must be driven to
// extend, i.e. a voltage below null; longer -> above null. Both controllers.
TEST(LegController, LegTooShortIsExtendedAndTooLongIsRetracted) {
  for (LegControllerKind kind : {LegControllerKind::kBsSmc, LegControllerKind::kPi}) {
    for (double sign : {1.0, -1.0}) {
      LegController c(MakeConfig(kind));
      // pressures at the static balance of the nominal load, so that only the error acts
      LegControllerInput in = RestInput(0.5034, 0.5034 + sign * 0.01);
      LegControllerOutput out;
      for (int k = 0; k < 20; ++k) {
        in.tick = k;
        in.time_s = 0.001 * k;
        in.setpoint_time_s = in.time_s;
        c.Update(in, out);
      }
      if (sign > 0) {
        EXPECT_LT(out.valve_v, 5.0) << static_cast<int>(kind);
      } else {
        EXPECT_GT(out.valve_v, 5.0) << static_cast<int>(kind);
      }
    }
  }
}

TEST(PiController, AntiWindupBoundsTheIntegralAndReleasesSaturationAtOnce) {
  PiConfig config;
  config.params.proportional_v_m = 400.0;
  config.params.integral_v_m_s = 4000.0;
  config.params.integrator_limit_v = 2.0;
  config.params.velocity_feedforward_v_s_m = 0.0;  // the PI part alone (the jump below
  config.params.rate_damping_v_s_m = 0.0;          // would be a huge measured velocity)
  PiController pi(config);
  PiOutput out;
  // 50 mm error for 2 s: P alone saturates (20 V), so the integral must not wind up at all.
  for (int k = 0; k < 2000; ++k) pi.Update({0.45, 0.50}, out);
  EXPECT_EQ(out.valve_v, 0.0);  // extend, saturated low (a < 0)
  EXPECT_TRUE(out.saturated);
  EXPECT_LE(std::abs(out.integral_v), 2.0);
  EXPECT_EQ(out.integral_v, 0.0);  // conditional integration: never integrated
  // Small error of the other sign: the output leaves saturation on the very next tick.
  pi.Update({0.501, 0.50}, out);
  EXPECT_FALSE(out.saturated);
  EXPECT_GT(out.valve_v, 0.0);
  // Unsaturated, the integral is clamped at its limit.
  PiController pi2(config);
  for (int k = 0; k < 5000; ++k) pi2.Update({0.5, 0.5001}, out);  // 0.1 mm -> 0.04 V P
  EXPECT_NEAR(out.integral_v, 2.0, 1e-12);
}

TEST(PiController, RateDampingOpposesTheMeasuredVelocityAndFeedForwardFollowsTheSetpoint) {
  PiConfig config;
  config.params.proportional_v_m = 0.0;
  config.params.integral_v_m_s = 0.0;
  config.params.velocity_feedforward_v_s_m = 6.0;
  config.params.rate_damping_v_s_m = 20.0;
  PiController pi(config);
  PiOutput out;
  // The leg extends at 0.1 m/s, setpoint at rest on it: u = 5 + sign(a) Kd (0 - 0.1) = 7 V
  // (a < 0: above null retracts, i.e. brakes the extension). Exact: the eq 40 estimate is
  // exact on a line.
  for (int k = 0; k < 40; ++k) pi.Update({0.5 + 1e-4 * k, 0.5 + 1e-4 * k, 0.0}, out);
  EXPECT_NEAR(out.velocity_m_s, 0.1, 1e-9);
  EXPECT_NEAR(out.valve_v, 7.0, 1e-9);
  // Setpoint moving with the leg at 0.1 m/s: no damping, feed-forward 6 * 0.1 -> 4.4 V.
  PiController pi2(config);
  for (int k = 0; k < 40; ++k) pi2.Update({0.5 + 1e-4 * k, 0.5 + 1e-4 * k, 0.1}, out);
  EXPECT_NEAR(out.valve_v, 4.4, 1e-9);
}

TEST(LegControllerConfig, ValidateNamesTheField) {
  LegControllerConfig c = MakeConfig(LegControllerKind::kBsSmc);
  c.params.bssmc.lambda_1_s = -1.0;
  try {
    c.Validate();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("lambda_1_s"), std::string::npos) << e.what();
  }
  c = MakeConfig(LegControllerKind::kPi);
  c.params.setpoint_timeout_s = 0.0;
  EXPECT_THROW(LegController{c}, std::invalid_argument);
}

}  // namespace
}  // namespace hexa

namespace hexa {
namespace {

// Coupled leg feedback (docs/measurements/control_coupled_feedback.md "Coupled leg feedback"): BeginCoupled +
// FinishCoupled with the leg's own feedback part is the uncoupled law (to round-off: the
// coupled path sums phi as model part + feedback part), and a different feedback part moves
// phi by exactly the difference, its rate phi_dot by the fraction times the difference.
TEST(LegControllerCoupled, OwnFeedbackReproducesTheUncoupledLawAndAMixMovesPhi) {
  LegControllerConfig config = MakeConfig(LegControllerKind::kBsSmc);
  LegController uncoupled(config), own(config), shifted(config);
  const double mid = config.model.cylinder.mid_stroke_length_m;
  const double fraction = config.params.bssmc.feedback_rate_fraction;
  ASSERT_GT(fraction, 0.0);
  double worst_v = 0.0, worst_phi = 0.0;
  int moving = 0, unsaturated = 0;
  for (int k = 0; k < 3000; ++k) {
    const double t = 0.001 * k;
    LegControllerInput in;
    in.tick = static_cast<std::uint64_t>(k);
    in.time_s = t;
    in.length_m = mid + 0.03 * std::sin(2.0 * M_PI * t) + 2e-5 * std::sin(7.0 * k);  // noisy
    in.cap_pressure_pa = 4.0e5 + 0.5e5 * std::sin(2.0 * M_PI * t + 0.3);
    in.rod_pressure_pa = 4.0e5 - 0.5e5 * std::sin(2.0 * M_PI * t + 0.3);
    in.supply_pressure_pa = 7.0e5;
    in.has_setpoint = true;
    in.setpoint_tick = static_cast<std::uint64_t>(5 * (k / 5));
    in.setpoint_time_s = 0.001 * in.setpoint_tick;
    const double ts = in.setpoint_time_s;
    in.setpoint_length_m = mid + 0.032 * std::sin(2.0 * M_PI * ts);
    in.setpoint_velocity_m_s = 0.032 * 2.0 * M_PI * std::cos(2.0 * M_PI * ts);
    in.setpoint_acceleration_m_s2 = -0.032 * 4.0 * M_PI * M_PI * std::sin(2.0 * M_PI * ts);
    in.feedforward_valid = true;
    in.feedforward_force_n = 15.0 + 5.0 * std::sin(2.0 * M_PI * ts);
    LegControllerOutput a, b, c;
    uncoupled.Update(in, a);
    const auto fb = own.BeginCoupled(in, b);
    const auto fb_c = shifted.BeginCoupled(in, c);
    ASSERT_TRUE(fb && fb_c);
    EXPECT_EQ(fb->force_n, fb_c->force_n);  // same state, same input
    own.FinishCoupled(*fb, b);
    BsSmcFeedback mix = *fb;
    mix.force_n += 10.0;
    mix.rate_n_s += 1000.0;
    shifted.FinishCoupled(mix, c);
    worst_v = std::max(worst_v, std::abs(a.valve_v - b.valve_v));
    worst_phi = std::max(worst_phi, std::abs(a.desired_force_n - b.desired_force_n));
    EXPECT_NEAR(c.desired_force_n - b.desired_force_n, 10.0, 1e-9) << k;
    const double expected_rate =
        1000.0 * fraction * (1.0 - std::exp(-std::pow(b.desired_velocity_m_s /
                                                      config.params.bssmc.feedback_rate_full_speed_m_s, 2)));
    EXPECT_NEAR(c.desired_force_rate_n_s - b.desired_force_rate_n_s, expected_rate, 1e-6) << k;
    moving += std::abs(expected_rate) > 100.0 ? 1 : 0;
    unsaturated += a.valve_v > 0.5 && a.valve_v < 9.5 ? 1 : 0;
    // `shifted` diverges from the others from here on: give it the others' state back.
    shifted = own;
  }
  EXPECT_LT(worst_v, 1e-9) << "V";
  EXPECT_LT(worst_phi, 1e-9) << "N";
  EXPECT_GT(moving, 1000);       // the rate path was exercised at speed
  EXPECT_GT(unsaturated, 1000);  // and the valve was not pinned at a limit
  std::printf("own feedback vs uncoupled: worst valve %.2e V, phi %.2e N; %d ticks with rate, %d unsaturated\n",
              worst_v, worst_phi, moving, unsaturated);
}

TEST(LegControllerCoupled, HoldingLegReturnsNoFeedbackPart) {
  LegController c(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5034, 0.5034);
  in.has_setpoint = false;
  LegControllerOutput out;
  EXPECT_FALSE(c.BeginCoupled(in, out).has_value());
  EXPECT_EQ(out.status, LegControlStatus::kHoldNoSetpoint);
  LegController pi(MakeConfig(LegControllerKind::kPi));  // the PI has no feedback part to mix
  EXPECT_FALSE(pi.BeginCoupled(RestInput(0.5034, 0.5034), out).has_value());
  EXPECT_EQ(out.status, LegControlStatus::kOk);
}


TEST(LegController, TheFeedbackVelocityGivenReplacesTheDifferentiatedOneInTheSlidingSurface) {
  // Two identical BS-SMCs on the same inputs; one is given a feedback velocity (the platform
  // state observer's, studies/platform_observer_feedback): its S (eq 19) differs by
  // exactly that velocity minus the eq 40 estimate, which both still report.
  LegController given(MakeConfig(LegControllerKind::kBsSmc)), own(MakeConfig(LegControllerKind::kBsSmc));
  LegControllerInput in = RestInput(0.5, 0.5);
  LegControllerOutput out_given, out_own;
  for (int k = 0; k < 20; ++k) {
    in.time_s = 0.001 * k;
    in.setpoint_time_s = 0.005 * (k / 5);  // a fresh setpoint every 5 ms, as the supervisor's
    in.length_m = 0.5 + 1e-4 * k;  // moving: the eq 40 estimate is not zero
    given.Update(in, out_given, 0.25);
    own.Update(in, out_own);
    ASSERT_EQ(out_given.status, LegControlStatus::kOk);
    EXPECT_EQ(out_given.velocity_m_s, out_own.velocity_m_s);
    EXPECT_NEAR(out_given.sliding_surface_m_s - out_own.sliding_surface_m_s, 0.25 - out_own.velocity_m_s, 1e-12);
  }
  EXPECT_GT(std::abs(out_own.velocity_m_s), 0.05);
}

}  // namespace
}  // namespace hexa
