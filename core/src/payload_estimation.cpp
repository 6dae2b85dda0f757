#include "hexa/core/payload_estimation.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "hexa/core/platform_inverse_dynamics.hpp"

namespace hexa {
namespace {

constexpr int kColumns = 7;  // f_scaled, then (1, v, v^2) extend, (1, v, v^2) retract
using Normal = Eigen::Matrix<double, kColumns, kColumns>;
using Column = Eigen::Matrix<double, kColumns, 1>;

struct LegSums {
  Normal n = Normal::Zero();
  Column r = Column::Zero();
  double yy = 0.0;
  std::size_t count = 0;
  std::size_t per_direction[2] = {0, 0};
};

// Dense per-tick arrays of one quantity for every leg, NaN where a leg has no sample.
struct DenseLegs {
  std::uint64_t first_tick = 0;
  std::size_t ticks = 0;
  LegArray<std::vector<double>> length_m, force_n;
};

DenseLegs Densify(const RigParams& rig, const KinematicCalibration& calibration, const PayloadRecord& record) {
  DenseLegs d;
  std::uint64_t first = std::numeric_limits<std::uint64_t>::max(), last = 0;
  for (const auto& leg : record.legs())
    for (const auto& s : leg) {
      first = std::min(first, s.tick);
      last = std::max(last, s.tick);
    }
  if (first > last) return d;
  d.first_tick = first;
  d.ticks = static_cast<std::size_t>(last - first + 1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const CylinderParams& cyl = rig.cylinder;
  const double mid = cyl.mid_stroke_length_m;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    d.length_m[i].assign(d.ticks, nan);
    d.force_n[i].assign(d.ticks, nan);
    for (const auto& s : record.legs()[i]) {
      const std::size_t k = static_cast<std::size_t>(s.tick - first);
      d.length_m[i][k] = CorrectedLengthM(calibration[i], s.reading_m, mid);
      d.force_n[i][k] = s.cap_pressure_pa * cyl.cap_area_m2 - s.rod_pressure_pa * cyl.annulus_area_m2 -
                        rig.air.atmosphere_pressure_pa * cyl.rod_area_m2;  // eq 8's pneumatic force
    }
  }
  return d;
}

// s_i from one leg's normal equations: the Schur complement of the f_scaled column against
// the friction columns of the directions that have enough samples.
bool SolveLeg(const LegSums& sums, int min_per_direction, PayloadLegEstimate& out) {
  std::vector<int> friction;
  for (int d = 0; d < 2; ++d)
    if (sums.per_direction[d] >= static_cast<std::size_t>(min_per_direction))
      for (int j = 0; j < 3; ++j) friction.push_back(1 + 3 * d + j);
  if (friction.empty()) return false;
  const int m = static_cast<int>(friction.size());
  Eigen::MatrixXd nff(m, m);
  Eigen::VectorXd nfg(m), rf(m);
  for (int a = 0; a < m; ++a) {
    nfg[a] = sums.n(friction[a], 0);
    rf[a] = sums.r[friction[a]];
    for (int b = 0; b < m; ++b) nff(a, b) = sums.n(friction[a], friction[b]);
  }
  // Columns scaled to unit diagonal: v and v^2 are ~0.1 and ~0.01 of the constant column.
  const Eigen::VectorXd scale = nff.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd nff_s = scale.asDiagonal() * nff * scale.asDiagonal();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(nff_s);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  const Eigen::VectorXd x_g = scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * nfg);
  const Eigen::VectorXd x_r = scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * rf);
  const double information = sums.n(0, 0) - nfg.dot(x_g);
  const double b = sums.r[0] - nfg.dot(x_r);
  if (!(information > 0.0) || !std::isfinite(b)) return false;
  out.scale = b / information;
  out.information = information;
  // Residual of the least-squares fit: y'y - theta' r with theta = (s, friction).
  const Eigen::VectorXd friction_coef = x_r - out.scale * x_g;
  const double explained = out.scale * sums.r[0] + friction_coef.dot(rf);
  out.residual_rms_n = std::sqrt(std::max(0.0, sums.yy - explained) / static_cast<double>(sums.count));
  return std::isfinite(out.scale);
}

}  // namespace

void PayloadEstimatorConfig::Validate() const {
  auto fail = [](const std::string& field, double value, const std::string& limit) {
    throw std::invalid_argument("PayloadEstimatorConfig." + field + " = " + std::to_string(value) +
                                " outside " + limit);
  };
  if (!(period_s > 0.0)) fail("period_s", period_s, "> 0");
  if (velocity_half_window_ticks < 1) fail("velocity_half_window_ticks", velocity_half_window_ticks, ">= 1");
  if (acceleration_half_window_ticks < 1)
    fail("acceleration_half_window_ticks", acceleration_half_window_ticks, ">= 1");
  if (stride_ticks < 1) fail("stride_ticks", stride_ticks, ">= 1");
  if (!(min_speed_m_s > 0.0)) fail("min_speed_m_s", min_speed_m_s, "> 0");
  if (!(stroke_margin_m >= 0.0)) fail("stroke_margin_m", stroke_margin_m, ">= 0");
  if (min_samples_per_direction < 10) fail("min_samples_per_direction", min_samples_per_direction, ">= 10");
  if (!(max_scale_std >= 0.0)) fail("max_scale_std", max_scale_std, ">= 0");
}

void PayloadRecord::Add(std::uint64_t tick, std::size_t leg, double reading_m, double cap_pressure_pa,
                        double rod_pressure_pa) {
  if (leg >= kNumLegs) return;
  legs_[leg].push_back({tick, reading_m, cap_pressure_pa, rod_pressure_pa});
}

std::size_t PayloadRecord::size() const {
  std::size_t n = 0;
  for (const auto& l : legs_) n += l.size();
  return n;
}

PayloadEstimate EstimatePayload(const RigParams& rig, const KinematicCalibration& calibration,
                                const PayloadRecord& record, const PayloadEstimatorConfig& config) {
  config.Validate();
  PayloadEstimate est;
  const DenseLegs d = Densify(rig, calibration, record);
  const int hv = config.velocity_half_window_ticks;
  const int ha = config.acceleration_half_window_ticks;
  const auto h = static_cast<std::size_t>(std::max(hv, ha));
  if (d.ticks <= 2 * h) {
    est.message = "the recording is too short for the payload estimate";
    return est;
  }
  RigParams calibrated = rig;
  calibrated.geometry = CalibratedGeometry(rig.geometry, calibration);
  PlatformInverseDynamics dynamics(calibrated);
  const double mid = rig.cylinder.mid_stroke_length_m;
  const double half_stroke = 0.5 * rig.cylinder.stroke_m - config.stroke_margin_m;
  const double dt = config.period_s;
  LegArray<LegSums> sums{};
  for (std::size_t k = h; k + h < d.ticks; k += static_cast<std::size_t>(config.stride_ticks)) {
    LegArray<double> l{}, v{}, a{};
    bool finite = true, sliding = false;
    for (std::size_t i = 0; i < kNumLegs && finite; ++i) {
      const auto& x = d.length_m[i];
      l[i] = x[k];
      v[i] = (x[k + hv] - x[k - hv]) / (2.0 * hv * dt);
      a[i] = (x[k + ha] - 2.0 * x[k] + x[k - ha]) / (ha * dt * ha * dt);
      finite = std::isfinite(l[i]) && std::isfinite(v[i]) && std::isfinite(a[i]) && std::isfinite(d.force_n[i][k]);
      sliding = sliding || std::abs(v[i]) >= config.min_speed_m_s;
    }
    if (!finite || !sliding) continue;
    PlatformLoad load;
    if (dynamics.Evaluate(l, v, a, load) != KinStatus::kOk) {
      ++est.failed_kinematics;
      continue;
    }
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const double speed = std::abs(v[i]);
      if (speed < config.min_speed_m_s || std::abs(l[i] - mid) > half_stroke) continue;
      const int dir = v[i] > 0.0 ? 0 : 1;
      Column x = Column::Zero();
      x[0] = load.force_scaled_n[i];
      x[1 + 3 * dir] = 1.0;
      x[2 + 3 * dir] = speed;
      x[3 + 3 * dir] = speed * speed;
      const double y = d.force_n[i][k] - load.force_fixed_n[i];
      LegSums& s = sums[i];
      s.n.noalias() += x * x.transpose();
      s.r += y * x;
      s.yy += y * y;
      ++s.count;
      ++s.per_direction[dir];
    }
  }
  double info_sum = 0.0, weighted = 0.0;
  int legs_used = 0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    est.legs[i].samples = sums[i].count;
    if (!SolveLeg(sums[i], config.min_samples_per_direction, est.legs[i])) continue;
    info_sum += est.legs[i].information;
    weighted += est.legs[i].information * est.legs[i].scale;
    ++legs_used;
  }
  if (legs_used < 2 || !(info_sum > 0.0)) {
    est.message = "too few sliding samples: " + std::to_string(legs_used) +
                  " legs moved enough for a payload estimate (at least 2 needed)";
    return est;
  }
  est.scale = weighted / info_sum;
  double scatter = 0.0;
  for (const auto& leg : est.legs)
    if (leg.information > 0.0) scatter += leg.information * (leg.scale - est.scale) * (leg.scale - est.scale);
  est.scale_std = std::sqrt(scatter / ((legs_used - 1) * info_sum));
  est.mass_kg = est.scale * rig.platform.mass_kg;
  est.inertia_diag_kg_m2 = est.scale * rig.platform.inertia_diag_kg_m2;
  est.ok = std::isfinite(est.scale) && est.scale > 0.0;
  if (!est.ok) est.message = "the payload estimate is not a positive number";
  est.precise = est.ok && est.scale_std <= config.max_scale_std;
  return est;
}

}  // namespace hexa
