#include "hexa/core/sensor_model.hpp"

#include <algorithm>
#include <cmath>

namespace hexa {

std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

SensorModel::SensorModel(const RigParams& rig, const DisturbanceProfile& profile,
                         std::uint64_t seed)
    : params_(rig.sensors), cylinder_(rig.cylinder), noise_enabled_(profile.sensor_noise),
      seed_(seed) {
  // Calibration errors are fixed per seed (their own stream, so changing the noise model
  // does not move them).
  std::mt19937_64 calib_rng(DeriveSeed(seed, 1));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    calibration_.offset_m[i] = profile.potentiometer_offset_max_m * unit(calib_rng);
    calibration_.gain_error[i] = profile.potentiometer_gain_error_max * unit(calib_rng);
  }
  if (!noise_enabled_) calibration_ = PotentiometerCalibration{};
  Reset();
}

void SensorModel::Reset() {
  noise_rng_.seed(DeriveSeed(seed_, 2));
  normal_.reset();
  imu_bias_rad_.setZero();
  next_imu_time_s_ = 0.0;
  last_imu_ = ImuReading{};
}

double SensorModel::QuantiseLengthM(double x_m) const {
  // 12-bit converter over the stroke [-L/2, L/2]; saturates at both ends.
  const double levels = std::ldexp(1.0, params_.length_bits) - 1.0;
  const double lsb = cylinder_.stroke_m / levels;
  const double counts = std::clamp(std::round((x_m + 0.5 * cylinder_.stroke_m) / lsb), 0.0, levels);
  return counts * lsb - 0.5 * cylinder_.stroke_m;
}

void SensorModel::Sample(const SensorTruth& truth, double time_s,
                         LegArray<LegSensorReading>& legs, ImuReading& imu) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegSensorReading& r = legs[i];
    double x = truth.piston_position_m[i];
    if (noise_enabled_) {
      x = calibration_.offset_m[i] + (1.0 + calibration_.gain_error[i]) * x +
          Gauss(params_.length_sigma_m);
      x = QuantiseLengthM(x);
    }
    r.length_m = cylinder_.mid_stroke_length_m + x;
    r.chamber1_pressure_pa = truth.chamber1_pressure_pa[i];
    r.chamber2_pressure_pa = truth.chamber2_pressure_pa[i];
    r.supply_pressure_pa = truth.supply_pressure_pa;
    if (noise_enabled_) {
      r.chamber1_pressure_pa += Gauss(params_.pressure_sigma_pa);
      r.chamber2_pressure_pa += Gauss(params_.pressure_sigma_pa);
      r.supply_pressure_pa += Gauss(params_.pressure_sigma_pa);
    }
  }
  // IMU: a new sample each imu_period_s (half a tick of tolerance against rounding).
  if (time_s + 0.5e-6 >= next_imu_time_s_) {
    ImuReading m;
    m.fresh = true;
    m.sample_time_s = time_s;
    m.angular_rate_B_rad_s = truth.angular_rate_B_rad_s;
    Eigen::Quaterniond q = truth.q_BP;
    if (noise_enabled_) {
      const double walk = params_.imu_bias_walk_rad_sqrt_s * std::sqrt(params_.imu_period_s);
      for (int k = 0; k < 3; ++k) imu_bias_rad_[k] += Gauss(walk);
      Eigen::Vector3d error = imu_bias_rad_;
      for (int k = 0; k < 3; ++k) error[k] += Gauss(params_.imu_orientation_sigma_rad);
      // Error rotation applied in the base frame: R_measured = Exp(error) R_true.
      const double angle = error.norm();
      if (angle > 0.0) q = Eigen::Quaterniond(Eigen::AngleAxisd(angle, error / angle)) * q;
    }
    m.q_BP_measured = q.normalized();
    last_imu_ = m;
    next_imu_time_s_ += params_.imu_period_s;
    if (next_imu_time_s_ < time_s) next_imu_time_s_ = time_s + params_.imu_period_s;
  } else {
    last_imu_.fresh = false;
  }
  imu = last_imu_;
}

}  // namespace hexa
