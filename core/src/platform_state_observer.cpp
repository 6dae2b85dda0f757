// Platform state observer: a modal steady-state Kalman filter in leg space
// (platform_state_observer.hpp, docs/controller_additions.md "Platform state observer").
#include "hexa/core/platform_state_observer.hpp"

#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

Pose HomePose(const GeometryParams& geometry) {
  Pose home;
  home.p_BP_B_m = geometry.home_position_m;
  home.R_BP.setIdentity();
  return home;
}

// Mode k's filter: leg_observer.hpp's model with the mode's mass (the force noise of the six
// legs maps to the mode's acceleration through 1 / m_k: V is orthonormal).
LegObserverConfig ModeFilterConfig(const PlatformStateObserverConfig& c, double mass_kg) {
  LegObserverConfig o;
  o.period_s = c.period_s;
  o.mass_kg = mass_kg;
  o.length_sigma_m = c.length_sigma_m;
  o.force_sigma_n = c.force_sigma_n;
  o.disturbance_rate_m_s3 = c.disturbance_rate_m_s3;
  return o;
}

// M_ls at home (throws when the geometry gives none: Validate's check).
Matrix6d HomeMassMatrix(const PlatformStateObserverConfig& c) {
  Matrix6d m;
  if (LegSpaceMassMatrix(c.geometry, c.inertial, HomePose(c.geometry), m) != KinStatus::kOk) {
    throw std::invalid_argument(
        "PlatformStateObserverConfig.geometry: no leg-space mass matrix at the home pose "
        "(singular leg Jacobian)");
  }
  return m;
}

Eigen::SelfAdjointEigenSolver<Matrix6d> Modes(const PlatformStateObserverConfig& c) {
  return Eigen::SelfAdjointEigenSolver<Matrix6d>(HomeMassMatrix(c));
}

}  // namespace

PlatformStateObserverConfig PlatformStateObserverConfig::FromRig(const RigParams& rig) {
  PlatformStateObserverConfig c;
  c.geometry = rig.geometry;
  c.inertial = PlatformInertialParams::FromRig(rig);
  c.cylinder = rig.cylinder;
  c.atmosphere_pressure_pa = rig.air.atmosphere_pressure_pa;
  c.length_sigma_m = rig.sensors.length_sigma_m;
  return c;
}

void PlatformStateObserverConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.Positive("period_s", period_s, "observer period");
  c.Positive("length_sigma_m", length_sigma_m, "potentiometer noise");
  c.NonNegative("force_sigma_n", force_sigma_n, "pneumatic force noise");
  c.Positive("disturbance_rate_m_s3", disturbance_rate_m_s3, "disturbance random walk");
  c.Positive("inertial.platform_mass_kg", inertial.platform_mass_kg, "platform mass");
  c.Positive("cylinder.cap_area_m2", cylinder.cap_area_m2, "cap area");
  c.Positive("cylinder.annulus_area_m2", cylinder.annulus_area_m2, "annulus area");
  ThrowIfIssues(issues, "PlatformStateObserverConfig");
}

PlatformStateObserver::PlatformStateObserver(const PlatformStateObserverConfig& config)
    : config_((config.Validate(), config)),
      modes_(Modes(config_).eigenvectors()),
      mode_mass_kg_(Modes(config_).eigenvalues()),
      filters_{LegObserver(ModeFilterConfig(config_, mode_mass_kg_[0])),
               LegObserver(ModeFilterConfig(config_, mode_mass_kg_[1])),
               LegObserver(ModeFilterConfig(config_, mode_mass_kg_[2])),
               LegObserver(ModeFilterConfig(config_, mode_mass_kg_[3])),
               LegObserver(ModeFilterConfig(config_, mode_mass_kg_[4])),
               LegObserver(ModeFilterConfig(config_, mode_mass_kg_[5]))} {
  InverseKinematics(config_.geometry, HomePose(config_.geometry), home_length_m_);
  Reset();
}

void PlatformStateObserver::Reset() {
  for (auto& f : filters_) f.Reset();
  pose_ = HomePose(config_.geometry);
  twist_B_.setZero();
  primed_ = false;
}

void PlatformStateObserver::Update(const PlatformStateObserverInput& in,
                                   PlatformStateObserverOutput& out) noexcept {
  Vector6d length, force;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int ii = static_cast<int>(i);
    length[ii] = in.length_m[i] - home_length_m_[i];
    force[ii] = in.cap_pressure_pa[i] * config_.cylinder.cap_area_m2 -
                in.rod_pressure_pa[i] * config_.cylinder.annulus_area_m2 -
                config_.atmosphere_pressure_pa * config_.cylinder.rod_area_m2;
  }
  if (!length.allFinite() || !force.allFinite()) {
    out.valid = false;
    return;
  }
  // The model's acceleration at the previous estimate: l'' = c + M_ls^-1 (F_p - f0).
  Vector6d acceleration = Vector6d::Zero();
  if (primed_) {
    PlatformMotion still;
    still.pose = pose_;
    still.twist_B = twist_B_;
    LegForceResult f0;
    Matrix6d m_ls;
    if (LegForcesForMotion(config_.geometry, config_.inertial, still, f0) == KinStatus::kOk &&
        LegSpaceMassMatrix(config_.geometry, config_.inertial, pose_, m_ls) == KinStatus::kOk) {
      Vector6d net, c;
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        net[static_cast<int>(i)] = force[static_cast<int>(i)] - f0.force_n[i];
        c[static_cast<int>(i)] = f0.leg_acceleration_m_s2[i];
      }
      acceleration = c + m_ls.ldlt().solve(net);
    }
  }
  const Vector6d eta = modes_.transpose() * length;
  const Vector6d u = modes_.transpose() * acceleration;
  Vector6d eta_hat, eta_dot_hat;
  for (int k = 0; k < 6; ++k) {
    filters_[static_cast<std::size_t>(k)].Update(eta[k], mode_mass_kg_[k] * u[k]);
    eta_hat[k] = filters_[static_cast<std::size_t>(k)].position_m();
    eta_dot_hat[k] = filters_[static_cast<std::size_t>(k)].velocity_m_s();
  }
  const Vector6d l_hat = modes_ * eta_hat;
  const Vector6d l_dot_hat = modes_ * eta_dot_hat;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    out.length_m[i] = home_length_m_[i] + l_hat[static_cast<int>(i)];
    out.velocity_m_s[i] = l_dot_hat[static_cast<int>(i)];
  }
  // Pose: the IMU's orientation, the position from the six filtered lengths.
  Eigen::Quaterniond q(in.orientation_wxyz[0], in.orientation_wxyz[1], in.orientation_wxyz[2],
                       in.orientation_wxyz[3]);
  if (std::isfinite(q.norm()) && q.norm() > 0.5) {
    q.normalize();
    GqfkLsqResult lsq;
    if (GqfkLeastSquares(config_.geometry, q.toRotationMatrix(), out.length_m, 1.0, lsq) ==
        KinStatus::kOk) {
      pose_.R_BP = q.toRotationMatrix();
      pose_.p_BP_B_m = lsq.p_BP_B_m;
    }
  }
  Matrix6d j;
  LegJacobian(config_.geometry, pose_, j);
  const Eigen::PartialPivLU<Matrix6d> lu(j);
  const Vector6d twist = lu.solve(l_dot_hat);
  if (twist.allFinite()) twist_B_ = twist;
  primed_ = true;
  out.pose = pose_;
  out.twist_B = twist_B_;
  out.valid = true;
}

}  // namespace hexa
