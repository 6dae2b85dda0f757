// Rig file loader (config/): the shipped reference file equals the core defaults, the profiles,
// and one validation rule per parameter shared by the core and the file. The broken copies and
// the line mapping: test_rig_config_files.cpp.
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
#include "rig_config_test_util.hpp"

namespace {

using hexa::config::ConfigIssue;
using hexa::config::ConfigResult;
using hexa::config::SystemConfig;
using namespace rig_config_test;

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
  const hexa::SoftLimitParams& x = a.soft_limits;
  const hexa::SoftLimitParams& y = b.soft_limits;
  EXPECT_EQ(x.max_base_joint_angle_rad, y.max_base_joint_angle_rad);
  EXPECT_EQ(x.max_platform_joint_angle_rad, y.max_platform_joint_angle_rad);
  EXPECT_EQ(x.position_min_from_home_m, y.position_min_from_home_m);
  EXPECT_EQ(x.position_max_from_home_m, y.position_max_from_home_m);
  EXPECT_EQ(x.rotation_min_rad, y.rotation_min_rad);
  EXPECT_EQ(x.rotation_max_rad, y.rotation_max_rad);
  EXPECT_EQ(x.max_linear_speed_m_s, y.max_linear_speed_m_s);
  EXPECT_EQ(x.max_angular_speed_rad_s, y.max_angular_speed_rad_s);
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
// in config/src/rig_proto.cpp, the reference file and the Expect*Eq helpers above; the
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
  EXPECT_EQ(sizeof(hexa::SoftLimitParams), 16 * sizeof(double));
  // + feedforward_enabled (padded), length_consistency_ticks (padded), soft_limits
  EXPECT_EQ(sizeof(hexa::SupervisorParams), 36 * sizeof(double));
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

// The soft limits written in the rig file are the ones the supervisor holds its setpoints in
// (the box about home, the joints, the speeds), and the supervisor refuses what the file does.
TEST(RigConfigValidate, SoftLimitsOfTheRigFileAreTheSupervisors) {
  std::string text = ReadFile(hexa::config::DefaultRigFile());
  const auto set = [&](const std::string& pattern, const std::string& replacement) {
    const std::string before = text;
    text = std::regex_replace(text, std::regex(pattern), replacement);
    ASSERT_NE(text, before) << pattern;
  };
  set("max_platform_joint_angle_rad: 0.8", "max_platform_joint_angle_rad: 0.15");
  set("position_max_from_home_m \\{[^}]*\\}", "position_max_from_home_m { x: 0.03 y: 0.1 z: 0.1 }");
  set("rotation_min_rad \\{[^}]*\\}", "rotation_min_rad { roll: -0.3 pitch: -0.3 yaw: -0.05 }");
  set("max_linear_speed_m_s: 0.8", "max_linear_speed_m_s: 0.4");
  const ConfigResult r = hexa::config::ParseSystemConfig(text, "tight_soft_limits");
  ASSERT_TRUE(r.ok) << r.error;
  const hexa::Supervisor supervisor(hexa::config::MakeSupervisorRig(r.config), r.config.supervisor);
  const hexa::SoftLimitsConfig& limits = supervisor.operator_motion().limits().config();
  const Eigen::Vector3d home = r.config.rig.geometry.home_position_m;
  EXPECT_DOUBLE_EQ(limits.box_max[0], home.x() + 0.03);
  EXPECT_DOUBLE_EQ(limits.box_min[0], home.x() - 0.1);
  EXPECT_DOUBLE_EQ(limits.box_max[2], home.z() + 0.1);
  EXPECT_DOUBLE_EQ(limits.box_min[5], -0.05);
  EXPECT_DOUBLE_EQ(limits.box_max[5], 0.3);
  EXPECT_DOUBLE_EQ(limits.max_platform_joint_angle_rad, 0.15);
  EXPECT_DOUBLE_EQ(limits.max_base_joint_angle_rad, 0.8);
  EXPECT_DOUBLE_EQ(limits.max_linear_speed_m_s, 0.4);
  EXPECT_DOUBLE_EQ(limits.max_angular_speed_rad_s, 1.0);
  EXPECT_DOUBLE_EQ(limits.stroke_margin_m, r.config.supervisor.stroke_margin_m);
  EXPECT_DOUBLE_EQ(limits.max_leg_speed_m_s, r.config.supervisor.max_leg_speed_m_s);
  // A box that leaves home out: the file and the supervisor refuse it on the same field.
  SystemConfig bad = r.config;
  bad.supervisor.soft_limits.position_min_from_home_m[1] = 0.01;
  const auto issues = hexa::config::ValidateSystemConfig(bad);
  ASSERT_EQ(issues.size(), 1u);
  EXPECT_EQ(issues[0].field, "supervisor.soft_limits.position_min_from_home_m.y");
  EXPECT_EQ(issues[0].limit, "< 0");
  try {
    hexa::Supervisor s(bad.rig, bad.supervisor);
    ADD_FAILURE() << "the supervisor accepted a box without home";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("supervisor.soft_limits.position_min_from_home_m.y"),
              std::string::npos) << e.what();
  }
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
