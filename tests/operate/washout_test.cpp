// Classical washout: step and ramp responses of every channel equal the continuous filter's
// analytic responses (partial fractions over the transfer function's poles, independent of the
// state-space code) to 1e-6 at every sample; the tilt rate never above its limit; the worked
// examples of docs/operate.md (braking, lane change) print their figures.
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/core/washout.hpp"
#include "operate_test_util.hpp"

namespace hexa {
namespace {

using cd = std::complex<double>;
using operate_test::Sampler;

// G(s) = k N(s) / prod (s - p_i) with distinct, non-zero poles. Step: y = G(0) +
// sum_i Res_i e^{p_i t} / p_i; ramp (input t): y = G(0) t + G'(0) + sum_i Res_i e^{p_i t} / p_i^2,
// Res_i = k N(p_i) / prod_{j != i} (p_i - p_j).
struct Transfer {
  std::function<cd(cd)> numerator;  // k N(s)
  std::vector<cd> poles;
  cd Evaluate(cd s) const {
    cd d = 1.0;
    for (const cd& p : poles) d *= (s - p);
    return numerator(s) / d;
  }
  cd Residue(std::size_t i) const {
    cd d = 1.0;
    for (std::size_t j = 0; j < poles.size(); ++j) {
      if (j != i) d *= (poles[i] - poles[j]);
    }
    return numerator(poles[i]) / d;
  }
  double Step(double t) const {
    cd y = Evaluate(0.0);
    for (std::size_t i = 0; i < poles.size(); ++i) y += Residue(i) * std::exp(poles[i] * t) / poles[i];
    return y.real();
  }
  double Ramp(double t) const {
    const double h = 1e-5;  // G'(0) by a central difference of a rational function: ~1e-11
    const cd derivative = (Evaluate(h) - Evaluate(-h)) / (2 * h);
    cd y = Evaluate(0.0) * t + derivative;
    for (std::size_t i = 0; i < poles.size(); ++i) {
      y += Residue(i) * std::exp(poles[i] * t) / (poles[i] * poles[i]);
    }
    return y.real();
  }
};

std::vector<cd> SecondOrderPoles(double wn, double zeta) {
  const cd root = std::sqrt(cd(zeta * zeta - 1.0, 0.0));
  return {wn * (-zeta + root), wn * (-zeta - root)};
}

WashoutConfig TestConfig() {
  WashoutConfig c;
  c.period_s = 0.005;
  c.translation[0] = {0.6, 1e3, 2.0, 0.7, 0.5, 1e3};
  c.translation[1] = {0.4, 1e3, 2.5, 0.6, 0.3, 1e3};
  c.translation[2] = {0.8, 1e3, 4.0, 1.3, 0.8, 1e3};  // over-damped: three real poles
  c.rotation[0] = {0.5, 1e3, 1.0, 0.7, 0.5};
  c.rotation[1] = {0.7, 1e3, 1.5, 0.5, 0.5};
  c.rotation[2] = {0.9, 1e3, 0.8, 1.4, 0.5};
  c.tilt = {0.5, 3.0, 0.7, 1.0, 0.5};  // rate limit high: the linear filter alone
  return c;
}

enum class Channel { kTranslation, kRotation, kTilt };

// Runs 10 s of a step (amplitude 1) or ramp (slope 1 per s) on one input and compares output
// `out_index` with the analytic response.
double WorstDeviation(const WashoutConfig& config, Channel channel, int axis, bool ramp,
                      const Transfer& G) {
  WashoutFilter filter(config);
  WashoutOutput out;
  double worst = 0.0, largest = 0.0;
  for (int k = 0; k <= 2000; ++k) {
    const double t = k * config.period_s;
    const double u = ramp ? t : 1.0;
    WashoutInput in;
    if (channel == Channel::kRotation) {
      in.angular_rate_rad_s[axis] = u;
    } else {
      in.acceleration_m_s2[axis] = u;
    }
    filter.Update(in, out);
    double y;
    if (channel == Channel::kTranslation) {
      y = out.translation_m[axis];
    } else if (channel == Channel::kRotation) {
      y = out.rotation_rad[axis];
    } else {
      y = out.tilt_rad[axis == 1 ? 0 : 1];
    }
    const double expected = ramp ? G.Ramp(t) : G.Step(t);
    worst = std::max(worst, std::abs(y - expected));
    largest = std::max(largest, std::abs(expected));
  }
  EXPECT_GT(largest, 1e-3);  // the response is not trivially zero
  return worst;
}

TEST(Washout, TranslationalStepAndRampMatchTheAnalyticResponse) {
  const WashoutConfig config = TestConfig();
  for (int axis = 0; axis < 3; ++axis) {
    const WashoutTranslationParams& p = config.translation[axis];
    Transfer G;
    G.numerator = [k = p.scale](cd s) { return k * s; };
    G.poles = SecondOrderPoles(p.frequency_rad_s, p.damping);
    G.poles.push_back(-p.break_frequency_rad_s);
    const double step = WorstDeviation(config, Channel::kTranslation, axis, false, G);
    const double ramp = WorstDeviation(config, Channel::kTranslation, axis, true, G);
    std::printf("translation axis %d: step %.2e m, ramp %.2e m\n", axis, step, ramp);
    EXPECT_LT(step, 1e-6);
    EXPECT_LT(ramp, 1e-6);
  }
}

TEST(Washout, RotationalStepAndRampMatchTheAnalyticResponse) {
  const WashoutConfig config = TestConfig();
  for (int axis = 0; axis < 3; ++axis) {
    const WashoutRotationParams& p = config.rotation[axis];
    Transfer G;
    G.numerator = [k = p.scale](cd s) { return k * s; };
    G.poles = SecondOrderPoles(p.frequency_rad_s, p.damping);
    const double step = WorstDeviation(config, Channel::kRotation, axis, false, G);
    const double ramp = WorstDeviation(config, Channel::kRotation, axis, true, G);
    std::printf("rotation axis %d: step %.2e rad, ramp %.2e rad\n", axis, step, ramp);
    EXPECT_LT(step, 1e-6);
    EXPECT_LT(ramp, 1e-6);
  }
}

// Surge -> pitch (sign -), sway -> roll (sign +): k wn^2 / (s^2 + 2 zeta wn s + wn^2) / g.
TEST(Washout, TiltStepAndRampMatchTheAnalyticResponse) {
  WashoutConfig config = TestConfig();
  for (int axis = 0; axis < 2; ++axis) {
    const double sign = axis == 0 ? -1.0 : 1.0;
    const double gain = sign * config.tilt.scale * config.tilt.frequency_rad_s *
                        config.tilt.frequency_rad_s / config.gravity_m_s2;
    Transfer G;
    G.numerator = [gain](cd) { return cd(gain); };
    G.poles = SecondOrderPoles(config.tilt.frequency_rad_s, config.tilt.damping);
    // A unit step of 1 m/s^2 tilts 0.5/9.81 = 2.9 deg at 1 rad/s of limit: never rate-limited
    // (peak rate measured below); the ramp stays under the angle limit for 10 s at 1 m/s^3.
    const double step = WorstDeviation(config, Channel::kTilt, axis, false, G);
    const double ramp = WorstDeviation(config, Channel::kTilt, axis, true, G);
    std::printf("tilt from axis %d: step %.2e rad, ramp %.2e rad\n", axis, step, ramp);
    EXPECT_LT(step, 1e-6);
    EXPECT_LT(ramp, 1e-6);
  }
  // A hand-checkable closed form beside the partial fractions: the tilt step response is
  // g_k (1 - e^{-zeta wn t} (cos wd t + zeta / sqrt(1 - zeta^2) sin wd t)).
  WashoutFilter filter(config);
  WashoutOutput out;
  WashoutInput in;
  in.acceleration_m_s2.y() = 1.0;
  const double wn = 3.0, z = 0.7, wd = wn * std::sqrt(1 - z * z), gk = 0.5 / 9.81;
  for (int k = 0; k <= 400; ++k) {
    filter.Update(in, out);
    const double t = k * config.period_s;
    const double expected =
        gk * (1 - std::exp(-z * wn * t) * (std::cos(wd * t) + z / std::sqrt(1 - z * z) * std::sin(wd * t)));
    ASSERT_NEAR(out.tilt_rad[0], expected, 1e-12) << t;
  }
}

// The tilt rate stays at or below its limit on random inputs, and the limit is reached.
TEST(Washout, TiltRateNeverAboveItsLimit) {
  WashoutConfig config;  // defaults: 3 deg/s
  WashoutFilter filter(config);
  Sampler s(99);
  WashoutOutput out;
  WashoutInput in;
  double worst = 0.0;
  int limited = 0;
  for (int k = 0; k < 200000; ++k) {
    if (k % 150 == 0) {
      in.acceleration_m_s2 = Eigen::Vector3d(s.Uniform(-8, 8), s.Uniform(-8, 8), s.Uniform(-3, 3));
      in.angular_rate_rad_s = Eigen::Vector3d(s.Uniform(-1, 1), s.Uniform(-1, 1), s.Uniform(-1, 1));
    }
    filter.Update(in, out);
    worst = std::max(worst, out.tilt_rate_rad_s.cwiseAbs().maxCoeff());
    if (out.tilt_rate_limited) ++limited;
    ASSERT_LE(std::abs(out.displacement[0]), config.translation[0].displacement_limit_m);
  }
  std::printf("tilt rate: largest %.6f rad/s, limit %.6f rad/s, limited on %d of 200000 ticks\n",
              worst, config.tilt.rate_limit_rad_s, limited);
  EXPECT_LE(worst, config.tilt.rate_limit_rad_s * (1 + 1e-12));
  EXPECT_GT(worst, 0.999 * config.tilt.rate_limit_rad_s);
  EXPECT_GT(limited, 0);
}

// A sustained deceleration (steady specific force): the translational channel washes out to
// zero displacement and the tilt carries the cue, reached at no more than the tilt-rate limit and
// settling on k_t a / g (small angles).
TEST(Washout, SustainedAccelerationBecomesATiltReachedAtTheRateLimit) {
  const WashoutConfig config;
  WashoutFilter filter(config);
  WashoutInput in;
  in.acceleration_m_s2 = Eigen::Vector3d(-1.0, 0.0, 0.0);  // braking at 1 m/s2, held
  WashoutOutput out;
  const double T = config.period_s, limit = config.tilt.rate_limit_rad_s;
  const double steady = config.tilt.scale * 1.0 / config.gravity_m_s2;  // 0.051 rad
  double previous = 0.0, largest_step = 0.0, reached_s = -1.0;
  for (int k = 0; k * T < 30.0; ++k) {
    filter.Update(in, out);
    const double pitch = out.tilt_rad[1];
    largest_step = std::max(largest_step, std::abs(pitch - previous));
    previous = pitch;
    if (reached_s < 0.0 && std::abs(pitch) >= 0.99 * steady) reached_s = k * T;
  }
  std::printf("steady braking 1 m/s2: tilt %.6f rad (steady state %.6f), 99 %% after %.3f s "
              "(rate limit alone: %.3f s), largest step %.3e rad (limit x T %.3e), surge %.2e m\n",
              out.tilt_rad[1], steady, reached_s, 0.99 * steady / limit, largest_step, limit * T,
              out.displacement[0]);
  EXPECT_LE(largest_step, limit * T * (1 + 1e-12));
  EXPECT_GE(reached_s, 0.99 * steady / limit - T);  // no faster than the rate limit allows
  EXPECT_NEAR(std::abs(out.tilt_rad[1]), steady, 1e-6);
  EXPECT_NEAR(out.displacement[4], out.tilt_rad[1], 1e-9);  // the pitch is the tilt: rate 0
  EXPECT_LT(std::abs(out.displacement[0]), 1e-6);            // washed out
}

// A step in lateral acceleration: the onset moves the platform the way of the acceleration,
// then the third-order high-pass brings the displacement back to zero.
TEST(Washout, AccelerationStepGivesATransientThatWashesOutToZeroDisplacement) {
  const WashoutConfig config;
  WashoutFilter filter(config);
  WashoutInput in;
  WashoutOutput out;
  filter.Update(in, out);
  in.acceleration_m_s2 = Eigen::Vector3d(0.0, 2.0, 0.0);  // a step of 2 m/s2 to the left
  double peak = 0.0, peak_s = 0.0;
  const double T = config.period_s;
  for (int k = 1; k * T < 40.0; ++k) {
    filter.Update(in, out);
    if (std::abs(out.translation_m[1]) > std::abs(peak)) peak = out.translation_m[1], peak_s = k * T;
  }
  std::printf("lateral step 2 m/s2: peak sway %.2f mm at %.3f s, %.2e m at 40 s\n", peak * 1e3,
              peak_s, out.translation_m[1]);
  EXPECT_GT(peak, 0.005);  // the onset: towards +y, several millimetres
  EXPECT_LT(peak_s, 2.0);
  EXPECT_LT(std::abs(out.translation_m[1]), 1e-6);  // back to zero
  EXPECT_LT(std::abs(out.displacement[1]), 1e-6);
}

struct ExampleFigures {
  double peak_surge_m = 0, peak_sway_m = 0, peak_pitch_rad = 0, peak_roll_rad = 0;
  double peak_yaw_rad = 0, final_abs_m = 0, tilt_limited_s = 0, peak_tilt_rate = 0;
};

ExampleFigures RunExample(const std::function<WashoutInput(double)>& vehicle, double duration_s) {
  const WashoutConfig config;  // the defaults, as config/washout/default.washout
  WashoutFilter filter(config);
  WashoutOutput out;
  ExampleFigures f;
  for (int k = 0; k * config.period_s <= duration_s; ++k) {
    filter.Update(vehicle(k * config.period_s), out);
    f.peak_surge_m = std::max(f.peak_surge_m, std::abs(out.displacement[0]));
    f.peak_sway_m = std::max(f.peak_sway_m, std::abs(out.displacement[1]));
    f.peak_roll_rad = std::max(f.peak_roll_rad, std::abs(out.displacement[3]));
    f.peak_pitch_rad = std::max(f.peak_pitch_rad, std::abs(out.displacement[4]));
    f.peak_yaw_rad = std::max(f.peak_yaw_rad, std::abs(out.displacement[5]));
    f.peak_tilt_rate = std::max(f.peak_tilt_rate, out.tilt_rate_rad_s.cwiseAbs().maxCoeff());
    if (out.tilt_rate_limited) f.tilt_limited_s += config.period_s;
    f.final_abs_m = out.displacement.head<3>().cwiseAbs().maxCoeff();
  }
  return f;
}

TEST(Washout, WorkedExamplesStayInsideTheirLimitsAndReturnToNeutral) {
  const WashoutConfig config;
  const ExampleFigures b = RunExample(BrakingExample, 12.0);
  std::printf("braking: peak surge %.1f mm, peak pitch %.2f deg, tilt rate-limited %.2f s, "
              "peak tilt rate %.3f deg/s, |x| at 12 s %.2f mm\n", b.peak_surge_m * 1e3,
              b.peak_pitch_rad / operate_test::kDeg, b.tilt_limited_s,
              b.peak_tilt_rate / operate_test::kDeg, b.final_abs_m * 1e3);
  EXPECT_LE(b.peak_surge_m, config.translation[0].displacement_limit_m);
  EXPECT_LE(b.peak_tilt_rate, config.tilt.rate_limit_rad_s * (1 + 1e-12));
  EXPECT_GT(b.peak_pitch_rad, 0.01);  // the tilt gave a sustained cue
  EXPECT_LT(b.final_abs_m, 0.002);    // washed out
  const ExampleFigures l = RunExample(LaneChangeExample, 12.0);
  std::printf("lane change: peak sway %.1f mm, peak roll %.2f deg, peak yaw %.2f deg, tilt "
              "rate-limited %.2f s, |y| at 12 s %.2f mm\n", l.peak_sway_m * 1e3,
              l.peak_roll_rad / operate_test::kDeg, l.peak_yaw_rad / operate_test::kDeg,
              l.tilt_limited_s, l.final_abs_m * 1e3);
  EXPECT_LE(l.peak_sway_m, config.translation[1].displacement_limit_m);
  EXPECT_LT(l.final_abs_m, 0.002);
}

TEST(Washout, ValidateNamesFieldValueAndLimit) {
  WashoutConfig config;
  config.translation[1].damping = 0.0;
  try {
    WashoutFilter filter(config);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "washout.translation.sway.damping: damping is out of range (value 0, limit [0.1, 5])"),
              std::string::npos) << e.what();
  }
  config = WashoutConfig{};
  config.tilt.rate_limit_rad_s = std::nan("");
  EXPECT_THROW(WashoutFilter{config}, std::invalid_argument);
}

TEST(Washout, MatrixExponentialOfARotationGenerator) {
  Eigen::MatrixXd M(2, 2);
  M << 0, -3.0, 3.0, 0;  // exp = rotation by 3 rad
  const Eigen::MatrixXd E = MatrixExponential(M);
  EXPECT_NEAR(E(0, 0), std::cos(3.0), 1e-14);
  EXPECT_NEAR(E(1, 0), std::sin(3.0), 1e-14);
}

}  // namespace
}  // namespace hexa
