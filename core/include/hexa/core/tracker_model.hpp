// External pose instrument of the simulated rig: a laser tracker / motion-capture
// system that measures the platform's TRUE pose with its own noise, for kinematic
// calibration only (never used for tracking). Off by default; its random numbers come from
// their own stream of the plant seed, so switching it on changes nothing else in a run.
#pragma once

#include <cstdint>
#include <random>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexa/core/pose.hpp"

namespace hexa {

struct TrackerParams {
  bool enabled = false;
  double period_s = 0.01;                     // 100 Hz
  double position_sigma_m = 0.02e-3;          // per axis
  double orientation_sigma_rad = 0.005 * 3.14159265358979323846 / 180.0;  // per axis
  void Validate() const;  // throws std::invalid_argument naming field, value and limit
};

struct TrackerReading {
  bool fresh = false;  // a new measurement at this tick
  double sample_time_s = 0.0;
  Eigen::Vector3d p_BP_B_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_BP = Eigen::Quaterniond::Identity();
};

class TrackerModel {
 public:
  TrackerModel(const TrackerParams& params, std::uint64_t seed);
  void Reset();
  // A fresh measurement when time_s has reached the next sample instant (and enabled).
  void Sample(const Eigen::Vector3d& p_BP_B_m, const Eigen::Quaterniond& q_BP, double time_s,
              TrackerReading& reading);

 private:
  TrackerParams params_;
  std::uint64_t seed_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  double next_time_s_ = 0.0;
};

}  // namespace hexa
