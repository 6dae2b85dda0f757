// Rig parameters: the constant Model of the platform, shared by the plant, the leg
// controllers and the supervisor. Plain data, SI units in every name, defaults are the
// reference rig HexaTaar-R of docs/design.md. The rig file (protobuf text format,
// config/) is translated into these structs and validated there; the core trusts them.
//
// Frames: B = base frame (z up, origin at the base joint plane centre), P = platform frame
// (origin at the platform joint plane centre). Leg i runs from base joint A_i to platform
// joint B_i. Leg length l_i = |p_BP_B + R_BP * p_PBi_P - p_BAi_B| (eq 46).
//
// Piston position x (eq 64): x = 0 at mid-stroke, positive when the leg extends
// (chamber 1 = cap side grows). Leg length l = mid_stroke_length_m + x.
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Core>

namespace hexa {

inline constexpr std::size_t kNumLegs = 6;

template <typename T>
using LegArray = std::array<T, kNumLegs>;

// Table 3 of the paper, plus the supply pressure of the reference rig.
struct AirParams {
  double heat_ratio = 1.4;                 // k
  double temperature_k = 294.0;            // T
  double gas_constant_j_kg_k = 287.0;      // R
  double atmosphere_pressure_pa = 1.0e5;   // Pa
  double supply_pressure_pa = 7.0e5;       // Ps, absolute
};

struct GeometryParams {
  LegArray<Eigen::Vector3d> p_BA_B{};  // base joint of each leg, in B [m]
  LegArray<Eigen::Vector3d> p_PB_P{};  // platform joint of each leg, in P [m]
  Eigen::Vector3d home_position_m{0.0, 0.0, 0.45};  // p_BP_B at home, no rotation
};

// Double-acting cylinder (chamber 1 = cap side, chamber 2 = rod side).
struct CylinderParams {
  double cap_area_m2 = 3.1416e-4;      // A1
  double annulus_area_m2 = 2.6389e-4;  // A2
  double rod_area_m2 = 5.0265e-5;      // Ar
  double stroke_m = 0.25;              // L
  double dead_volume_m3 = 1.0e-5;      // V0i, each chamber (eq 64)
  double moving_mass_kg = 0.25;        // piston + rod
  double mid_stroke_length_m = 0.5034; // leg length at x = 0
  double end_stop_stiffness_n_m = 2.0e5;
  double end_stop_damping_n_s_m = 2.0e3;
};

// 5/3 proportional valve (eq 6, 42, 43). X_spool = a u + b. X_spool > 0 (u below null)
// connects supply -> chamber 1 and chamber 2 -> exhaust (extend, Table 4); X_spool < 0
// connects supply -> chamber 2 and chamber 1 -> exhaust (retract, Table 5).
struct ValveParams {
  double min_voltage_v = 0.0;
  double max_voltage_v = 10.0;
  double null_voltage_v = 5.0;
  double spool_gain_m_v = -0.3e-3;       // a (eq 42)
  double spool_offset_m = 1.5e-3;        // b (eq 42)
  double max_spool_m = 1.5e-3;           // |X_spool| at full opening
  double max_orifice_area_m2 = 15.0e-6;  // A_v at full opening (eq 6)
  double discharge_coefficient = 0.6;    // C_f (eq 4), assumption
  double spool_time_constant_s = 0.003;  // first-order spool lag, assumption
};

// Eq 3 parameters for one stroke direction, as magnitudes (Table 8 encodes the direction
// in the sign; friction always opposes motion).
struct FrictionDirectionParams {
  double stribeck_velocity_m_s = 0.0;  // v_s
  double viscous_n_s_m = 0.0;          // B
  double static_n = 0.0;               // F_s
  double coulomb_n = 0.0;              // F_c
};

struct FrictionParams {
  FrictionDirectionParams extend{0.5641, 34.4445, 86.6540, 49.1371};  // Table 8, up
  FrictionDirectionParams retract{0.2894, 3.2342, 91.9421, 78.8793};  // Table 8, down
  // LuGre bristle parameters (plant only; the controller uses the static eq 14).
  double bristle_stiffness_n_m = 1.0e5;  // sigma0, assumption
  double bristle_damping_n_s_m = 300.0;  // sigma1, assumption
};

// Polytropic coefficients of the pressure dynamics (eq 7, 65), Table 8.
struct PolytropicParams {
  double inflow = 1.0;   // gamma_i
  double outflow = 1.0;  // gamma_o
  double volume = 1.0;   // gamma_k
};

struct PolytropicSet {
  PolytropicParams extend{1.364, 1.045, 1.172};   // Table 8, up
  PolytropicParams retract{1.341, 1.029, 1.651};  // Table 8, down
};

struct PlatformParams {
  double mass_kg = 6.0;
  Eigen::Vector3d inertia_diag_kg_m2{0.094, 0.094, 0.19};  // about the platform centre
  double gravity_m_s2 = 9.81;
};

struct SensorNoiseParams {
  double length_sigma_m = 0.05e-3;      // potentiometer
  int length_bits = 12;                 // quantisation over the stroke
  double pressure_sigma_pa = 2.0e3;
  double imu_orientation_sigma_rad = 0.1 * 3.14159265358979323846 / 180.0;
  double imu_bias_walk_rad_sqrt_s = 1.0e-4;  // random-walk intensity of the IMU bias
  double imu_period_s = 0.005;               // 200 Hz
};

// A disturbance profile (docs/design.md, "Trajectories and figures of merit"): what the plant
// does differently from the controllers' model. `ideal` is all zeros / ones.
struct DisturbanceProfile {
  bool sensor_noise = true;
  double friction_scale = 1.2;
  double polytropic_scale = 1.1;
  double payload_scale = 1.2;                 // platform mass and inertia factor
  double supply_ripple_amplitude_pa = 0.2e5;  // +-0.2 bar
  double supply_ripple_frequency_hz = 0.5;
  double joint_position_error_max_m = 2.0e-3;  // each joint, uniform in a ball
  double potentiometer_offset_max_m = 1.0e-3;
  double potentiometer_gain_error_max = 0.005;
};

// A potentiometer's calibration as the controllers apply it (rig overlay, docs/config.md):
// the reading of piston position x is offset_m + gain * x (the convention of the plant's
// calibration errors, sensor_model.hpp). Identity by default.
struct PotentiometerCalibrationParams {
  double offset_m = 0.0;
  double gain = 1.0;
};

// Everything about the physical rig that the controllers may know (their model), plus
// sensor characteristics. The plant applies a DisturbanceProfile on top.
struct RigParams {
  AirParams air;
  GeometryParams geometry;
  CylinderParams cylinder;
  ValveParams valve;
  FrictionParams friction;
  PolytropicSet polytropic;
  PlatformParams platform;
  SensorNoiseParams sensors;
};

// The reference rig HexaTaar-R of docs/design.md, computed from its joint layout.
RigParams MakeReferenceRig();

}  // namespace hexa
