// Rig file loader: protobuf text format -> hexa::config::SystemConfig.
//
// Stages, each stopping at its first failing stage so that messages stay about the cause:
//   1. parse (syntax, unknown fields, repeated singular fields): the parser's line/column;
//   2. presence and finiteness of every field (reflection over the schema), with the line
//      of the field (non-finite) or of its enclosing block (missing);
//   3. structure: six legs with ids 1..6, unique profile names;
//   4. translation into the core structs and value rules (validate.cpp); each rule names a
//      field path that is mapped back to its line through the parser's ParseInfoTree.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "hexa/config/rig_config.hpp"
#include "bounded_file.hpp"
#include "internal.hpp"
#include "rig.pb.h"
#include "text_format.hpp"

namespace hexa::config {

namespace gp = google::protobuf;
using internal::CountLines;
using internal::ElementSelector;
using internal::FormatDouble;
using internal::FromRange;
using internal::Locate;
using internal::Location;
using ParseInfoTree = gp::TextFormat::ParseInfoTree;

std::string ConfigIssue::ToString() const {
  std::ostringstream out;
  out << file << ":" << line << ":" << column << ": error: ";
  if (!field.empty()) out << field << ": ";
  out << message;
  if (!value.empty() || !limit.empty()) {
    out << " (";
    if (!value.empty()) out << "value " << value;
    if (!value.empty() && !limit.empty()) out << ", ";
    if (!limit.empty()) out << "limit " << limit;
    out << ")";
  }
  return out.str();
}

std::string DefaultRigFile() { return HEXA_DEFAULT_RIG_FILE; }

namespace {

// Blocks a rig file may leave out (their defaults apply): the board wiring, the coupled leg
// feedback (off).
const std::vector<std::string> kOptionalBlocks = {"board", "leg_controller.coupled_legs"};

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

// Stage 4a: proto -> structs (all fields known to be present; legs and profiles checked).
SystemConfig Translate(const pb::RigFile& f) {
  SystemConfig c;
  c.rig_name = f.rig_name();
  RigParams& rig = c.rig;
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

  const pb::LegControllerConfig& lc = f.leg_controller();
  c.leg_controller.differentiator.window = lc.differentiator().window();
  c.leg_controller.differentiator.sigma = lc.differentiator().sigma();
  c.leg_controller.differentiator.centre_lag_samples = lc.differentiator().centre_lag_samples();
  const pb::BsSmcConfig& b = lc.bssmc();
  c.leg_controller.bssmc.lambda_1_s = b.lambda_1_s();
  c.leg_controller.bssmc.switching_gain_n = b.switching_gain_n();
  c.leg_controller.bssmc.boundary_layer_xi_s_m = b.boundary_layer_xi_s_m();
  c.leg_controller.bssmc.backstepping_beta_1_s = b.backstepping_beta_1_s();
  c.leg_controller.bssmc.effective_mass_kg = b.effective_mass_kg();
  c.leg_controller.bssmc.gravity_load_n = b.gravity_load_n();
  c.leg_controller.bssmc.viscous_estimate_scale = b.viscous_estimate_scale();
  c.leg_controller.bssmc.friction_estimate_scale = b.friction_estimate_scale();
  c.leg_controller.bssmc.friction_smoothing_velocity_m_s = b.friction_smoothing_velocity_m_s();
  c.leg_controller.bssmc.reaching_proportional_n_s_m = b.reaching_proportional_n_s_m();
  c.leg_controller.bssmc.null_band_area_fraction = b.null_band_area_fraction();
  c.leg_controller.bssmc.spool_filter_time_constant_s = b.spool_filter_time_constant_s();
  c.leg_controller.bssmc.integral_gain_n_m = b.integral_gain_n_m();
  c.leg_controller.bssmc.integral_limit_n = b.integral_limit_n();
  c.leg_controller.bssmc.integral_active_below_m_s = b.integral_active_below_m_s();
  c.leg_controller.bssmc.integral_leak_time_constant_s = b.integral_leak_time_constant_s();
  c.leg_controller.bssmc.integral_deadband_m = b.integral_deadband_m();
  c.leg_controller.bssmc.feedback_rate_fraction = b.feedback_rate_fraction();
  c.leg_controller.bssmc.feedback_rate_time_constant_s = b.feedback_rate_time_constant_s();
  c.leg_controller.bssmc.feedback_rate_from_observer = b.feedback_rate_from_observer();
  c.leg_controller.bssmc.observer_mass_kg = b.observer_mass_kg();
  c.leg_controller.bssmc.observer_length_sigma_m = b.observer_length_sigma_m();
  c.leg_controller.bssmc.observer_force_sigma_n = b.observer_force_sigma_n();
  c.leg_controller.bssmc.observer_disturbance_rate_m_s3 = b.observer_disturbance_rate_m_s3();
  c.leg_controller.bssmc.feedback_rate_full_speed_m_s = b.feedback_rate_full_speed_m_s();
  c.leg_controller.bssmc.dither_amplitude_n = b.dither_amplitude_n();
  c.leg_controller.bssmc.dither_frequency_hz = b.dither_frequency_hz();
  c.leg_controller.bssmc.dither_gate_speed_m_s = b.dither_gate_speed_m_s();
  c.leg_controller.bssmc.friction_adaptation_rate_1_n_m = b.friction_adaptation_rate_1_n_m();
  c.leg_controller.bssmc.friction_adaptation_speed_m_s = b.friction_adaptation_speed_m_s();
  c.leg_controller.bssmc.friction_adaptation_min_scale = b.friction_adaptation_min_scale();
  c.leg_controller.bssmc.friction_adaptation_max_scale = b.friction_adaptation_max_scale();
  c.leg_controller.pi.proportional_v_m = lc.pi().proportional_v_m();
  c.leg_controller.pi.integral_v_m_s = lc.pi().integral_v_m_s();
  c.leg_controller.pi.integrator_limit_v = lc.pi().integrator_limit_v();
  c.leg_controller.pi.velocity_feedforward_v_s_m = lc.pi().velocity_feedforward_v_s_m();
  c.leg_controller.pi.rate_damping_v_s_m = lc.pi().rate_damping_v_s_m();
  c.leg_controller.pi.force_feedforward_v_n = lc.pi().force_feedforward_v_n();
  c.leg_controller.setpoint_timeout_s = lc.setpoint_timeout_s();
  if (lc.has_coupled_legs()) {
    const pb::CoupledLegsConfig& k = lc.coupled_legs();
    c.leg_controller.coupled.enabled = k.enabled();
    c.leg_controller.coupled.gain = k.gain();
    c.leg_controller.coupled.cutoff_hz = k.cutoff_hz();
    c.leg_controller.coupled.raise_only = k.raise_only();
  }

  const pb::SupervisorConfig& sv = f.supervisor();
  c.supervisor.period_s = sv.period_s();
  c.supervisor.blend_duration_s = sv.blend_duration_s();
  c.supervisor.stop_duration_s = sv.stop_duration_s();
  c.supervisor.stroke_margin_m = sv.stroke_margin_m();
  c.supervisor.max_leg_speed_m_s = sv.max_leg_speed_m_s();
  c.supervisor.max_leg_acceleration_m_s2 = sv.max_leg_acceleration_m_s2();
  c.supervisor.max_consecutive_deadline_misses = sv.max_consecutive_deadline_misses();
  c.supervisor.workspace_radius_m = sv.workspace_radius_m();
  c.supervisor.workspace_max_rotation_rad = sv.workspace_max_rotation_rad();
  c.supervisor.least_squares_estimator = sv.least_squares_estimator();
  c.supervisor.estimator_outlier_threshold_m = sv.estimator_outlier_threshold_m();
  c.supervisor.feedforward_enabled = sv.feedforward_enabled();
  c.supervisor.length_consistency_limit_m = sv.length_consistency_limit_m();
  c.supervisor.length_consistency_ticks = sv.length_consistency_ticks();
  c.supervisor.setpoint_lead_s = sv.setpoint_lead_s();
  c.supervisor.outer_loop.enabled = sv.outer_loop().enabled();
  c.supervisor.outer_loop.gain = sv.outer_loop().gain();
  c.supervisor.outer_loop.max_correction_m = sv.outer_loop().max_correction_m();
  c.supervisor.outer_loop.translation_gain_scale = sv.outer_loop().translation_gain_scale();
  c.supervisor.outer_loop.gate_leg_speed_m_s = sv.outer_loop().gate_leg_speed_m_s();
  c.supervisor.soft_limits = FromPb(sv.soft_limits());

  for (const pb::DisturbanceProfileConfig& d : f.disturbance_profile()) c.profiles[d.name()] = FromPb(d);
  c.default_profile = f.default_profile();
  if (f.has_board()) c.board = FromPb(f.board());
  return c;
}

// Six `leg` elements with ids 1..6 once each in the top-level block `block` (geometry, board).
void CheckSixLegIds(const pb::RigFile& f, const ParseInfoTree& tree, const std::string& file, const std::string& block,
                    const std::string& what, std::vector<ConfigIssue>& issues) {
  const gp::FieldDescriptor* block_fd = pb::RigFile::descriptor()->FindFieldByName(block);
  const gp::Message& msg = f.GetReflection()->GetMessage(f, block_fd);
  const gp::FieldDescriptor* leg_fd = msg.GetDescriptor()->FindFieldByName("leg");
  const gp::Reflection* r = msg.GetReflection();
  const Location block_loc = FromRange(tree.GetLocationRange(block_fd, -1));
  const ParseInfoTree* block_tree = tree.GetTreeForNested(block_fd, -1);
  const int legs = r->FieldSize(msg, leg_fd);
  if (legs != static_cast<int>(kNumLegs)) {
    issues.push_back({file, block_loc.line, block_loc.column, block + ".leg", what, std::to_string(legs) + " legs",
                      "exactly 6"});
  }
  std::map<int, int> first_line_of_id;
  for (int k = 0; k < legs; ++k) {
    const gp::Message& leg = r->GetRepeatedMessage(msg, leg_fd, k);
    const gp::FieldDescriptor* id_fd = leg.GetDescriptor()->FindFieldByName("id");
    const int id = leg.GetReflection()->GetInt32(leg, id_fd);
    const ParseInfoTree* leg_tree = block_tree ? block_tree->GetTreeForNested(leg_fd, k) : nullptr;
    const Location loc = leg_tree ? FromRange(leg_tree->GetLocationRange(id_fd, -1)) : block_loc;
    const std::string path = block + ".leg[" + std::to_string(k) + "].id";
    if (id < 1 || id > static_cast<int>(kNumLegs)) {
      issues.push_back({file, loc.line, loc.column, path, "leg id out of range", std::to_string(id), "[1, 6]"});
    } else if (const auto it = first_line_of_id.find(id); it != first_line_of_id.end()) {
      issues.push_back({file, loc.line, loc.column, path,
                        "leg " + std::to_string(id) + " is defined twice (first at line " +
                            std::to_string(it->second) + ")",
                        std::to_string(id), "each id 1..6 exactly once"});
    } else {
      first_line_of_id[id] = loc.line;
    }
  }
}

// Stage 3: six legs with ids 1..6 once each (geometry, board); profile names non-empty and
// unique.
void CheckStructure(const pb::RigFile& f, const ParseInfoTree& tree, const std::string& file, int eof_line,
                    std::vector<ConfigIssue>& issues) {
  CheckSixLegIds(f, tree, file, "geometry", "a 6-6 platform needs exactly six legs", issues);
  if (f.has_board()) CheckSixLegIds(f, tree, file, "board", "the board serves exactly six legs", issues);

  const gp::FieldDescriptor* profile_fd = pb::RigFile::descriptor()->FindFieldByName("disturbance_profile");
  const gp::FieldDescriptor* name_fd = pb::DisturbanceProfileConfig::descriptor()->FindFieldByName("name");
  if (f.disturbance_profile_size() == 0) {
    issues.push_back({file, eof_line, 1, "disturbance_profile", "at least one disturbance profile is required",
                      "0 profiles", ">= 1"});
  }
  std::map<std::string, int> first_line_of_name;
  for (int k = 0; k < f.disturbance_profile_size(); ++k) {
    const std::string& name = f.disturbance_profile(k).name();
    const ParseInfoTree* profile_tree = tree.GetTreeForNested(profile_fd, k);
    const Location loc = profile_tree ? FromRange(profile_tree->GetLocationRange(name_fd, -1))
                                      : FromRange(tree.GetLocationRange(profile_fd, k));
    const std::string path = "disturbance_profile[" + std::to_string(k) + "].name";
    if (name.empty()) {
      issues.push_back({file, loc.line, loc.column, path, "profile name must not be empty", "\"\"", "non-empty"});
    } else if (const auto it = first_line_of_name.find(name); it != first_line_of_name.end()) {
      issues.push_back({file, loc.line, loc.column, path,
                        "disturbance profile '" + name + "' is defined twice (first at line " +
                            std::to_string(it->second) + ")",
                        "\"" + name + "\"", "unique profile names"});
    } else {
      first_line_of_name[name] = loc.line;
    }
  }
}

std::string JoinIssues(const std::vector<ConfigIssue>& issues) {
  std::string out;
  for (const ConfigIssue& issue : issues) out += (out.empty() ? "" : "\n") + issue.ToString();
  return out;
}

ConfigResult Fail(std::vector<ConfigIssue> issues) {
  ConfigResult result;
  result.ok = false;
  result.error = JoinIssues(issues);
  result.issues = std::move(issues);
  return result;
}

}  // namespace

ConfigResult ParseSystemConfig(const std::string& text, const std::string& display_name) {
  try {
    pb::RigFile file;
    ParseInfoTree tree;
    std::vector<ConfigIssue> issues;
    if (!internal::ParseTextFormat(text, display_name, file, tree, issues)) return Fail(std::move(issues));
    const int eof_line = CountLines(text);

    internal::CheckEveryFieldWritten(file, tree, display_name, eof_line, kOptionalBlocks, issues);
    if (!issues.empty()) return Fail(std::move(issues));

    CheckStructure(file, tree, display_name, eof_line, issues);
    if (!issues.empty()) return Fail(std::move(issues));

    SystemConfig config = Translate(file);
    config.source_path = display_name;
    issues = ValidateSystemConfig(config);
    for (ConfigIssue& issue : issues) {
      issue.file = display_name;
      const Location loc = Locate(file, tree, issue.field);
      issue.line = loc.line > 0 ? loc.line : 1;
      issue.column = loc.line > 0 ? loc.column : 1;
    }
    if (!issues.empty()) {
      ConfigResult failed = Fail(std::move(issues));
      failed.config = std::move(config);
      failed.translated = true;
      return failed;
    }

    ConfigResult result;
    result.ok = true;
    result.translated = true;
    result.config = std::move(config);
    return result;
  } catch (const std::exception& e) {  // e.g. std::bad_alloc; the status API never throws
    return Fail({{display_name, 0, 0, "", std::string("internal error while loading: ") + e.what(), "", ""}});
  }
}

ConfigResult LoadSystemConfig(const std::string& path) {
  std::string text, error;
  if (!internal::ReadBoundedFile(path, "rig file", internal::kMaxRigFileBytes, text, error))
    return Fail({{path, 0, 0, "", error, "", ""}});
  return ParseSystemConfig(text, path);
}

SystemConfig LoadSystemConfigOrThrow(const std::string& path) {
  ConfigResult result = LoadSystemConfig(path);
  if (!result.ok) throw ConfigError(result.error);
  return std::move(result.config);
}

ProfileResult SelectProfile(const SystemConfig& config, const std::string& name) {
  ProfileResult result;
  result.name = name.empty() ? config.default_profile : name;
  const auto it = config.profiles.find(result.name);
  if (it != config.profiles.end()) {
    result.ok = true;
    result.profile = it->second;
    return result;
  }
  std::string names;
  for (const auto& [known, profile] : config.profiles) names += (names.empty() ? "" : ", ") + known;
  ConfigIssue issue;
  issue.file = config.source_path.empty() ? "<config>" : config.source_path;
  issue.field = "disturbance_profile";
  issue.message = "unknown disturbance profile requested";
  issue.value = "\"" + result.name + "\"";
  issue.limit = "one of the profiles defined in the file: " + names;
  result.error = issue.ToString();
  return result;
}

std::string ToTextFormat(const SystemConfig& c) {
  pb::RigFile f;
  f.set_rig_name(c.rig_name);
  const RigParams& rig = c.rig;
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

  pb::LegControllerConfig* lc = f.mutable_leg_controller();
  lc->mutable_differentiator()->set_window(c.leg_controller.differentiator.window);
  lc->mutable_differentiator()->set_sigma(c.leg_controller.differentiator.sigma);
  lc->mutable_differentiator()->set_centre_lag_samples(c.leg_controller.differentiator.centre_lag_samples);
  pb::BsSmcConfig* b = lc->mutable_bssmc();
  b->set_lambda_1_s(c.leg_controller.bssmc.lambda_1_s);
  b->set_switching_gain_n(c.leg_controller.bssmc.switching_gain_n);
  b->set_boundary_layer_xi_s_m(c.leg_controller.bssmc.boundary_layer_xi_s_m);
  b->set_backstepping_beta_1_s(c.leg_controller.bssmc.backstepping_beta_1_s);
  b->set_effective_mass_kg(c.leg_controller.bssmc.effective_mass_kg);
  b->set_gravity_load_n(c.leg_controller.bssmc.gravity_load_n);
  b->set_viscous_estimate_scale(c.leg_controller.bssmc.viscous_estimate_scale);
  b->set_friction_estimate_scale(c.leg_controller.bssmc.friction_estimate_scale);
  b->set_friction_smoothing_velocity_m_s(c.leg_controller.bssmc.friction_smoothing_velocity_m_s);
  b->set_reaching_proportional_n_s_m(c.leg_controller.bssmc.reaching_proportional_n_s_m);
  b->set_null_band_area_fraction(c.leg_controller.bssmc.null_band_area_fraction);
  b->set_spool_filter_time_constant_s(c.leg_controller.bssmc.spool_filter_time_constant_s);
  b->set_integral_gain_n_m(c.leg_controller.bssmc.integral_gain_n_m);
  b->set_integral_limit_n(c.leg_controller.bssmc.integral_limit_n);
  b->set_integral_active_below_m_s(c.leg_controller.bssmc.integral_active_below_m_s);
  b->set_integral_leak_time_constant_s(c.leg_controller.bssmc.integral_leak_time_constant_s);
  b->set_integral_deadband_m(c.leg_controller.bssmc.integral_deadband_m);
  b->set_feedback_rate_fraction(c.leg_controller.bssmc.feedback_rate_fraction);
  b->set_feedback_rate_time_constant_s(c.leg_controller.bssmc.feedback_rate_time_constant_s);
  b->set_feedback_rate_from_observer(c.leg_controller.bssmc.feedback_rate_from_observer);
  b->set_observer_mass_kg(c.leg_controller.bssmc.observer_mass_kg);
  b->set_observer_length_sigma_m(c.leg_controller.bssmc.observer_length_sigma_m);
  b->set_observer_force_sigma_n(c.leg_controller.bssmc.observer_force_sigma_n);
  b->set_observer_disturbance_rate_m_s3(c.leg_controller.bssmc.observer_disturbance_rate_m_s3);
  b->set_feedback_rate_full_speed_m_s(c.leg_controller.bssmc.feedback_rate_full_speed_m_s);
  b->set_dither_amplitude_n(c.leg_controller.bssmc.dither_amplitude_n);
  b->set_dither_frequency_hz(c.leg_controller.bssmc.dither_frequency_hz);
  b->set_dither_gate_speed_m_s(c.leg_controller.bssmc.dither_gate_speed_m_s);
  b->set_friction_adaptation_rate_1_n_m(c.leg_controller.bssmc.friction_adaptation_rate_1_n_m);
  b->set_friction_adaptation_speed_m_s(c.leg_controller.bssmc.friction_adaptation_speed_m_s);
  b->set_friction_adaptation_min_scale(c.leg_controller.bssmc.friction_adaptation_min_scale);
  b->set_friction_adaptation_max_scale(c.leg_controller.bssmc.friction_adaptation_max_scale);
  lc->mutable_pi()->set_proportional_v_m(c.leg_controller.pi.proportional_v_m);
  lc->mutable_pi()->set_integral_v_m_s(c.leg_controller.pi.integral_v_m_s);
  lc->mutable_pi()->set_integrator_limit_v(c.leg_controller.pi.integrator_limit_v);
  lc->mutable_pi()->set_velocity_feedforward_v_s_m(c.leg_controller.pi.velocity_feedforward_v_s_m);
  lc->mutable_pi()->set_rate_damping_v_s_m(c.leg_controller.pi.rate_damping_v_s_m);
  lc->mutable_pi()->set_force_feedforward_v_n(c.leg_controller.pi.force_feedforward_v_n);
  lc->set_setpoint_timeout_s(c.leg_controller.setpoint_timeout_s);
  pb::CoupledLegsConfig* k = lc->mutable_coupled_legs();
  k->set_enabled(c.leg_controller.coupled.enabled);
  k->set_gain(c.leg_controller.coupled.gain);
  k->set_cutoff_hz(c.leg_controller.coupled.cutoff_hz);
  k->set_raise_only(c.leg_controller.coupled.raise_only);

  pb::SupervisorConfig* sv = f.mutable_supervisor();
  sv->set_period_s(c.supervisor.period_s);
  sv->set_blend_duration_s(c.supervisor.blend_duration_s);
  sv->set_stop_duration_s(c.supervisor.stop_duration_s);
  sv->set_stroke_margin_m(c.supervisor.stroke_margin_m);
  sv->set_max_leg_speed_m_s(c.supervisor.max_leg_speed_m_s);
  sv->set_max_leg_acceleration_m_s2(c.supervisor.max_leg_acceleration_m_s2);
  sv->set_max_consecutive_deadline_misses(c.supervisor.max_consecutive_deadline_misses);
  sv->set_workspace_radius_m(c.supervisor.workspace_radius_m);
  sv->set_workspace_max_rotation_rad(c.supervisor.workspace_max_rotation_rad);
  sv->set_least_squares_estimator(c.supervisor.least_squares_estimator);
  sv->set_estimator_outlier_threshold_m(c.supervisor.estimator_outlier_threshold_m);
  sv->set_feedforward_enabled(c.supervisor.feedforward_enabled);
  sv->set_length_consistency_limit_m(c.supervisor.length_consistency_limit_m);
  sv->set_length_consistency_ticks(c.supervisor.length_consistency_ticks);
  sv->set_setpoint_lead_s(c.supervisor.setpoint_lead_s);
  sv->mutable_outer_loop()->set_enabled(c.supervisor.outer_loop.enabled);
  sv->mutable_outer_loop()->set_gain(c.supervisor.outer_loop.gain);
  sv->mutable_outer_loop()->set_max_correction_m(c.supervisor.outer_loop.max_correction_m);
  sv->mutable_outer_loop()->set_translation_gain_scale(c.supervisor.outer_loop.translation_gain_scale);
  sv->mutable_outer_loop()->set_gate_leg_speed_m_s(c.supervisor.outer_loop.gate_leg_speed_m_s);
  ToPb(c.supervisor.soft_limits, sv->mutable_soft_limits());

  for (const auto& [name, profile] : c.profiles) ToPb(name, profile, f.add_disturbance_profile());
  f.set_default_profile(c.default_profile);
  if (c.board) ToPb(*c.board, f.mutable_board());

  std::string text;
  gp::TextFormat::Printer printer;
  printer.PrintToString(f, &text);
  return text;
}

std::string Summary(const SystemConfig& c) {
  const internal::HomeGeometry home = internal::ComputeHomeGeometry(c.rig.geometry);
  const auto [lo, hi] = std::minmax_element(home.length_m.begin(), home.length_m.end());
  std::ostringstream out;
  out.precision(6);
  out << c.rig_name << ": " << kNumLegs << " legs, home leg length " << *lo;
  if (*hi - *lo > 1e-7) out << ".." << *hi;
  out << " m (mid-stroke " << c.rig.cylinder.mid_stroke_length_m << " m, stroke " << c.rig.cylinder.stroke_m
      << " m), home Jacobian condition " << home.jacobian_condition << ", supply " << c.rig.air.supply_pressure_pa
      << " Pa, platform " << c.rig.platform.mass_kg << " kg, profiles {";
  bool first = true;
  for (const auto& [name, profile] : c.profiles) {
    out << (first ? "" : ", ") << name;
    first = false;
  }
  out << "}, default " << c.default_profile;
  if (c.board) {
    out << ", I/O board " << c.board->adc_bits << "-bit ADC / " << c.board->dac_bits << "-bit DAC, watchdog "
        << c.board->watchdog_timeout_s << " s";
  }
  for (const RigOverlay& o : c.overlays) {
    int legs = 0;
    for (const LegOverride& l : o.leg) legs += l.empty() ? 0 : 1;
    out << "; overlay " << o.source_path << " (" << legs << " legs, " << o.provenance.method << ", "
        << o.provenance.date << ")";
  }
  return out.str();
}

}  // namespace hexa::config
