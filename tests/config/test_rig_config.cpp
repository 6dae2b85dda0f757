// Rig file loader (config/): the shipped reference file, the broken copies in broken/, and
// generic properties of the line mapping (every numeric field, made NaN or removed, is
// reported at its own line / its block's line).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/supervisor.hpp"

namespace {

using hexa::config::ConfigIssue;
using hexa::config::ConfigResult;
using hexa::config::SystemConfig;

const std::string kTestDir = HEXA_CONFIG_TEST_DIR;
const std::string kTmpDir = HEXA_CONFIG_TEST_TMP_DIR;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string JoinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

// 1-based line carrying "DEFECT" (found by the test, independently of the loader).
int DefectLine(const std::string& path) {
  const auto lines = SplitLines(ReadFile(path));
  int found = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find("DEFECT") != std::string::npos) {
      EXPECT_EQ(found, 0) << path << " has more than one DEFECT marker";
      found = static_cast<int>(i) + 1;
    }
  }
  EXPECT_GT(found, 0) << path << " has no DEFECT marker";
  return found;
}

void ExpectVecEq(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double tol, const std::string& what) {
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a(k), b(k), tol) << what << "(" << k << ")";
}

// Every field of the structs; scalars exactly, joint coordinates to the file's 1e-12 m.
void ExpectRigEq(const hexa::RigParams& a, const hexa::RigParams& b, double geometry_tol_m) {
  EXPECT_EQ(a.air.heat_ratio, b.air.heat_ratio);
  EXPECT_EQ(a.air.temperature_k, b.air.temperature_k);
  EXPECT_EQ(a.air.gas_constant_j_kg_k, b.air.gas_constant_j_kg_k);
  EXPECT_EQ(a.air.atmosphere_pressure_pa, b.air.atmosphere_pressure_pa);
  EXPECT_EQ(a.air.supply_pressure_pa, b.air.supply_pressure_pa);
  for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
    ExpectVecEq(a.geometry.p_BA_B[i], b.geometry.p_BA_B[i], geometry_tol_m, "p_BA_B[" + std::to_string(i) + "]");
    ExpectVecEq(a.geometry.p_PB_P[i], b.geometry.p_PB_P[i], geometry_tol_m, "p_PB_P[" + std::to_string(i) + "]");
  }
  ExpectVecEq(a.geometry.home_position_m, b.geometry.home_position_m, 0.0, "home_position_m");
  EXPECT_EQ(a.cylinder.cap_area_m2, b.cylinder.cap_area_m2);
  EXPECT_EQ(a.cylinder.annulus_area_m2, b.cylinder.annulus_area_m2);
  EXPECT_EQ(a.cylinder.rod_area_m2, b.cylinder.rod_area_m2);
  EXPECT_EQ(a.cylinder.stroke_m, b.cylinder.stroke_m);
  EXPECT_EQ(a.cylinder.dead_volume_m3, b.cylinder.dead_volume_m3);
  EXPECT_EQ(a.cylinder.moving_mass_kg, b.cylinder.moving_mass_kg);
  EXPECT_EQ(a.cylinder.mid_stroke_length_m, b.cylinder.mid_stroke_length_m);
  EXPECT_EQ(a.cylinder.end_stop_stiffness_n_m, b.cylinder.end_stop_stiffness_n_m);
  EXPECT_EQ(a.cylinder.end_stop_damping_n_s_m, b.cylinder.end_stop_damping_n_s_m);
  EXPECT_EQ(a.valve.min_voltage_v, b.valve.min_voltage_v);
  EXPECT_EQ(a.valve.max_voltage_v, b.valve.max_voltage_v);
  EXPECT_EQ(a.valve.null_voltage_v, b.valve.null_voltage_v);
  EXPECT_EQ(a.valve.spool_gain_m_v, b.valve.spool_gain_m_v);
  EXPECT_EQ(a.valve.spool_offset_m, b.valve.spool_offset_m);
  EXPECT_EQ(a.valve.max_spool_m, b.valve.max_spool_m);
  EXPECT_EQ(a.valve.max_orifice_area_m2, b.valve.max_orifice_area_m2);
  EXPECT_EQ(a.valve.discharge_coefficient, b.valve.discharge_coefficient);
  EXPECT_EQ(a.valve.spool_time_constant_s, b.valve.spool_time_constant_s);
  for (const auto& [fa, fb] : {std::pair{a.friction.extend, b.friction.extend},
                               std::pair{a.friction.retract, b.friction.retract}}) {
    EXPECT_EQ(fa.stribeck_velocity_m_s, fb.stribeck_velocity_m_s);
    EXPECT_EQ(fa.viscous_n_s_m, fb.viscous_n_s_m);
    EXPECT_EQ(fa.static_n, fb.static_n);
    EXPECT_EQ(fa.coulomb_n, fb.coulomb_n);
  }
  EXPECT_EQ(a.friction.bristle_stiffness_n_m, b.friction.bristle_stiffness_n_m);
  EXPECT_EQ(a.friction.bristle_damping_n_s_m, b.friction.bristle_damping_n_s_m);
  for (const auto& [pa, pb] : {std::pair{a.polytropic.extend, b.polytropic.extend},
                               std::pair{a.polytropic.retract, b.polytropic.retract}}) {
    EXPECT_EQ(pa.inflow, pb.inflow);
    EXPECT_EQ(pa.outflow, pb.outflow);
    EXPECT_EQ(pa.volume, pb.volume);
  }
  EXPECT_EQ(a.platform.mass_kg, b.platform.mass_kg);
  ExpectVecEq(a.platform.inertia_diag_kg_m2, b.platform.inertia_diag_kg_m2, 0.0, "inertia_diag_kg_m2");
  EXPECT_EQ(a.platform.gravity_m_s2, b.platform.gravity_m_s2);
  EXPECT_EQ(a.sensors.length_sigma_m, b.sensors.length_sigma_m);
  EXPECT_EQ(a.sensors.length_bits, b.sensors.length_bits);
  EXPECT_EQ(a.sensors.pressure_sigma_pa, b.sensors.pressure_sigma_pa);
  EXPECT_EQ(a.sensors.imu_orientation_sigma_rad, b.sensors.imu_orientation_sigma_rad);
  EXPECT_EQ(a.sensors.imu_bias_walk_rad_sqrt_s, b.sensors.imu_bias_walk_rad_sqrt_s);
  EXPECT_EQ(a.sensors.imu_period_s, b.sensors.imu_period_s);
}

void ExpectLegControllerEq(const hexa::LegControllerParams& a, const hexa::LegControllerParams& b) {
  EXPECT_EQ(a.differentiator.window, b.differentiator.window);
  EXPECT_EQ(a.differentiator.sigma, b.differentiator.sigma);
  EXPECT_EQ(a.differentiator.centre_lag_samples, b.differentiator.centre_lag_samples);
  EXPECT_EQ(a.bssmc.lambda_1_s, b.bssmc.lambda_1_s);
  EXPECT_EQ(a.bssmc.switching_gain_n, b.bssmc.switching_gain_n);
  EXPECT_EQ(a.bssmc.boundary_layer_xi_s_m, b.bssmc.boundary_layer_xi_s_m);
  EXPECT_EQ(a.bssmc.backstepping_beta_1_s, b.bssmc.backstepping_beta_1_s);
  EXPECT_EQ(a.bssmc.effective_mass_kg, b.bssmc.effective_mass_kg);
  EXPECT_EQ(a.bssmc.gravity_load_n, b.bssmc.gravity_load_n);
  EXPECT_EQ(a.bssmc.viscous_estimate_scale, b.bssmc.viscous_estimate_scale);
  EXPECT_EQ(a.bssmc.friction_estimate_scale, b.bssmc.friction_estimate_scale);
  EXPECT_EQ(a.bssmc.friction_smoothing_velocity_m_s, b.bssmc.friction_smoothing_velocity_m_s);
  EXPECT_EQ(a.bssmc.reaching_proportional_n_s_m, b.bssmc.reaching_proportional_n_s_m);
  EXPECT_EQ(a.bssmc.null_band_area_fraction, b.bssmc.null_band_area_fraction);
  EXPECT_EQ(a.bssmc.spool_filter_time_constant_s, b.bssmc.spool_filter_time_constant_s);
  EXPECT_EQ(a.bssmc.feedback_rate_fraction, b.bssmc.feedback_rate_fraction);
  EXPECT_EQ(a.bssmc.feedback_rate_time_constant_s, b.bssmc.feedback_rate_time_constant_s);
  EXPECT_EQ(a.bssmc.feedback_rate_from_observer, b.bssmc.feedback_rate_from_observer);
  EXPECT_EQ(a.bssmc.observer_mass_kg, b.bssmc.observer_mass_kg);
  EXPECT_EQ(a.bssmc.observer_length_sigma_m, b.bssmc.observer_length_sigma_m);
  EXPECT_EQ(a.bssmc.observer_force_sigma_n, b.bssmc.observer_force_sigma_n);
  EXPECT_EQ(a.bssmc.observer_disturbance_rate_m_s3, b.bssmc.observer_disturbance_rate_m_s3);
  EXPECT_EQ(a.bssmc.feedback_rate_full_speed_m_s, b.bssmc.feedback_rate_full_speed_m_s);
  EXPECT_EQ(a.bssmc.integral_gain_n_m, b.bssmc.integral_gain_n_m);
  EXPECT_EQ(a.bssmc.integral_limit_n, b.bssmc.integral_limit_n);
  EXPECT_EQ(a.bssmc.integral_active_below_m_s, b.bssmc.integral_active_below_m_s);
  EXPECT_EQ(a.bssmc.integral_leak_time_constant_s, b.bssmc.integral_leak_time_constant_s);
  EXPECT_EQ(a.bssmc.integral_deadband_m, b.bssmc.integral_deadband_m);
  EXPECT_EQ(a.bssmc.dither_amplitude_n, b.bssmc.dither_amplitude_n);
  EXPECT_EQ(a.bssmc.dither_frequency_hz, b.bssmc.dither_frequency_hz);
  EXPECT_EQ(a.bssmc.dither_gate_speed_m_s, b.bssmc.dither_gate_speed_m_s);
  EXPECT_EQ(a.bssmc.friction_adaptation_rate_1_n_m, b.bssmc.friction_adaptation_rate_1_n_m);
  EXPECT_EQ(a.bssmc.friction_adaptation_speed_m_s, b.bssmc.friction_adaptation_speed_m_s);
  EXPECT_EQ(a.bssmc.friction_adaptation_min_scale, b.bssmc.friction_adaptation_min_scale);
  EXPECT_EQ(a.bssmc.friction_adaptation_max_scale, b.bssmc.friction_adaptation_max_scale);
  EXPECT_EQ(a.pi.proportional_v_m, b.pi.proportional_v_m);
  EXPECT_EQ(a.pi.integral_v_m_s, b.pi.integral_v_m_s);
  EXPECT_EQ(a.pi.integrator_limit_v, b.pi.integrator_limit_v);
  EXPECT_EQ(a.pi.velocity_feedforward_v_s_m, b.pi.velocity_feedforward_v_s_m);
  EXPECT_EQ(a.pi.rate_damping_v_s_m, b.pi.rate_damping_v_s_m);
  EXPECT_EQ(a.pi.force_feedforward_v_n, b.pi.force_feedforward_v_n);
  EXPECT_EQ(a.setpoint_timeout_s, b.setpoint_timeout_s);
  EXPECT_EQ(a.coupled.enabled, b.coupled.enabled);
  EXPECT_EQ(a.coupled.gain, b.coupled.gain);
  EXPECT_EQ(a.coupled.cutoff_hz, b.coupled.cutoff_hz);
  EXPECT_EQ(a.coupled.raise_only, b.coupled.raise_only);
}

void ExpectSupervisorEq(const hexa::SupervisorParams& a, const hexa::SupervisorParams& b) {
  EXPECT_EQ(a.period_s, b.period_s);
  EXPECT_EQ(a.blend_duration_s, b.blend_duration_s);
  EXPECT_EQ(a.stop_duration_s, b.stop_duration_s);
  EXPECT_EQ(a.stroke_margin_m, b.stroke_margin_m);
  EXPECT_EQ(a.max_leg_speed_m_s, b.max_leg_speed_m_s);
  EXPECT_EQ(a.max_leg_acceleration_m_s2, b.max_leg_acceleration_m_s2);
  EXPECT_EQ(a.max_consecutive_deadline_misses, b.max_consecutive_deadline_misses);
  EXPECT_EQ(a.workspace_radius_m, b.workspace_radius_m);
  EXPECT_EQ(a.workspace_max_rotation_rad, b.workspace_max_rotation_rad);
  EXPECT_EQ(a.least_squares_estimator, b.least_squares_estimator);
  EXPECT_EQ(a.estimator_outlier_threshold_m, b.estimator_outlier_threshold_m);
  EXPECT_EQ(a.outer_loop.enabled, b.outer_loop.enabled);
  EXPECT_EQ(a.outer_loop.gain, b.outer_loop.gain);
  EXPECT_EQ(a.outer_loop.max_correction_m, b.outer_loop.max_correction_m);
  EXPECT_EQ(a.outer_loop.translation_gain_scale, b.outer_loop.translation_gain_scale);
  EXPECT_EQ(a.outer_loop.gate_leg_speed_m_s, b.outer_loop.gate_leg_speed_m_s);
  EXPECT_EQ(a.feedforward_enabled, b.feedforward_enabled);
  EXPECT_EQ(a.length_consistency_limit_m, b.length_consistency_limit_m);
  EXPECT_EQ(a.length_consistency_ticks, b.length_consistency_ticks);
  EXPECT_EQ(a.setpoint_lead_s, b.setpoint_lead_s);
}

void ExpectProfileEq(const hexa::DisturbanceProfile& a, const hexa::DisturbanceProfile& b) {
  EXPECT_EQ(a.sensor_noise, b.sensor_noise);
  EXPECT_EQ(a.friction_scale, b.friction_scale);
  EXPECT_EQ(a.polytropic_scale, b.polytropic_scale);
  EXPECT_EQ(a.payload_scale, b.payload_scale);
  EXPECT_EQ(a.supply_ripple_amplitude_pa, b.supply_ripple_amplitude_pa);
  EXPECT_EQ(a.supply_ripple_frequency_hz, b.supply_ripple_frequency_hz);
  EXPECT_EQ(a.joint_position_error_max_m, b.joint_position_error_max_m);
  EXPECT_EQ(a.potentiometer_offset_max_m, b.potentiometer_offset_max_m);
  EXPECT_EQ(a.potentiometer_gain_error_max, b.potentiometer_gain_error_max);
}

hexa::DisturbanceProfile IdealProfile() {
  hexa::DisturbanceProfile p;
  p.sensor_noise = false;
  p.friction_scale = 1.0;
  p.polytropic_scale = 1.0;
  p.payload_scale = 1.0;
  p.supply_ripple_amplitude_pa = 0.0;
  p.supply_ripple_frequency_hz = 0.0;
  p.joint_position_error_max_m = 0.0;
  p.potentiometer_offset_max_m = 0.0;
  p.potentiometer_gain_error_max = 0.0;
  return p;
}

void ExpectChannelEq(const hexa::ChannelCalibration& a, const hexa::ChannelCalibration& b, double tol,
                     const std::string& what) {
  EXPECT_NEAR(a.offset_si, b.offset_si, tol) << what;
  EXPECT_NEAR(a.gain_si_per_count, b.gain_si_per_count, tol) << what;
  EXPECT_NEAR(a.min_si, b.min_si, tol) << what;
  EXPECT_NEAR(a.max_si, b.max_si, tol) << what;
}

void ExpectBoardEq(const hexa::BoardCalibration& a, const hexa::BoardCalibration& b, double tol) {
  for (std::size_t i = 0; i < hexa::kNumLegs; ++i) {
    const std::string leg = "leg " + std::to_string(i + 1);
    ExpectChannelEq(a.legs[i].potentiometer_m, b.legs[i].potentiometer_m, tol, leg + " potentiometer");
    ExpectChannelEq(a.legs[i].chamber1_pressure_pa, b.legs[i].chamber1_pressure_pa, tol, leg + " chamber 1");
    ExpectChannelEq(a.legs[i].chamber2_pressure_pa, b.legs[i].chamber2_pressure_pa, tol, leg + " chamber 2");
    ExpectChannelEq(a.legs[i].valve_v, b.legs[i].valve_v, tol, leg + " valve");
  }
  ExpectChannelEq(a.supply_pressure_pa, b.supply_pressure_pa, tol, "supply");
  ExpectChannelEq(a.imu_rate_rad_s, b.imu_rate_rad_s, tol, "gyro");
  EXPECT_EQ(a.adc_bits, b.adc_bits);
  EXPECT_EQ(a.dac_bits, b.dac_bits);
  EXPECT_EQ(a.watchdog_timeout_s, b.watchdog_timeout_s);
}

SystemConfig DefaultsInCode() {
  SystemConfig c;
  c.rig_name = "HexaTaar-R";
  c.rig = hexa::MakeReferenceRig();
  c.profiles["realistic"] = hexa::DisturbanceProfile{};
  c.profiles["ideal"] = IdealProfile();
  c.default_profile = "realistic";
  return c;
}

// ---------------------------------------------------------------- the shipped file

TEST(RigConfigReference, LoadsAndEqualsCoreDefaults) {
  const ConfigResult r = hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.issues.empty());
  EXPECT_EQ(r.config.rig_name, "HexaTaar-R");
  EXPECT_EQ(r.config.source_path, hexa::config::DefaultRigFile());
  // Joint coordinates are written rounded to 1e-12 m; everything else must be exact.
  ExpectRigEq(r.config.rig, hexa::MakeReferenceRig(), 1e-12);
  ExpectLegControllerEq(r.config.leg_controller, hexa::LegControllerParams{});
  ExpectSupervisorEq(r.config.supervisor, hexa::SupervisorParams{});
  ASSERT_EQ(r.config.profiles.size(), 2u);
  ASSERT_EQ(r.config.profiles.count("realistic"), 1u);
  ASSERT_EQ(r.config.profiles.count("ideal"), 1u);
  ExpectProfileEq(r.config.profiles.at("realistic"), hexa::DisturbanceProfile{});
  ExpectProfileEq(r.config.profiles.at("ideal"), IdealProfile());
  EXPECT_EQ(r.config.default_profile, "realistic");
  ASSERT_TRUE(r.config.board.has_value());
  ExpectBoardEq(*r.config.board, hexa::MakeReferenceBoardCalibration(hexa::MakeReferenceRig()), 1e-12);
}

TEST(RigConfigReference, BoardBlockIsOptionalAndRoundTrips) {
  SystemConfig c = DefaultsInCode();  // no board: a rig the simulator drives only
  ConfigResult r = hexa::config::ParseSystemConfig(hexa::config::ToTextFormat(c), "no_board");
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_FALSE(r.config.board.has_value());
  c.board = hexa::MakeReferenceBoardCalibration(c.rig);
  c.board->legs[4].potentiometer_m.offset_si += 0.0005;
  c.board->watchdog_timeout_s = 0.02;
  r = hexa::config::ParseSystemConfig(hexa::config::ToTextFormat(c), "board");
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_TRUE(r.config.board.has_value());
  ExpectBoardEq(*r.config.board, *c.board, 0.0);
}

// A field added to a core struct must also be added to proto/rig.proto, the translation
// in config/src/rig_config.cpp, the reference file and the Expect*Eq helpers above; the
// sizes below were those when the schema was last brought in line with the structs.
TEST(RigConfigReference, CoreStructsHaveNotGrownPastTheSchema) {
  EXPECT_EQ(sizeof(hexa::AirParams), 5 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::CylinderParams), 9 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::ValveParams), 9 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::FrictionDirectionParams), 4 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::FrictionParams), 10 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::PolytropicParams), 3 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::PlatformParams), 5 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::SensorNoiseParams), 6 * sizeof(double));  // 5 doubles + int (padded)
  EXPECT_EQ(sizeof(hexa::DisturbanceProfile), 9 * sizeof(double));  // bool (padded) + 8 doubles
  EXPECT_EQ(sizeof(hexa::DifferentiatorParams), 3 * sizeof(double));  // int (padded) + 2 doubles
  EXPECT_EQ(sizeof(hexa::BsSmcParams), 32 * sizeof(double));  // 31 doubles + feedback_rate_from_observer (padded)
  EXPECT_EQ(sizeof(hexa::PiParams), 6 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::CoupledLegsParams), 4 * sizeof(double));  // 2 doubles + 2 bools (padded)
  EXPECT_EQ(sizeof(hexa::LegControllerParams), 46 * sizeof(double));
  EXPECT_EQ(sizeof(hexa::OuterLoopParams), 5 * sizeof(double));
  // + feedforward_enabled (padded), length_consistency_ticks (padded)
  EXPECT_EQ(sizeof(hexa::SupervisorParams), 20 * sizeof(double));
}

TEST(RigConfigReference, DefaultsBuiltInCodeAreValid) {
  EXPECT_TRUE(hexa::config::ValidateSystemConfig(DefaultsInCode()).empty());
}

TEST(RigConfigReference, TextFormatRoundTrip) {
  const SystemConfig original = DefaultsInCode();
  const ConfigResult r = hexa::config::ParseSystemConfig(hexa::config::ToTextFormat(original), "roundtrip");
  ASSERT_TRUE(r.ok) << r.error;
  ExpectRigEq(r.config.rig, original.rig, 0.0);  // shortest round-trip printing: exact
  ExpectLegControllerEq(r.config.leg_controller, original.leg_controller);
  ExpectSupervisorEq(r.config.supervisor, original.supervisor);
  ASSERT_EQ(r.config.profiles.size(), 2u);
  ExpectProfileEq(r.config.profiles.at("ideal"), IdealProfile());
  EXPECT_EQ(r.config.default_profile, "realistic");
}

TEST(RigConfigReference, ThrowingVariantAndMissingFile) {
  EXPECT_NO_THROW(hexa::config::LoadSystemConfigOrThrow(hexa::config::DefaultRigFile()));
  const std::string missing = kTmpDir + "/does_not_exist.textproto";
  const ConfigResult r = hexa::config::LoadSystemConfig(missing);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find(missing), std::string::npos) << r.error;
  EXPECT_THROW(hexa::config::LoadSystemConfigOrThrow(missing), hexa::config::ConfigError);
  EXPECT_THROW(hexa::config::LoadSystemConfigOrThrow(kTestDir + "/broken/negative_mass.textproto"),
               hexa::config::ConfigError);
}

TEST(RigConfigProfiles, SelectKnownDefaultAndUnknown) {
  const ConfigResult r = hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile());
  ASSERT_TRUE(r.ok) << r.error;
  const auto by_default = hexa::config::SelectProfile(r.config, "");
  ASSERT_TRUE(by_default.ok);
  EXPECT_EQ(by_default.name, "realistic");
  const auto ideal = hexa::config::SelectProfile(r.config, "ideal");
  ASSERT_TRUE(ideal.ok);
  EXPECT_FALSE(ideal.profile.sensor_noise);
  const auto unknown = hexa::config::SelectProfile(r.config, "windy");
  EXPECT_FALSE(unknown.ok);
  EXPECT_NE(unknown.error.find("unknown disturbance profile requested"), std::string::npos) << unknown.error;
  EXPECT_NE(unknown.error.find("\"windy\""), std::string::npos) << unknown.error;
  EXPECT_NE(unknown.error.find("ideal, realistic"), std::string::npos) << unknown.error;
  EXPECT_NE(unknown.error.find(hexa::config::DefaultRigFile()), std::string::npos) << unknown.error;
}

TEST(RigConfigValidate, ConfigBuiltInCodeNamesFieldValueAndLimit) {
  SystemConfig c = DefaultsInCode();
  c.rig.cylinder.annulus_area_m2 = 4e-4;
  c.leg_controller.differentiator.sigma = -1.0;
  const auto issues = hexa::config::ValidateSystemConfig(c);
  ASSERT_EQ(issues.size(), 2u);
  EXPECT_EQ(issues[0].field, "cylinder.annulus_area_m2");
  EXPECT_EQ(issues[0].value, "0.0004");
  EXPECT_EQ(issues[1].field, "leg_controller.differentiator.sigma");
  EXPECT_EQ(issues[1].limit, "> 0");
  EXPECT_EQ(issues[1].line, 0);  // no file
}

// ---------------------------------------------------------------- broken copies

struct BrokenCase {
  std::string name;
  std::string field;    // exact field path ("" for syntax errors)
  std::string message;  // substrings expected in the message, value and limit
  std::string value;
  std::string limit;
};

std::ostream& operator<<(std::ostream& out, const BrokenCase& c) { return out << c.name; }

const std::vector<BrokenCase> kBrokenCases = {
    {"syntax_error", "", "Expected \":\"", "", ""},
    {"unknown_field", "cylinder.cap_aera_m2", "did you mean 'cap_area_m2'", "cap_aera_m2", "cap_area_m2"},
    {"missing_field", "cylinder.rod_area_m2", "'rod_area_m2' is missing from block 'cylinder'", "(absent)", "every field"},
    {"missing_block", "valve", "'valve' is missing from the file", "(absent)", "every field"},
    {"negative_mass", "platform.mass_kg", "mass must be positive", "-6", "> 0"},
    {"zero_area", "cylinder.cap_area_m2", "area must be positive", "0", "> 0"},
    {"annulus_ge_cap", "cylinder.annulus_area_m2", "smaller than the cap area", "0.00035",
     "< cylinder.cap_area_m2 (0.00031416)"},
    {"valve_null_outside", "valve.null_voltage_v", "strictly between", "12", "(0, 10)"},
    {"non_finite", "friction.bristle_damping_n_s_m", "finite", "inf", "finite"},
    {"coincident_joints", "geometry.leg[id=2].p_BA_B_m", "coincides with that of leg 1", "0", ">= 0.001 m"},
    {"collinear_base", "geometry", "base joints are collinear", "0", ">= 0.001 m"},
    {"singular_geometry", "geometry", "Jacobian (eq 48) at the home pose is singular", "condition number inf", "<= 100"},
    {"ill_conditioned_geometry", "geometry", "badly conditioned", "condition number 213.4", "<= 100"},
    {"home_outside_stroke", "geometry.home_position_m", "outside the usable stroke", "0.6598",
     "[0.3884, 0.6184] m"},
    {"window_too_small", "leg_controller.differentiator.window", "window", "1", "[2, 32]"},
    {"sigma_zero", "leg_controller.differentiator.sigma", "must be positive", "0", "> 0"},
    {"unknown_profile", "default_profile", "unknown disturbance profile requested", "\"realsitic\"",
     "ideal, realistic"},
    {"duplicate_profile", "disturbance_profile[1].name", "'realistic' is defined twice (first at line",
     "\"realistic\"", "unique"},
    {"duplicate_leg_id", "geometry.leg[5].id", "leg 5 is defined twice", "5", "exactly once"},
    // Physical limits (each of these was accepted and broke the plant or the control).
    {"supply_beyond_ideal_gas", "air.supply_pressure_pa", "ideal gas", "5020000 Pa",
     "<= 3055565.012 Pa"},
    {"platform_too_heavy", "platform.mass_kg", "the legs must hold the platform", "1e+30 kg",
     "<= 34.39010948 kg"},
    {"spool_faster_than_step", "valve.spool_time_constant_s", "spool lag", "1e-09 s",
     ">= 0.0003333333333 s"},
    {"lambda_beyond_valve_chain", "leg_controller.bssmc.lambda_1_s", "lambda tau < pi/2",
     "1e+12 1/s", "<= 224.3994753 1/s"},  // pi / 2 / 7 ms (differentiator lag 1 sample)
    {"end_stop_too_stiff", "cylinder.end_stop_stiffness_n_m", "end-stop contact mode", "0.0005 s",
     "<= 5.129139494e-05 s"},
    {"heat_ratio_above_monatomic", "air.heat_ratio", "heat capacity ratio of a gas", "1.8",
     "(1, 1.6667]"},
    // Feedback rate in phi_dot and its leg observer.
    {"feedback_rate_fraction_above_one", "leg_controller.bssmc.feedback_rate_fraction",
     "fraction of the feedback part's rate in phi_dot is out of range", "1.5", "[0, 1]"},
    {"observer_mass_zero", "leg_controller.bssmc.observer_mass_kg", "observer mass must be positive", "0",
     "> 0"},
    // The BS-SMC's dither needs at least 4 control periods per cycle.
    {"dither_too_fast", "leg_controller.bssmc.dither_frequency_hz", "dither frequency", "400",
     "[0, 250]"},
    // The remote I/O board's calibration (docs/board_protocol.md).
    {"board_gain_zero", "board.leg[id=3].valve_v.gain_si_per_count", "channel gain must not be zero", "0",
     "!= 0"},
    {"board_potentiometer_short", "board.leg[id=1].potentiometer_m.min_si",
     "plausible range must cover the stroke", "0.4", "<= 0.3784"},
    {"board_five_legs", "board.leg", "the board serves exactly six legs", "5 legs", "exactly 6"},
};

class BrokenFile : public ::testing::TestWithParam<BrokenCase> {};

TEST_P(BrokenFile, ApiReportsFileLineFieldValueLimit) {
  const BrokenCase& c = GetParam();
  const std::string path = kTestDir + "/broken/" + c.name + ".textproto";
  const int line = DefectLine(path);
  const ConfigResult r = hexa::config::LoadSystemConfig(path);
  ASSERT_FALSE(r.ok);
  ASSERT_EQ(r.issues.size(), 1u) << "one defect must give one message:\n" << r.error;
  const ConfigIssue& issue = r.issues[0];
  EXPECT_EQ(issue.file, path);
  EXPECT_EQ(issue.line, line) << r.error;
  EXPECT_EQ(issue.field, c.field) << r.error;
  EXPECT_NE(issue.message.find(c.message), std::string::npos) << r.error;
  EXPECT_NE(issue.value.find(c.value), std::string::npos) << r.error;
  EXPECT_NE(issue.limit.find(c.limit), std::string::npos) << r.error;
  // The text names all of it too.
  EXPECT_EQ(r.error.rfind(path + ":" + std::to_string(line) + ":", 0), 0u) << r.error;
  EXPECT_NE(r.error.find(c.field), std::string::npos) << r.error;
  if (!c.value.empty()) {
    EXPECT_NE(r.error.find("value " + c.value), std::string::npos) << r.error;
  }
  if (!c.limit.empty()) {
    EXPECT_NE(r.error.find(c.limit), std::string::npos) << r.error;
  }
}

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

RunResult RunCheckConfig(const std::string& args, const std::string& tag,
                         const std::string& prefix = "") {
  const std::string out_path = kTmpDir + "/cli_" + tag + ".out";
  const std::string err_path = kTmpDir + "/cli_" + tag + ".err";
  const std::string cmd = prefix + "'" + HEXA_CHECK_CONFIG_BIN + "' " + args + " >'" + out_path + "' 2>'" +
                          err_path + "'";
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  r.out = ReadFile(out_path);
  r.err = ReadFile(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  return r;
}

TEST_P(BrokenFile, CliExitsNonZeroWithTheMessageOnStderr) {
  const BrokenCase& c = GetParam();
  const std::string path = kTestDir + "/broken/" + c.name + ".textproto";
  const int line = DefectLine(path);
  const RunResult r = RunCheckConfig("'" + path + "'", c.name);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_EQ(r.err.rfind(path + ":" + std::to_string(line) + ":", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(c.limit), std::string::npos) << r.err;
}

INSTANTIATE_TEST_SUITE_P(Config, BrokenFile, ::testing::ValuesIn(kBrokenCases),
                         [](const ::testing::TestParamInfo<BrokenCase>& info) { return info.param.name; });

TEST(RigConfigCli, ReferenceOkAndUnknownProfileOption) {
  const RunResult ok = RunCheckConfig("'" + hexa::config::DefaultRigFile() + "' --profile ideal", "ok");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(ok.out.rfind("OK ", 0), 0u) << ok.out;
  EXPECT_NE(ok.out.find("HexaTaar-R"), std::string::npos) << ok.out;
  const RunResult bad = RunCheckConfig("--profile windy", "badprofile");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("unknown disturbance profile requested"), std::string::npos) << bad.err;
  const RunResult usage = RunCheckConfig("--frobnicate", "usage");
  EXPECT_EQ(usage.exit_code, 2);
}

// A rig file is read whole: a device, a FIFO or a huge file is refused before reading, so that
// `hexa_check_config /dev/zero` answers at once instead of reading for ever.
TEST(RigConfigCli, DevicesFifosAndHugeFilesAreRefusedAtOnce) {
  // `timeout`: a reader without the limit would read /dev/zero until memory runs out (124).
  const RunResult zero = RunCheckConfig("/dev/zero", "devzero", "timeout 20 ");
  EXPECT_EQ(zero.exit_code, 1) << zero.err;
  EXPECT_NE(zero.err.find("/dev/zero"), std::string::npos) << zero.err;
  EXPECT_NE(zero.err.find("rig file is not a regular file"), std::string::npos) << zero.err;

  const std::string fifo = kTmpDir + "/rig_fifo";
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const ConfigResult from_fifo = hexa::config::LoadSystemConfig(fifo);  // no writer: no wait
  std::remove(fifo.c_str());
  EXPECT_FALSE(from_fifo.ok);
  EXPECT_NE(from_fifo.error.find("not a regular file"), std::string::npos) << from_fifo.error;

  // The reference rig file followed by comments up to 2 MiB: valid text, but over the limit.
  const std::string huge = kTmpDir + "/rig_huge.textproto";
  {
    std::ofstream out(huge);
    out << ReadFile(hexa::config::DefaultRigFile());
    const std::string comment = "# " + std::string(97, 'x') + "\n";
    for (int i = 0; i < 2 * 1024 * 1024 / 100; ++i) out << comment;
  }
  const ConfigResult big = hexa::config::LoadSystemConfig(huge);
  const ConfigResult big_overlay = hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile(), {huge});
  std::remove(huge.c_str());
  EXPECT_FALSE(big.ok);
  EXPECT_NE(big.error.find("more than the limit of 1048576 bytes"), std::string::npos) << big.error;
  EXPECT_FALSE(big_overlay.ok);
  EXPECT_NE(big_overlay.error.find("rig overlay is"), std::string::npos) << big_overlay.error;
}

// ---------------------------------------------------------------- every field's line

// Scalar numeric fields of the reference ("  name: 1.5e-3"), 0-based line indices.
std::vector<std::size_t> ScalarNumericLines(const std::vector<std::string>& lines) {
  static const std::regex kScalar(R"(^\s*[a-z_0-9]+: -?[0-9][0-9.e+-]*\s*(#.*)?$)");
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (std::regex_match(lines[i], kScalar)) out.push_back(i);
  }
  return out;
}

std::string FieldName(const std::string& line) {
  const auto start = line.find_first_not_of(' ');
  return line.substr(start, line.find(':') - start);
}

TEST(RigConfigLines, EveryNumericFieldMadeNanIsReportedAtItsLine) {
  const auto lines = SplitLines(ReadFile(hexa::config::DefaultRigFile()));
  const auto numeric = ScalarNumericLines(lines);
  ASSERT_GT(numeric.size(), 80u);  // the reference has ~90 scalar numeric fields
  for (std::size_t i : numeric) {
    auto edited = lines;
    edited[i] = edited[i].substr(0, edited[i].find(':') + 1) + " nan";
    const ConfigResult r = hexa::config::ParseSystemConfig(JoinLines(edited), "nan.textproto");
    ASSERT_FALSE(r.ok) << lines[i];
    ASSERT_EQ(r.issues.size(), 1u) << lines[i] << "\n" << r.error;
    EXPECT_EQ(r.issues[0].line, static_cast<int>(i) + 1) << lines[i] << "\n" << r.error;
    // Integer fields fail in the parser (nan is no integer); doubles in the finiteness check.
    if (r.issues[0].field.empty()) {
      EXPECT_NE(r.issues[0].message.find("syntax error"), std::string::npos) << r.error;
    } else {
      const std::string name = FieldName(lines[i]);
      EXPECT_EQ(r.issues[0].field.substr(r.issues[0].field.size() - name.size()), name) << r.error;
      EXPECT_EQ(r.issues[0].value, "nan") << r.error;
    }
  }
}

// Start line (0-based) of the innermost block enclosing line i, found by brace counting.
std::size_t EnclosingBlockLine(const std::vector<std::string>& lines, std::size_t i) {
  int depth = 0;
  for (std::size_t k = i; k-- > 0;) {
    const std::string code = lines[k].substr(0, lines[k].find('#'));
    for (auto it = code.rbegin(); it != code.rend(); ++it) {
      if (*it == '}') ++depth;
      if (*it == '{') {
        if (depth == 0) return k;
        --depth;
      }
    }
  }
  return 0;
}

TEST(RigConfigLines, EveryNumericFieldRemovedIsReportedAsMissingAtItsBlock) {
  const auto lines = SplitLines(ReadFile(hexa::config::DefaultRigFile()));
  for (std::size_t i : ScalarNumericLines(lines)) {
    auto edited = lines;
    edited.erase(edited.begin() + static_cast<std::ptrdiff_t>(i));
    const ConfigResult r = hexa::config::ParseSystemConfig(JoinLines(edited), "missing.textproto");
    ASSERT_FALSE(r.ok) << lines[i];
    ASSERT_EQ(r.issues.size(), 1u) << lines[i] << "\n" << r.error;
    const std::string name = FieldName(lines[i]);
    const ConfigIssue& issue = r.issues[0];
    EXPECT_EQ(issue.line, static_cast<int>(EnclosingBlockLine(lines, i)) + 1) << lines[i] << "\n" << r.error;
    EXPECT_EQ(issue.field.substr(issue.field.size() - name.size()), name) << r.error;
    EXPECT_NE(issue.message.find("'" + name + "' is missing"), std::string::npos) << r.error;
  }
}

// ---------------------------------------------------------------- one rule per parameter

// Core constructors and the rig file must check the same parameter against different
// limits (air.heat_ratio: > 1 in the plant and the controller, (1, 5/3] in the file). Now both
// call the same per-struct check: a value the file rejects, the core rejects too, naming the
// same field and limit.
struct Mutation {
  const char* field;
  const char* limit;
  void (*apply)(SystemConfig&);
};

TEST(RigConfigValidate, CoreConstructorsApplyTheSameRuleAsTheRigFile) {
  const std::vector<Mutation> mutations = {
      {"air.heat_ratio", "(1, 1.6667]", [](SystemConfig& c) { c.rig.air.heat_ratio = 1.8; }},
      {"polytropic.retract.volume", "[1, 2]", [](SystemConfig& c) { c.rig.polytropic.retract.volume = 2.5; }},
      {"friction.extend.coulomb_n", "> 0", [](SystemConfig& c) {
         c.rig.friction.extend.coulomb_n = 0.0;
         c.rig.friction.extend.static_n = 10.0;
       }},
      {"valve.spool_time_constant_s", "> 0", [](SystemConfig& c) { c.rig.valve.spool_time_constant_s = 0.0; }},
      {"cylinder.rod_area_m2", "> 0", [](SystemConfig& c) { c.rig.cylinder.rod_area_m2 = 0.0; }},
  };
  for (const Mutation& m : mutations) {
    SystemConfig c = DefaultsInCode();
    m.apply(c);
    const auto issues = hexa::config::ValidateSystemConfig(c);
    bool file_rejects = false;
    for (const auto& i : issues) file_rejects = file_rejects || (i.field == m.field && i.limit == m.limit);
    EXPECT_TRUE(file_rejects) << m.field;
    hexa::PlatformPlantConfig plant;
    plant.rig = c.rig;
    plant.disturbance = c.profiles.at("ideal");
    try {
      hexa::PlatformPlant p(plant);
      ADD_FAILURE() << m.field << ": the plant accepted what the rig file rejects";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(std::string(m.field) + ":"), std::string::npos) << what;
      EXPECT_NE(what.find(std::string("limit ") + m.limit), std::string::npos) << what;
    }
    auto leg = hexa::LegControllerConfig::FromRig(c.rig, c.leg_controller, hexa::LegControllerKind::kBsSmc);
    if (std::string(m.field).rfind("valve.spool_time", 0) == 0) continue;  // the plant's parameter
    try {
      hexa::LegController l(leg);
      ADD_FAILURE() << m.field << ": the leg controller accepted what the rig file rejects";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(m.field) + ":"), std::string::npos) << e.what();
    }
  }
  // Controller and supervisor structs.
  SystemConfig c = DefaultsInCode();
  c.leg_controller.bssmc.null_band_area_fraction = 1.5;
  c.supervisor.max_consecutive_deadline_misses = 0;
  c.supervisor.outer_loop.gain = 2.0;
  const auto issues = hexa::config::ValidateSystemConfig(c);
  ASSERT_EQ(issues.size(), 3u);
  EXPECT_THROW(hexa::LegController(hexa::LegControllerConfig::FromRig(c.rig, c.leg_controller,
                                                                      hexa::LegControllerKind::kBsSmc)),
               std::invalid_argument);
  EXPECT_THROW(hexa::Supervisor(c.rig, c.supervisor), std::invalid_argument);
}

// Four values that once passed validation, as a user would write them: each is rejected on its field with
// a physical reason; the plant, whose state they made non-finite, rejects the plant ones too.
TEST(RigConfigValidate, UnphysicalExamplesAreRejectedWithAPhysicalReason) {
  struct Case {
    const char* field;
    void (*apply)(SystemConfig&);
    bool plant;
  };
  const std::vector<Case> cases = {
      {"air.supply_pressure_pa", [](SystemConfig& c) { c.rig.air.supply_pressure_pa = 1e300; }, true},
      {"platform.mass_kg", [](SystemConfig& c) { c.rig.platform.mass_kg = 1e30; }, true},
      {"valve.spool_time_constant_s", [](SystemConfig& c) { c.rig.valve.spool_time_constant_s = 1e-9; }, true},
      {"leg_controller.bssmc.lambda_1_s", [](SystemConfig& c) { c.leg_controller.bssmc.lambda_1_s = 1e12; }, false},
  };
  for (const Case& k : cases) {
    SystemConfig c = DefaultsInCode();
    k.apply(c);
    const auto issues = hexa::config::ValidateSystemConfig(c);
    bool found = false;
    for (const auto& i : issues) {
      if (i.field == k.field) {
        found = true;
        EXPECT_TRUE(i.physical_limit) << i.message;
        EXPECT_NE(i.message.find("physical limit: "), std::string::npos) << i.message;
      }
    }
    EXPECT_TRUE(found) << k.field;
    if (!k.plant) continue;
    hexa::PlatformPlantConfig plant;
    plant.rig = c.rig;
    plant.disturbance = c.profiles.at("realistic");
    try {
      hexa::PlatformPlant p(plant);
      ADD_FAILURE() << k.field << ": the plant accepted it";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(k.field), std::string::npos) << e.what();
    }
  }
}

TEST(RigConfigCli, ExplainPrintsEveryDerivedLimitWithItsReason) {
  const RunResult r = RunCheckConfig("--explain '" + hexa::config::DefaultRigFile() + "'", "explain");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* field : {"air.supply_pressure_pa", "platform.mass_kg", "valve.spool_time_constant_s",
                            "cylinder.dead_volume_m3", "cylinder.end_stop_stiffness_n_m",
                            "friction.bristle_stiffness_n_m", "leg_controller.bssmc.lambda_1_s",
                            "leg_controller.bssmc.backstepping_beta_1_s",
                            "leg_controller.bssmc.switching_gain_n", "leg_controller.pi.proportional_v_m"}) {
    EXPECT_NE(r.out.find(std::string("[") + field + "]"), std::string::npos) << field << "\n" << r.out;
  }
  EXPECT_EQ(r.out.find("VIOLATED"), std::string::npos) << r.out;
  const RunResult bad = RunCheckConfig("--explain '" + kTestDir + "/broken/platform_too_heavy.textproto'", "explain_bad");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.out.find("VIOLATED  platform mass [platform.mass_kg]: 1e+30 kg, limit <= 34.39010948 kg"),
            std::string::npos) << bad.out;
}

}  // namespace
