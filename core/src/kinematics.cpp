// Kinematics of the 6-6 Gough-Stewart platform (paper Sec. 4.1, eq 46-48) and the
// forward-kinematics solvers built on them. See docs/kinematics.md for the derivations,
// the paper slips and the measured costs.
//
// Geometry: leg i runs from the base joint a_i = p_BA_B[i] to the platform joint
// p + R b_i, b_i = p_PB_P[i]. Equivalently the platform origin p lies on the sphere of
// radius l_i about O_i = a_i - R b_i (the centres used by GQFK, eq 47).
#include "hexa/core/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace hexa {
namespace {

bool IsValidLength(double length_m) { return std::isfinite(length_m) && length_m > 0.0; }

bool AllLengthsValid(const LegArray<double>& length_m) {
  for (double l : length_m) {
    if (!IsValidLength(l)) return false;
  }
  return true;
}

// A rotation from an IMU is orthonormal to float precision at best; 1e-6 rejects garbage
// (NaN, a scaled or reflected matrix) without rejecting honest round-off.
bool IsRotation(const Eigen::Matrix3d& R) {
  if (!R.allFinite()) return false;
  const double orthonormality_error =
      (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return orthonormality_error < 1e-6 && R.determinant() > 0.0;
}

// Sphere centres O_i = a_i - R b_i (eq 47): p is at distance l_i from O_i.
LegArray<Eigen::Vector3d> SphereCentres(const GeometryParams& geometry,
                                        const Eigen::Matrix3d& R_BP) {
  LegArray<Eigen::Vector3d> centre;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    centre[i] = geometry.p_BA_B[i] - R_BP * geometry.p_PB_P[i];
  }
  return centre;
}

// Rotation vector -> rotation matrix (Rodrigues), exact for any angle.
Eigen::Matrix3d ExpRotation(const Eigen::Vector3d& theta_rad) {
  const double angle_rad = theta_rad.norm();
  if (angle_rad < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle_rad, theta_rad / angle_rad).toRotationMatrix();
}

// Leg-length residuals of a pose: implied - measured.
Vector6d LengthResiduals(const GeometryParams& geometry, const Pose& pose,
                         const LegArray<double>& length_m) {
  Vector6d r;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    r[static_cast<Eigen::Index>(i)] =
        (pose.p_BP_B_m + pose.R_BP * geometry.p_PB_P[i] - geometry.p_BA_B[i]).norm() -
        length_m[i];
  }
  return r;
}

// Least-squares position from the spheres of the legs marked in `used` (at least 4):
// linear estimate from the differenced sphere equations, then Gauss-Newton on the
// nonlinear residuals |p - O_i| - l_i. Returns kOk, kDegenerate or kUnreachable (the
// averaged spheres do not reach the centre plane); p is always finite.
KinStatus SolveSpheres(const LegArray<Eigen::Vector3d>& centre,
                       const LegArray<double>& length_m, const std::array<bool, kNumLegs>& used,
                       int max_gauss_newton_steps, Eigen::Vector3d& p) {
  int n_used = 0;
  Eigen::Vector3d mean_centre = Eigen::Vector3d::Zero();
  double mean_c = 0.0;  // mean of |O_i|^2 - l_i^2
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!used[i]) continue;
    ++n_used;
    mean_centre += centre[i];
    mean_c += centre[i].squaredNorm() - length_m[i] * length_m[i];
  }
  mean_centre /= n_used;
  mean_c /= n_used;

  // Sphere i: |p|^2 - 2 O_i.p + |O_i|^2 - l_i^2 = 0. Subtracting the mean of the used
  // equations removes |p|^2:  2 (O_i - Obar).p = (|O_i|^2 - l_i^2) - mean(...).
  // Normal equations M p = g with M = 4 sum (O_i - Obar)(O_i - Obar)^T: the scatter matrix
  // of the centres, whose weakest eigenvector is the normal of their best-fit plane.
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!used[i]) continue;
    const Eigen::Vector3d row = 2.0 * (centre[i] - mean_centre);
    const double rhs = centre[i].squaredNorm() - length_m[i] * length_m[i] - mean_c;
    M += row * row.transpose();
    g += row * rhs;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(M);
  const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
  const Eigen::Matrix3d V = eig.eigenvectors();
  if (!(lambda[1] > 1e-12 * lambda[2]) || !(lambda[2] > 0.0)) {
    p = mean_centre;
    return KinStatus::kDegenerate;  // centres (nearly) collinear
  }
  // The in-plane part of the linear solution is well determined and exact for exact data
  // (it does not depend on the normal component, since the eigenvectors are M-orthogonal).
  // Along the normal the linear system is (nearly) singular, because the base and platform
  // joints are planar: take that component from the averaged sphere equation instead.
  const Eigen::Vector3d normal = V.col(0);
  const Eigen::Vector3d p_plane =
      V.col(1) * (V.col(1).dot(g) / lambda[1]) + V.col(2) * (V.col(2).dot(g) / lambda[2]);
  // mean_i |p_plane + t n - O_i|^2 = mean_i l_i^2  ->  t^2 + 2 m t + q = 0.
  double m = 0.0, q = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    if (!used[i]) continue;
    const Eigen::Vector3d d = p_plane - centre[i];
    m += normal.dot(d);
    q += d.squaredNorm() - length_m[i] * length_m[i];
  }
  m /= n_used;
  q /= n_used;
  const double discriminant = m * m - q;
  const double root = std::sqrt(std::max(discriminant, 0.0));
  // Of the two intersections pick the one above the base (larger z), as GQFK does.
  const double t = (normal.z() >= 0.0) ? -m + root : -m - root;
  p = p_plane + t * normal;

  // Gauss-Newton on r_i = |p - O_i| - l_i. From the exact linear start it converges in one
  // step; with inconsistent data (non-zero residual) convergence is only linear, and the
  // cap bounds the work.
  for (int step = 0; step < max_gauss_newton_steps; ++step) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      if (!used[i]) continue;
      const Eigen::Vector3d d = p - centre[i];
      const double dist = d.norm();
      if (!(dist > 0.0)) return KinStatus::kDegenerate;
      const Eigen::Vector3d u = d / dist;
      JtJ += u * u.transpose();
      Jtr += u * (dist - length_m[i]);
    }
    const Eigen::Vector3d dp = -JtJ.ldlt().solve(Jtr);
    if (!dp.allFinite()) return KinStatus::kDegenerate;
    p += dp;
    if (dp.norm() < 1e-15) break;
  }
  return discriminant < 0.0 ? KinStatus::kUnreachable : KinStatus::kOk;
}

}  // namespace

const char* ToString(KinStatus status) {
  switch (status) {
    case KinStatus::kOk:
      return "ok";
    case KinStatus::kInvalidInput:
      return "invalid input";
    case KinStatus::kUnreachable:
      return "unreachable";
    case KinStatus::kDegenerate:
      return "degenerate";
    case KinStatus::kNotConverged:
      return "not converged";
  }
  return "unknown";
}

void InverseKinematics(const GeometryParams& geometry, const Pose& pose,
                       LegArray<double>& length_m, LegArray<Eigen::Vector3d>* unit_B) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    // eq 46: l_i = |p + R b_i - a_i| (the paper writes out the expanded square).
    const Eigen::Vector3d leg_B =
        pose.p_BP_B_m + pose.R_BP * geometry.p_PB_P[i] - geometry.p_BA_B[i];
    length_m[i] = leg_B.norm();
    if (unit_B != nullptr) {
      (*unit_B)[i] = length_m[i] > 0.0 ? Eigen::Vector3d(leg_B / length_m[i])
                                       : Eigen::Vector3d::Zero();
    }
  }
}

void LegJacobian(const GeometryParams& geometry, const Pose& pose, Matrix6d& J) {
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const Eigen::Vector3d Rb_B = pose.R_BP * geometry.p_PB_P[i];
    const Eigen::Vector3d leg_B = pose.p_BP_B_m + Rb_B - geometry.p_BA_B[i];
    const double length_m = leg_B.norm();
    const Eigen::Vector3d s_B =
        length_m > 0.0 ? Eigen::Vector3d(leg_B / length_m) : Eigen::Vector3d::Zero();
    // eq 48 with b_i expressed in B: l_dot_i = s_i . (v + w x R b_i)
    //                                        = s_i . v + (R b_i x s_i) . w.
    const auto row = static_cast<Eigen::Index>(i);
    J.block<1, 3>(row, 0) = s_B.transpose();
    J.block<1, 3>(row, 3) = Rb_B.cross(s_B).transpose();
  }
}

KinStatus GqfkPosition(const GeometryParams& geometry, const Eigen::Matrix3d& R_BP,
                       const LegArray<double>& length_m, const std::array<int, 3>& legs,
                       Eigen::Vector3d& p_BP_B_m) {
  p_BP_B_m = geometry.home_position_m;  // finite output on every failure path
  for (int k = 0; k < 3; ++k) {
    if (legs[k] < 0 || legs[k] >= static_cast<int>(kNumLegs)) return KinStatus::kInvalidInput;
    if (!IsValidLength(length_m[legs[k]])) return KinStatus::kInvalidInput;
  }
  if (legs[0] == legs[1] || legs[0] == legs[2] || legs[1] == legs[2]) {
    return KinStatus::kInvalidInput;
  }
  if (!IsRotation(R_BP)) return KinStatus::kInvalidInput;

  // eq 47, as the standard three-sphere intersection (the printed formula is garbled; see
  // docs/kinematics.md). Local frame: e_x from O1 to O2, e_y in the plane of the three
  // centres, e_z = e_x x e_y its normal (the paper's d-hat).
  const Eigen::Vector3d O1 = geometry.p_BA_B[legs[0]] - R_BP * geometry.p_PB_P[legs[0]];
  const Eigen::Vector3d O2 = geometry.p_BA_B[legs[1]] - R_BP * geometry.p_PB_P[legs[1]];
  const Eigen::Vector3d O3 = geometry.p_BA_B[legs[2]] - R_BP * geometry.p_PB_P[legs[2]];
  const double r1 = length_m[legs[0]], r2 = length_m[legs[1]], r3 = length_m[legs[2]];

  const Eigen::Vector3d d12 = O2 - O1;
  const double d = d12.norm();
  const double scale_m = std::max({d, (O3 - O1).norm(), 1e-300});
  if (d < 1e-9 * scale_m) return KinStatus::kDegenerate;
  const Eigen::Vector3d ex = d12 / d;
  const Eigen::Vector3d d13 = O3 - O1;
  const double i = ex.dot(d13);
  const Eigen::Vector3d ey_raw = d13 - i * ex;
  const double j = ey_raw.norm();
  if (j < 1e-9 * scale_m) return KinStatus::kDegenerate;  // collinear centres
  const Eigen::Vector3d ey = ey_raw / j;
  const Eigen::Vector3d ez = ex.cross(ey);

  // Radical planes of spheres (1,2) and (1,3) give the in-plane coordinates.
  const double x = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d);
  const double y = (r1 * r1 - r3 * r3 + i * i + j * j) / (2.0 * j) - (i / j) * x;
  const Eigen::Vector3d foot = O1 + x * ex + y * ey;
  const double h_squared = r1 * r1 - x * x - y * y;
  if (!(h_squared >= 0.0)) {
    p_BP_B_m = foot;  // closest point to an intersection; finite
    return KinStatus::kUnreachable;
  }
  // The two solutions are mirror images in the centre plane: take the one above the base.
  // If that plane is vertical the choice is ambiguous.
  if (std::abs(ez.z()) < 1e-9) {
    p_BP_B_m = foot;
    return KinStatus::kDegenerate;
  }
  const double h = std::sqrt(h_squared);
  p_BP_B_m = foot + (ez.z() > 0.0 ? h : -h) * ez;
  return KinStatus::kOk;
}

KinStatus GqfkLeastSquares(const GeometryParams& geometry, const Eigen::Matrix3d& R_BP,
                           const LegArray<double>& length_m, double outlier_threshold_m,
                           GqfkLsqResult& result) {
  result = GqfkLsqResult{};
  result.p_BP_B_m = geometry.home_position_m;
  if (!AllLengthsValid(length_m) || !IsRotation(R_BP) || !(outlier_threshold_m > 0.0)) {
    return KinStatus::kInvalidInput;
  }
  const LegArray<Eigen::Vector3d> centre = SphereCentres(geometry, R_BP);

  auto residuals_of = [&](const Eigen::Vector3d& p, LegArray<double>& residual_m) {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      residual_m[i] = length_m[i] - (p - centre[i]).norm();  // measured - implied
    }
  };
  auto rms_of = [](const LegArray<double>& residual_m, int skip) {
    double sum = 0.0;
    int n = 0;
    for (int i = 0; i < static_cast<int>(kNumLegs); ++i) {
      if (i == skip) continue;
      sum += residual_m[i] * residual_m[i];
      ++n;
    }
    return std::sqrt(sum / n);
  };
  auto max_abs_of = [](const LegArray<double>& residual_m, int skip) {
    double worst = 0.0;
    for (int i = 0; i < static_cast<int>(kNumLegs); ++i) {
      if (i != skip) worst = std::max(worst, std::abs(residual_m[i]));
    }
    return worst;
  };

  std::array<bool, kNumLegs> used;
  used.fill(true);
  // 12 steps: enough for the linear convergence of Gauss-Newton on one bad leg to settle
  // below a micrometre; consistent data need one.
  constexpr int kFullSteps = 12;
  // Leave-one-out fits only have to be ranked by RMS: the fit without the faulty leg is
  // exact after one step, the others stay centimetres off, so 3 steps rank them reliably.
  constexpr int kRankingSteps = 3;
  Eigen::Vector3d p;
  KinStatus status = SolveSpheres(centre, length_m, used, kFullSteps, p);
  if (status == KinStatus::kDegenerate) {
    result.p_BP_B_m = p;
    return status;
  }
  residuals_of(p, result.residual_m);
  if (max_abs_of(result.residual_m, -1) <= outlier_threshold_m) {
    result.p_BP_B_m = p;
    result.rms_residual_m = rms_of(result.residual_m, -1);
    return status;
  }

  // Some leg disagrees. The largest residual of the six-leg fit does not reliably name the
  // culprit (a bad leg with high leverage pulls the fit toward itself and pushes its error
  // onto the others), so refit without each leg in turn and keep the fit whose five legs
  // agree best. The removed leg is reported only if it really disagrees with that fit.
  int best_leg = -1;
  double best_rms_m = 0.0;
  Eigen::Vector3d best_p = p;
  LegArray<double> best_residual_m{};
  KinStatus best_status = status;
  for (int k = 0; k < static_cast<int>(kNumLegs); ++k) {
    used.fill(true);
    used[k] = false;
    Eigen::Vector3d p_k;
    const KinStatus status_k = SolveSpheres(centre, length_m, used, kRankingSteps, p_k);
    if (status_k == KinStatus::kDegenerate) continue;
    LegArray<double> residual_k;
    residuals_of(p_k, residual_k);
    const double rms_k = rms_of(residual_k, k);
    if (best_leg < 0 || rms_k < best_rms_m) {
      best_leg = k;
      best_rms_m = rms_k;
      best_p = p_k;
      best_residual_m = residual_k;
      best_status = status_k;
    }
  }
  if (best_leg >= 0) {  // finish the winning fit
    used.fill(true);
    used[best_leg] = false;
    best_status = SolveSpheres(centre, length_m, used, kFullSteps, best_p);
    residuals_of(best_p, best_residual_m);
    best_rms_m = rms_of(best_residual_m, best_leg);
  }
  if (best_leg < 0 || std::abs(best_residual_m[best_leg]) <= outlier_threshold_m) {
    // No single leg explains the disagreement: keep the six-leg fit and say so.
    result.p_BP_B_m = p;
    result.rms_residual_m = rms_of(result.residual_m, -1);
    return KinStatus::kUnreachable;
  }
  result.p_BP_B_m = best_p;
  result.residual_m = best_residual_m;
  result.excluded_leg = best_leg;
  result.rms_residual_m = best_rms_m;
  if (best_status != KinStatus::kOk) return best_status;
  // More than one bad leg: the remaining five still disagree.
  return max_abs_of(best_residual_m, best_leg) <= outlier_threshold_m ? KinStatus::kOk
                                                                      : KinStatus::kUnreachable;
}

KinStatus NewtonRaphsonFk(const GeometryParams& geometry, const LegArray<double>& length_m,
                          const Pose& initial_guess, const NewtonFkConfig& config,
                          NewtonFkResult& result) {
  result = NewtonFkResult{};
  result.pose.p_BP_B_m = geometry.home_position_m;
  if (!AllLengthsValid(length_m) || !initial_guess.p_BP_B_m.allFinite() ||
      !IsRotation(initial_guess.R_BP) || config.max_iterations < 1 ||
      !(config.tolerance_m > 0.0)) {
    result.max_residual_m = std::numeric_limits<double>::infinity();
    return KinStatus::kInvalidInput;
  }
  Pose pose = initial_guess;
  Vector6d residual = LengthResiduals(geometry, pose, length_m);
  double max_residual_m = residual.cwiseAbs().maxCoeff();
  Matrix6d J;
  KinStatus status = KinStatus::kNotConverged;
  int iteration = 0;
  while (true) {
    if (max_residual_m <= config.tolerance_m) {
      status = KinStatus::kOk;
      break;
    }
    if (iteration >= config.max_iterations) break;
    ++iteration;
    // Newton step on the small-angle parameterisation [dp; dtheta] (rotation vector in B,
    // R <- Exp(dtheta) R): the leg-length differential is exactly eq 48's J.
    LegJacobian(geometry, pose, J);
    const Eigen::PartialPivLU<Matrix6d> lu(J);
    if (!(lu.rcond() > 1e-12)) {
      status = KinStatus::kDegenerate;
      break;
    }
    const Vector6d step = -lu.solve(residual);
    if (!step.allFinite()) {
      status = KinStatus::kDegenerate;
      break;
    }
    // Backtracking on the max residual: far from the solution (or near a singularity) the
    // full step can overshoot; close to it the full step is always taken (quadratic
    // convergence).
    double fraction = 1.0;
    bool improved = false;
    for (int halving = 0; halving < 30; ++halving, fraction *= 0.5) {
      Pose trial;
      trial.p_BP_B_m = pose.p_BP_B_m + fraction * step.head<3>();
      trial.R_BP = ExpRotation(fraction * step.tail<3>()) * pose.R_BP;
      const Vector6d trial_residual = LengthResiduals(geometry, trial, length_m);
      const double trial_max_m = trial_residual.cwiseAbs().maxCoeff();
      if (trial_max_m < max_residual_m) {
        pose = trial;
        residual = trial_residual;
        max_residual_m = trial_max_m;
        improved = true;
        break;
      }
    }
    if (!improved) break;  // stagnated (round-off floor or no nearby solution)
  }
  // Keep R exactly orthonormal after the chain of small rotations.
  pose.R_BP = Eigen::Quaterniond(pose.R_BP).normalized().toRotationMatrix();
  result.pose = pose;
  result.iterations = iteration;
  result.max_residual_m = max_residual_m;
  return status;
}

}  // namespace hexa
