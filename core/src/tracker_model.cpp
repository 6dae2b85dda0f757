#include "hexa/core/tracker_model.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "hexa/core/sensor_model.hpp"

namespace hexa {

void TrackerParams::Validate() const {
  auto require = [](bool ok, const char* field, double value, const char* limit) {
    if (ok) return;
    std::ostringstream m;
    m << "tracker." << field << " = " << value << " must be " << limit;
    throw std::invalid_argument(m.str());
  };
  require(std::isfinite(period_s) && period_s > 0.0, "period_s", period_s, "finite and > 0");
  require(std::isfinite(position_sigma_m) && position_sigma_m >= 0.0, "position_sigma_m",
          position_sigma_m, "finite and >= 0");
  require(std::isfinite(orientation_sigma_rad) && orientation_sigma_rad >= 0.0,
          "orientation_sigma_rad", orientation_sigma_rad, "finite and >= 0");
}

TrackerModel::TrackerModel(const TrackerParams& params, std::uint64_t seed)
    : params_(params), seed_(seed) {
  params_.Validate();
  Reset();
}

void TrackerModel::Reset() {
  rng_.seed(DeriveSeed(seed_, 4));  // stream 4: independent of sensors (1, 2) and geometry (3)
  normal_.reset();
  next_time_s_ = 0.0;
}

void TrackerModel::Sample(const Eigen::Vector3d& p_BP_B_m, const Eigen::Quaterniond& q_BP,
                          double time_s, TrackerReading& reading) {
  reading.fresh = false;
  if (!params_.enabled || time_s + 0.5e-6 < next_time_s_) return;
  reading.fresh = true;
  reading.sample_time_s = time_s;
  for (int k = 0; k < 3; ++k) {
    reading.p_BP_B_m[k] = p_BP_B_m[k] + params_.position_sigma_m * normal_(rng_);
  }
  Eigen::Vector3d error;
  for (int k = 0; k < 3; ++k) error[k] = params_.orientation_sigma_rad * normal_(rng_);
  const double angle = error.norm();
  Eigen::Quaterniond q = q_BP;
  if (angle > 0.0) q = Eigen::Quaterniond(Eigen::AngleAxisd(angle, error / angle)) * q;
  reading.q_BP = q.normalized();
  next_time_s_ += params_.period_s;
  if (next_time_s_ < time_s) next_time_s_ = time_s + params_.period_s;
}

}  // namespace hexa
