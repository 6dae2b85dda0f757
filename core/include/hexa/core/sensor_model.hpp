// Sensors of the simulated rig (docs/design.md "Plant model", rig.hpp SensorNoiseParams):
// potentiometer leg length (noise, 12-bit quantisation over the stroke, per-seed offset
// and gain error), chamber and supply pressures (noise), IMU orientation at 200 Hz (noise
// plus a bias random walk). Randomness only from an explicit seed (std::mt19937_64).
#pragma once

#include <cstdint>
#include <random>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexa/core/rig.hpp"

namespace hexa {

struct LegSensorReading {
  double length_m = 0.0;              // potentiometer
  double chamber1_pressure_pa = 0.0;  // P1 (cap), absolute
  double chamber2_pressure_pa = 0.0;  // P2 (rod), absolute
  double supply_pressure_pa = 0.0;    // P_s, absolute
};

struct ImuReading {
  bool fresh = false;  // true on the ticks the 200 Hz IMU produced a new sample
  bool dropped_out = false;  // plant fault imu-dropout: the IMU delivers nothing (plant_faults.hpp)
  double sample_time_s = 0.0;
  Eigen::Quaterniond q_BP_measured = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_rate_B_rad_s = Eigen::Vector3d::Zero();  // true rate (no gyro model)
};

// What the sensors see of the true plant at one tick.
struct SensorTruth {
  LegArray<double> piston_position_m{};   // x of eq 64 (true)
  LegArray<double> chamber1_pressure_pa{};
  LegArray<double> chamber2_pressure_pa{};
  double supply_pressure_pa = 0.0;
  Eigen::Quaterniond q_BP = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_rate_B_rad_s = Eigen::Vector3d::Zero();
};

// Per-seed calibration errors of the potentiometers (DisturbanceProfile).
struct PotentiometerCalibration {
  LegArray<double> offset_m{};    // added to the reading
  LegArray<double> gain_error{};  // reading of x is (1 + gain_error) x
};

class SensorModel {
 public:
  // `noise_enabled` false: perfect sensors (no noise, no quantisation, no calibration
  // error, no IMU bias), the `ideal` profile.
  SensorModel(const RigParams& rig, const DisturbanceProfile& profile, std::uint64_t seed);

  void Reset();  // re-seeds: the same seed gives the same sequence again

  // Samples all sensors at simulated time `time_s`; the IMU produces a fresh sample when
  // `time_s` has reached its next 200 Hz instant.
  void Sample(const SensorTruth& truth, double time_s, LegArray<LegSensorReading>& legs,
              ImuReading& imu);

  const PotentiometerCalibration& calibration() const { return calibration_; }
  const Eigen::Vector3d& imu_bias_rad() const { return imu_bias_rad_; }

 private:
  double Gauss(double sigma) { return sigma * normal_(noise_rng_); }
  double QuantiseLengthM(double x_m) const;

  SensorNoiseParams params_;
  CylinderParams cylinder_;
  bool noise_enabled_ = true;
  std::uint64_t seed_ = 0;
  PotentiometerCalibration calibration_;
  std::mt19937_64 noise_rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Eigen::Vector3d imu_bias_rad_ = Eigen::Vector3d::Zero();
  double next_imu_time_s_ = 0.0;
  ImuReading last_imu_;
};

// SplitMix64 step: derives independent sub-seeds (calibration, noise, geometry) from the
// one seed of the configuration.
std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t stream);

}  // namespace hexa
