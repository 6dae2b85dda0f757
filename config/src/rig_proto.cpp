// The rig file's messages (proto/rig.proto) and the core's parameter structs, both ways: one
// pair of functions per block, side by side, so that a field added to one direction and not
// the other shows in review. FromRigFile assumes a checked file (every field present, six
// legs with ids 1..6, unique profile names: rig_config.cpp's stages 1-3).
#include "rig_proto.hpp"

namespace hexa::config::internal {
namespace {

Eigen::Vector3d FromPb(const pb::Vector3& v) { return {v.x(), v.y(), v.z()}; }
void ToPb(const Eigen::Vector3d& v, pb::Vector3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

FrictionDirectionParams FromPb(const pb::FrictionDirectionConfig& f) {
  FrictionDirectionParams p;
  p.stribeck_velocity_m_s = f.stribeck_velocity_m_s();
  p.viscous_n_s_m = f.viscous_n_s_m();
  p.static_n = f.static_n();
  p.coulomb_n = f.coulomb_n();
  return p;
}
void ToPb(const FrictionDirectionParams& p, pb::FrictionDirectionConfig* f) {
  f->set_stribeck_velocity_m_s(p.stribeck_velocity_m_s);
  f->set_viscous_n_s_m(p.viscous_n_s_m);
  f->set_static_n(p.static_n);
  f->set_coulomb_n(p.coulomb_n);
}

PolytropicParams FromPb(const pb::PolytropicConfig& g) {
  PolytropicParams p;
  p.inflow = g.inflow();
  p.outflow = g.outflow();
  p.volume = g.volume();
  return p;
}
void ToPb(const PolytropicParams& p, pb::PolytropicConfig* g) {
  g->set_inflow(p.inflow);
  g->set_outflow(p.outflow);
  g->set_volume(p.volume);
}

DisturbanceProfile FromPb(const pb::DisturbanceProfileConfig& d) {
  DisturbanceProfile p;
  p.sensor_noise = d.sensor_noise();
  p.friction_scale = d.friction_scale();
  p.polytropic_scale = d.polytropic_scale();
  p.payload_scale = d.payload_scale();
  p.supply_ripple_amplitude_pa = d.supply_ripple_amplitude_pa();
  p.supply_ripple_frequency_hz = d.supply_ripple_frequency_hz();
  p.joint_position_error_max_m = d.joint_position_error_max_m();
  p.potentiometer_offset_max_m = d.potentiometer_offset_max_m();
  p.potentiometer_gain_error_max = d.potentiometer_gain_error_max();
  return p;
}
void ToPb(const std::string& name, const DisturbanceProfile& p, pb::DisturbanceProfileConfig* d) {
  d->set_name(name);
  d->set_sensor_noise(p.sensor_noise);
  d->set_friction_scale(p.friction_scale);
  d->set_polytropic_scale(p.polytropic_scale);
  d->set_payload_scale(p.payload_scale);
  d->set_supply_ripple_amplitude_pa(p.supply_ripple_amplitude_pa);
  d->set_supply_ripple_frequency_hz(p.supply_ripple_frequency_hz);
  d->set_joint_position_error_max_m(p.joint_position_error_max_m);
  d->set_potentiometer_offset_max_m(p.potentiometer_offset_max_m);
  d->set_potentiometer_gain_error_max(p.potentiometer_gain_error_max);
}

ChannelCalibration FromPb(const pb::ChannelCalibrationConfig& c) {
  return {c.offset_si(), c.gain_si_per_count(), c.min_si(), c.max_si()};
}
void ToPb(const ChannelCalibration& c, pb::ChannelCalibrationConfig* out) {
  out->set_offset_si(c.offset_si);
  out->set_gain_si_per_count(c.gain_si_per_count);
  out->set_min_si(c.min_si);
  out->set_max_si(c.max_si);
}

BoardCalibration FromPb(const pb::BoardConfig& f) {
  BoardCalibration b;
  for (const pb::BoardLegChannelsConfig& leg : f.leg()) {
    BoardLegCalibration& l = b.legs[static_cast<std::size_t>(leg.id() - 1)];
    l.potentiometer_m = FromPb(leg.potentiometer_m());
    l.chamber1_pressure_pa = FromPb(leg.chamber1_pressure_pa());
    l.chamber2_pressure_pa = FromPb(leg.chamber2_pressure_pa());
    l.valve_v = FromPb(leg.valve_v());
  }
  b.supply_pressure_pa = FromPb(f.supply_pressure_pa());
  b.imu_rate_rad_s = FromPb(f.imu_rate_rad_s());
  b.adc_bits = f.adc_bits();
  b.dac_bits = f.dac_bits();
  b.watchdog_timeout_s = f.watchdog_timeout_s();
  return b;
}
void ToPb(const BoardCalibration& b, pb::BoardConfig* f) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    pb::BoardLegChannelsConfig* leg = f->add_leg();
    leg->set_id(static_cast<int>(i + 1));
    ToPb(b.legs[i].potentiometer_m, leg->mutable_potentiometer_m());
    ToPb(b.legs[i].chamber1_pressure_pa, leg->mutable_chamber1_pressure_pa());
    ToPb(b.legs[i].chamber2_pressure_pa, leg->mutable_chamber2_pressure_pa());
    ToPb(b.legs[i].valve_v, leg->mutable_valve_v());
  }
  ToPb(b.supply_pressure_pa, f->mutable_supply_pressure_pa());
  ToPb(b.imu_rate_rad_s, f->mutable_imu_rate_rad_s());
  f->set_adc_bits(b.adc_bits);
  f->set_dac_bits(b.dac_bits);
  f->set_watchdog_timeout_s(b.watchdog_timeout_s);
}

// The rig's physics: air, geometry, cylinder, valve, friction, polytropic exponents, platform,
// sensors.
void FromPb(const pb::RigFile& f, RigParams& rig) {
  rig.air.heat_ratio = f.air().heat_ratio();
  rig.air.temperature_k = f.air().temperature_k();
  rig.air.gas_constant_j_kg_k = f.air().gas_constant_j_kg_k();
  rig.air.atmosphere_pressure_pa = f.air().atmosphere_pressure_pa();
  rig.air.supply_pressure_pa = f.air().supply_pressure_pa();

  for (const pb::LegConfig& leg : f.geometry().leg()) {
    const auto i = static_cast<std::size_t>(leg.id() - 1);
    rig.geometry.p_BA_B[i] = FromPb(leg.p_ba_b_m());
    rig.geometry.p_PB_P[i] = FromPb(leg.p_pb_p_m());
  }
  rig.geometry.home_position_m = FromPb(f.geometry().home_position_m());

  const pb::CylinderConfig& y = f.cylinder();
  rig.cylinder.cap_area_m2 = y.cap_area_m2();
  rig.cylinder.annulus_area_m2 = y.annulus_area_m2();
  rig.cylinder.rod_area_m2 = y.rod_area_m2();
  rig.cylinder.stroke_m = y.stroke_m();
  rig.cylinder.dead_volume_m3 = y.dead_volume_m3();
  rig.cylinder.moving_mass_kg = y.moving_mass_kg();
  rig.cylinder.mid_stroke_length_m = y.mid_stroke_length_m();
  rig.cylinder.end_stop_stiffness_n_m = y.end_stop_stiffness_n_m();
  rig.cylinder.end_stop_damping_n_s_m = y.end_stop_damping_n_s_m();

  const pb::ValveConfig& v = f.valve();
  rig.valve.min_voltage_v = v.min_voltage_v();
  rig.valve.max_voltage_v = v.max_voltage_v();
  rig.valve.null_voltage_v = v.null_voltage_v();
  rig.valve.spool_gain_m_v = v.spool_gain_m_v();
  rig.valve.spool_offset_m = v.spool_offset_m();
  rig.valve.max_spool_m = v.max_spool_m();
  rig.valve.max_orifice_area_m2 = v.max_orifice_area_m2();
  rig.valve.discharge_coefficient = v.discharge_coefficient();
  rig.valve.spool_time_constant_s = v.spool_time_constant_s();

  rig.friction.extend = FromPb(f.friction().extend());
  rig.friction.retract = FromPb(f.friction().retract());
  rig.friction.bristle_stiffness_n_m = f.friction().bristle_stiffness_n_m();
  rig.friction.bristle_damping_n_s_m = f.friction().bristle_damping_n_s_m();
  rig.polytropic.extend = FromPb(f.polytropic().extend());
  rig.polytropic.retract = FromPb(f.polytropic().retract());

  rig.platform.mass_kg = f.platform().mass_kg();
  rig.platform.inertia_diag_kg_m2 = FromPb(f.platform().inertia_diag_kg_m2());
  rig.platform.gravity_m_s2 = f.platform().gravity_m_s2();

  const pb::SensorNoiseConfig& s = f.sensors();
  rig.sensors.length_sigma_m = s.length_sigma_m();
  rig.sensors.length_bits = s.length_bits();
  rig.sensors.pressure_sigma_pa = s.pressure_sigma_pa();
  rig.sensors.imu_orientation_sigma_rad = s.imu_orientation_sigma_rad();
  rig.sensors.imu_bias_walk_rad_sqrt_s = s.imu_bias_walk_rad_sqrt_s();
  rig.sensors.imu_period_s = s.imu_period_s();
}
void ToPb(const RigParams& rig, pb::RigFile& f) {
  pb::AirConfig* air = f.mutable_air();
  air->set_heat_ratio(rig.air.heat_ratio);
  air->set_temperature_k(rig.air.temperature_k);
  air->set_gas_constant_j_kg_k(rig.air.gas_constant_j_kg_k);
  air->set_atmosphere_pressure_pa(rig.air.atmosphere_pressure_pa);
  air->set_supply_pressure_pa(rig.air.supply_pressure_pa);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    pb::LegConfig* leg = f.mutable_geometry()->add_leg();
    leg->set_id(static_cast<int>(i + 1));
    ToPb(rig.geometry.p_BA_B[i], leg->mutable_p_ba_b_m());
    ToPb(rig.geometry.p_PB_P[i], leg->mutable_p_pb_p_m());
  }
  ToPb(rig.geometry.home_position_m, f.mutable_geometry()->mutable_home_position_m());
  pb::CylinderConfig* y = f.mutable_cylinder();
  y->set_cap_area_m2(rig.cylinder.cap_area_m2);
  y->set_annulus_area_m2(rig.cylinder.annulus_area_m2);
  y->set_rod_area_m2(rig.cylinder.rod_area_m2);
  y->set_stroke_m(rig.cylinder.stroke_m);
  y->set_dead_volume_m3(rig.cylinder.dead_volume_m3);
  y->set_moving_mass_kg(rig.cylinder.moving_mass_kg);
  y->set_mid_stroke_length_m(rig.cylinder.mid_stroke_length_m);
  y->set_end_stop_stiffness_n_m(rig.cylinder.end_stop_stiffness_n_m);
  y->set_end_stop_damping_n_s_m(rig.cylinder.end_stop_damping_n_s_m);
  pb::ValveConfig* v = f.mutable_valve();
  v->set_min_voltage_v(rig.valve.min_voltage_v);
  v->set_max_voltage_v(rig.valve.max_voltage_v);
  v->set_null_voltage_v(rig.valve.null_voltage_v);
  v->set_spool_gain_m_v(rig.valve.spool_gain_m_v);
  v->set_spool_offset_m(rig.valve.spool_offset_m);
  v->set_max_spool_m(rig.valve.max_spool_m);
  v->set_max_orifice_area_m2(rig.valve.max_orifice_area_m2);
  v->set_discharge_coefficient(rig.valve.discharge_coefficient);
  v->set_spool_time_constant_s(rig.valve.spool_time_constant_s);
  ToPb(rig.friction.extend, f.mutable_friction()->mutable_extend());
  ToPb(rig.friction.retract, f.mutable_friction()->mutable_retract());
  f.mutable_friction()->set_bristle_stiffness_n_m(rig.friction.bristle_stiffness_n_m);
  f.mutable_friction()->set_bristle_damping_n_s_m(rig.friction.bristle_damping_n_s_m);
  ToPb(rig.polytropic.extend, f.mutable_polytropic()->mutable_extend());
  ToPb(rig.polytropic.retract, f.mutable_polytropic()->mutable_retract());
  f.mutable_platform()->set_mass_kg(rig.platform.mass_kg);
  ToPb(rig.platform.inertia_diag_kg_m2, f.mutable_platform()->mutable_inertia_diag_kg_m2());
  f.mutable_platform()->set_gravity_m_s2(rig.platform.gravity_m_s2);
  pb::SensorNoiseConfig* s = f.mutable_sensors();
  s->set_length_sigma_m(rig.sensors.length_sigma_m);
  s->set_length_bits(rig.sensors.length_bits);
  s->set_pressure_sigma_pa(rig.sensors.pressure_sigma_pa);
  s->set_imu_orientation_sigma_rad(rig.sensors.imu_orientation_sigma_rad);
  s->set_imu_bias_walk_rad_sqrt_s(rig.sensors.imu_bias_walk_rad_sqrt_s);
  s->set_imu_period_s(rig.sensors.imu_period_s);
}

LegControllerParams FromPb(const pb::LegControllerConfig& lc) {
  LegControllerParams p;
  p.differentiator.window = lc.differentiator().window();
  p.differentiator.sigma = lc.differentiator().sigma();
  p.differentiator.centre_lag_samples = lc.differentiator().centre_lag_samples();
  const pb::BsSmcConfig& b = lc.bssmc();
  p.bssmc.lambda_1_s = b.lambda_1_s();
  p.bssmc.switching_gain_n = b.switching_gain_n();
  p.bssmc.boundary_layer_xi_s_m = b.boundary_layer_xi_s_m();
  p.bssmc.backstepping_beta_1_s = b.backstepping_beta_1_s();
  p.bssmc.effective_mass_kg = b.effective_mass_kg();
  p.bssmc.gravity_load_n = b.gravity_load_n();
  p.bssmc.viscous_estimate_scale = b.viscous_estimate_scale();
  p.bssmc.friction_estimate_scale = b.friction_estimate_scale();
  p.bssmc.friction_smoothing_velocity_m_s = b.friction_smoothing_velocity_m_s();
  p.bssmc.reaching_proportional_n_s_m = b.reaching_proportional_n_s_m();
  p.bssmc.null_band_area_fraction = b.null_band_area_fraction();
  p.bssmc.spool_filter_time_constant_s = b.spool_filter_time_constant_s();
  p.bssmc.integral_gain_n_m = b.integral_gain_n_m();
  p.bssmc.integral_limit_n = b.integral_limit_n();
  p.bssmc.integral_active_below_m_s = b.integral_active_below_m_s();
  p.bssmc.integral_leak_time_constant_s = b.integral_leak_time_constant_s();
  p.bssmc.integral_deadband_m = b.integral_deadband_m();
  p.bssmc.feedback_rate_fraction = b.feedback_rate_fraction();
  p.bssmc.feedback_rate_time_constant_s = b.feedback_rate_time_constant_s();
  p.bssmc.feedback_rate_from_observer = b.feedback_rate_from_observer();
  p.bssmc.observer_mass_kg = b.observer_mass_kg();
  p.bssmc.observer_length_sigma_m = b.observer_length_sigma_m();
  p.bssmc.observer_force_sigma_n = b.observer_force_sigma_n();
  p.bssmc.observer_disturbance_rate_m_s3 = b.observer_disturbance_rate_m_s3();
  p.bssmc.feedback_rate_full_speed_m_s = b.feedback_rate_full_speed_m_s();
  p.bssmc.dither_amplitude_n = b.dither_amplitude_n();
  p.bssmc.dither_frequency_hz = b.dither_frequency_hz();
  p.bssmc.dither_gate_speed_m_s = b.dither_gate_speed_m_s();
  p.bssmc.friction_adaptation_rate_1_n_m = b.friction_adaptation_rate_1_n_m();
  p.bssmc.friction_adaptation_speed_m_s = b.friction_adaptation_speed_m_s();
  p.bssmc.friction_adaptation_min_scale = b.friction_adaptation_min_scale();
  p.bssmc.friction_adaptation_max_scale = b.friction_adaptation_max_scale();
  p.pi.proportional_v_m = lc.pi().proportional_v_m();
  p.pi.integral_v_m_s = lc.pi().integral_v_m_s();
  p.pi.integrator_limit_v = lc.pi().integrator_limit_v();
  p.pi.velocity_feedforward_v_s_m = lc.pi().velocity_feedforward_v_s_m();
  p.pi.rate_damping_v_s_m = lc.pi().rate_damping_v_s_m();
  p.pi.force_feedforward_v_n = lc.pi().force_feedforward_v_n();
  p.setpoint_timeout_s = lc.setpoint_timeout_s();
  if (lc.has_coupled_legs()) {
    const pb::CoupledLegsConfig& k = lc.coupled_legs();
    p.coupled.enabled = k.enabled();
    p.coupled.gain = k.gain();
    p.coupled.cutoff_hz = k.cutoff_hz();
    p.coupled.raise_only = k.raise_only();
  }
  return p;
}
void ToPb(const LegControllerParams& p, pb::LegControllerConfig* lc) {
  lc->mutable_differentiator()->set_window(p.differentiator.window);
  lc->mutable_differentiator()->set_sigma(p.differentiator.sigma);
  lc->mutable_differentiator()->set_centre_lag_samples(p.differentiator.centre_lag_samples);
  pb::BsSmcConfig* b = lc->mutable_bssmc();
  b->set_lambda_1_s(p.bssmc.lambda_1_s);
  b->set_switching_gain_n(p.bssmc.switching_gain_n);
  b->set_boundary_layer_xi_s_m(p.bssmc.boundary_layer_xi_s_m);
  b->set_backstepping_beta_1_s(p.bssmc.backstepping_beta_1_s);
  b->set_effective_mass_kg(p.bssmc.effective_mass_kg);
  b->set_gravity_load_n(p.bssmc.gravity_load_n);
  b->set_viscous_estimate_scale(p.bssmc.viscous_estimate_scale);
  b->set_friction_estimate_scale(p.bssmc.friction_estimate_scale);
  b->set_friction_smoothing_velocity_m_s(p.bssmc.friction_smoothing_velocity_m_s);
  b->set_reaching_proportional_n_s_m(p.bssmc.reaching_proportional_n_s_m);
  b->set_null_band_area_fraction(p.bssmc.null_band_area_fraction);
  b->set_spool_filter_time_constant_s(p.bssmc.spool_filter_time_constant_s);
  b->set_integral_gain_n_m(p.bssmc.integral_gain_n_m);
  b->set_integral_limit_n(p.bssmc.integral_limit_n);
  b->set_integral_active_below_m_s(p.bssmc.integral_active_below_m_s);
  b->set_integral_leak_time_constant_s(p.bssmc.integral_leak_time_constant_s);
  b->set_integral_deadband_m(p.bssmc.integral_deadband_m);
  b->set_feedback_rate_fraction(p.bssmc.feedback_rate_fraction);
  b->set_feedback_rate_time_constant_s(p.bssmc.feedback_rate_time_constant_s);
  b->set_feedback_rate_from_observer(p.bssmc.feedback_rate_from_observer);
  b->set_observer_mass_kg(p.bssmc.observer_mass_kg);
  b->set_observer_length_sigma_m(p.bssmc.observer_length_sigma_m);
  b->set_observer_force_sigma_n(p.bssmc.observer_force_sigma_n);
  b->set_observer_disturbance_rate_m_s3(p.bssmc.observer_disturbance_rate_m_s3);
  b->set_feedback_rate_full_speed_m_s(p.bssmc.feedback_rate_full_speed_m_s);
  b->set_dither_amplitude_n(p.bssmc.dither_amplitude_n);
  b->set_dither_frequency_hz(p.bssmc.dither_frequency_hz);
  b->set_dither_gate_speed_m_s(p.bssmc.dither_gate_speed_m_s);
  b->set_friction_adaptation_rate_1_n_m(p.bssmc.friction_adaptation_rate_1_n_m);
  b->set_friction_adaptation_speed_m_s(p.bssmc.friction_adaptation_speed_m_s);
  b->set_friction_adaptation_min_scale(p.bssmc.friction_adaptation_min_scale);
  b->set_friction_adaptation_max_scale(p.bssmc.friction_adaptation_max_scale);
  lc->mutable_pi()->set_proportional_v_m(p.pi.proportional_v_m);
  lc->mutable_pi()->set_integral_v_m_s(p.pi.integral_v_m_s);
  lc->mutable_pi()->set_integrator_limit_v(p.pi.integrator_limit_v);
  lc->mutable_pi()->set_velocity_feedforward_v_s_m(p.pi.velocity_feedforward_v_s_m);
  lc->mutable_pi()->set_rate_damping_v_s_m(p.pi.rate_damping_v_s_m);
  lc->mutable_pi()->set_force_feedforward_v_n(p.pi.force_feedforward_v_n);
  lc->set_setpoint_timeout_s(p.setpoint_timeout_s);
  pb::CoupledLegsConfig* k = lc->mutable_coupled_legs();
  k->set_enabled(p.coupled.enabled);
  k->set_gain(p.coupled.gain);
  k->set_cutoff_hz(p.coupled.cutoff_hz);
  k->set_raise_only(p.coupled.raise_only);
}

SoftLimitParams FromPb(const pb::SoftLimitsConfig& f) {
  SoftLimitParams p;
  p.max_base_joint_angle_rad = f.max_base_joint_angle_rad();
  p.max_platform_joint_angle_rad = f.max_platform_joint_angle_rad();
  const pb::Vector3& lo = f.position_min_from_home_m();
  const pb::Vector3& hi = f.position_max_from_home_m();
  p.position_min_from_home_m = {lo.x(), lo.y(), lo.z()};
  p.position_max_from_home_m = {hi.x(), hi.y(), hi.z()};
  const pb::RollPitchYaw& rlo = f.rotation_min_rad();
  const pb::RollPitchYaw& rhi = f.rotation_max_rad();
  p.rotation_min_rad = {rlo.roll(), rlo.pitch(), rlo.yaw()};
  p.rotation_max_rad = {rhi.roll(), rhi.pitch(), rhi.yaw()};
  p.max_linear_speed_m_s = f.max_linear_speed_m_s();
  p.max_angular_speed_rad_s = f.max_angular_speed_rad_s();
  return p;
}
void ToPb(const SoftLimitParams& p, pb::SoftLimitsConfig* f) {
  f->set_max_base_joint_angle_rad(p.max_base_joint_angle_rad);
  f->set_max_platform_joint_angle_rad(p.max_platform_joint_angle_rad);
  const auto vec = [](const std::array<double, 3>& v, pb::Vector3* out) {
    out->set_x(v[0]);
    out->set_y(v[1]);
    out->set_z(v[2]);
  };
  const auto rpy = [](const std::array<double, 3>& v, pb::RollPitchYaw* out) {
    out->set_roll(v[0]);
    out->set_pitch(v[1]);
    out->set_yaw(v[2]);
  };
  vec(p.position_min_from_home_m, f->mutable_position_min_from_home_m());
  vec(p.position_max_from_home_m, f->mutable_position_max_from_home_m());
  rpy(p.rotation_min_rad, f->mutable_rotation_min_rad());
  rpy(p.rotation_max_rad, f->mutable_rotation_max_rad());
  f->set_max_linear_speed_m_s(p.max_linear_speed_m_s);
  f->set_max_angular_speed_rad_s(p.max_angular_speed_rad_s);
}

SupervisorParams FromPb(const pb::SupervisorConfig& sv) {
  SupervisorParams p;
  p.period_s = sv.period_s();
  p.blend_duration_s = sv.blend_duration_s();
  p.stop_duration_s = sv.stop_duration_s();
  p.stroke_margin_m = sv.stroke_margin_m();
  p.max_leg_speed_m_s = sv.max_leg_speed_m_s();
  p.max_leg_acceleration_m_s2 = sv.max_leg_acceleration_m_s2();
  p.max_consecutive_deadline_misses = sv.max_consecutive_deadline_misses();
  p.workspace_radius_m = sv.workspace_radius_m();
  p.workspace_max_rotation_rad = sv.workspace_max_rotation_rad();
  p.least_squares_estimator = sv.least_squares_estimator();
  p.estimator_outlier_threshold_m = sv.estimator_outlier_threshold_m();
  p.feedforward_enabled = sv.feedforward_enabled();
  p.length_consistency_limit_m = sv.length_consistency_limit_m();
  p.length_consistency_ticks = sv.length_consistency_ticks();
  p.setpoint_lead_s = sv.setpoint_lead_s();
  p.outer_loop.enabled = sv.outer_loop().enabled();
  p.outer_loop.gain = sv.outer_loop().gain();
  p.outer_loop.max_correction_m = sv.outer_loop().max_correction_m();
  p.outer_loop.translation_gain_scale = sv.outer_loop().translation_gain_scale();
  p.outer_loop.gate_leg_speed_m_s = sv.outer_loop().gate_leg_speed_m_s();
  p.soft_limits = FromPb(sv.soft_limits());
  return p;
}
void ToPb(const SupervisorParams& p, pb::SupervisorConfig* sv) {
  sv->set_period_s(p.period_s);
  sv->set_blend_duration_s(p.blend_duration_s);
  sv->set_stop_duration_s(p.stop_duration_s);
  sv->set_stroke_margin_m(p.stroke_margin_m);
  sv->set_max_leg_speed_m_s(p.max_leg_speed_m_s);
  sv->set_max_leg_acceleration_m_s2(p.max_leg_acceleration_m_s2);
  sv->set_max_consecutive_deadline_misses(p.max_consecutive_deadline_misses);
  sv->set_workspace_radius_m(p.workspace_radius_m);
  sv->set_workspace_max_rotation_rad(p.workspace_max_rotation_rad);
  sv->set_least_squares_estimator(p.least_squares_estimator);
  sv->set_estimator_outlier_threshold_m(p.estimator_outlier_threshold_m);
  sv->set_feedforward_enabled(p.feedforward_enabled);
  sv->set_length_consistency_limit_m(p.length_consistency_limit_m);
  sv->set_length_consistency_ticks(p.length_consistency_ticks);
  sv->set_setpoint_lead_s(p.setpoint_lead_s);
  sv->mutable_outer_loop()->set_enabled(p.outer_loop.enabled);
  sv->mutable_outer_loop()->set_gain(p.outer_loop.gain);
  sv->mutable_outer_loop()->set_max_correction_m(p.outer_loop.max_correction_m);
  sv->mutable_outer_loop()->set_translation_gain_scale(p.outer_loop.translation_gain_scale);
  sv->mutable_outer_loop()->set_gate_leg_speed_m_s(p.outer_loop.gate_leg_speed_m_s);
  ToPb(p.soft_limits, sv->mutable_soft_limits());
}

}  // namespace

SystemConfig FromRigFile(const pb::RigFile& f) {
  SystemConfig c;
  c.rig_name = f.rig_name();
  FromPb(f, c.rig);
  c.leg_controller = FromPb(f.leg_controller());
  c.supervisor = FromPb(f.supervisor());
  for (const pb::DisturbanceProfileConfig& d : f.disturbance_profile()) c.profiles[d.name()] = FromPb(d);
  c.default_profile = f.default_profile();
  if (f.has_board()) c.board = FromPb(f.board());
  return c;
}

pb::RigFile ToRigFile(const SystemConfig& c) {
  pb::RigFile f;
  f.set_rig_name(c.rig_name);
  ToPb(c.rig, f);
  ToPb(c.leg_controller, f.mutable_leg_controller());
  ToPb(c.supervisor, f.mutable_supervisor());
  for (const auto& [name, profile] : c.profiles) ToPb(name, profile, f.add_disturbance_profile());
  f.set_default_profile(c.default_profile);
  if (c.board) ToPb(*c.board, f.mutable_board());
  return f;
}

}  // namespace hexa::config::internal
