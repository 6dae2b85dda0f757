// platform_study zsplit and modes (main.cpp's header says what they print).
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/platform_dynamics.hpp"

#include "platform_study.hpp"

namespace platform_study {

// Where combined z's error comes from, through the legs: every 1 ms tick of the tracking
// window the six true leg-length errors e = l - l_d(q_d) (plant's true geometry, the
// trajectory of NOW) map to a pose error J(q_d)^-1 e (eq 48, first order), whose z is checked
// against the true z error. e is split on the leg-space modes at home (eigenvectors V_k of
// M_ls, eq 48, the rig's masses): z_k = (J(q_d)^-1 V_k V_k^T e)_z, sum_k z_k = the z error.
// Per mode: its mass, its task direction, the RMS of its leg error, the RMS of z_k and its
// share of z's mean square (mean z_k z / mean z^2; the shares sum to 1). The last column splits
// z_k into what J(home)^-1 gives (the mode's own z at home) and the rest (the pose-dependent
// geometry moving the mode's leg error into z away from home).
void ZSplit(const hexa::LockstepConfig& config, PaperMotion motion, int periods) {
  hexa::LockstepSimulation sim(config);
  sim.Tick();
  const hexa::StartRequest start = PaperStart(sim, motion, periods);
  const hexa::GeometryParams& geometry = sim.plant().true_geometry();
  hexa::Pose home;
  home.p_BP_B_m = geometry.home_position_m;
  home.R_BP.setIdentity();
  hexa::Matrix6d j_home, m_ls;
  hexa::LegJacobian(geometry, home, j_home);
  hexa::LegSpaceMassMatrix(geometry, hexa::PlatformInertialParams::FromRig(config.rig), home, m_ls);
  const Eigen::SelfAdjointEigenSolver<hexa::Matrix6d> eig(m_ls);
  const hexa::Matrix6d v = eig.eigenvectors();
  const hexa::Matrix6d j_home_inv = j_home.inverse();
  double sq_true = 0.0, sq_lin = 0.0, sq_diff = 0.0;
  std::array<double, 6> sq_mode{}, cross_mode{}, sq_leg_mode{}, sq_home{}, sq_leak{};
  long n = 0;
  std::vector<double> t_s, heave_m;  // the desired motion's heave coordinate V_heave^T l_d
  int heave = 0;
  for (int k = 0; k < 6; ++k) {
    if (std::abs((j_home_inv * v.col(k))[2]) > std::abs((j_home_inv * v.col(heave))[2])) heave = k;
  }
  ForEachTrackingTick(sim, start, config.rig.geometry,
                      [&](const hexa::PlatformPlantOutput& p, double, const hexa::TrajectorySample& d,
                          const hexa::LegArray<double>&, const hexa::LegArray<double>&) {
    hexa::LegArray<double> ld{};
    hexa::InverseKinematics(geometry, d.pose, ld);
    hexa::Matrix6d j;
    hexa::LegJacobian(geometry, d.pose, j);
    const hexa::Matrix6d j_inv = j.inverse();
    Eigen::Vector<double, 6> e;
    for (int i = 0; i < 6; ++i) e[i] = p.truth.length_m[i] - ld[i];
    const double z_true = p.truth.pose.p_BP_B_m.z() - d.pose.p_BP_B_m.z();
    t_s.push_back(static_cast<double>(n) * config.tick_s);
    double h = 0.0;
    for (int i = 0; i < 6; ++i) h += v(i, heave) * ld[static_cast<std::size_t>(i)];
    heave_m.push_back(h);
    const double z_lin = (j_inv * e)[2];
    sq_true += z_true * z_true;
    sq_lin += z_lin * z_lin;
    sq_diff += (z_true - z_lin) * (z_true - z_lin);
    for (int k = 0; k < 6; ++k) {
      const double a = v.col(k).dot(e);
      const double zk = (j_inv * v.col(k))[2] * a;
      const double zk_home = (j_home_inv * v.col(k))[2] * a;
      sq_mode[k] += zk * zk;
      cross_mode[k] += zk * z_lin;
      sq_leg_mode[k] += a * a;
      sq_home[k] += zk_home * zk_home;
      sq_leak[k] += (zk - zk_home) * (zk - zk_home);
    }
    ++n;
  });
  if (n == 0) {
    std::fprintf(stderr, "zsplit: empty tracking window\n");
    return;
  }
  const double dn = static_cast<double>(n);
  std::printf("z error RMS %.4f cm, through the legs (J^-1 e) %.4f cm, difference %.4f cm\n",
              100 * std::sqrt(sq_true / dn), 100 * std::sqrt(sq_lin / dn), 100 * std::sqrt(sq_diff / dn));
  std::printf("mode kg | task direction x y z roll pitch yaw | leg error RMS mm | z_k RMS cm | share of z MS | "
              "z_k at home J / pose-dependent rest RMS cm\n");
  for (int k = 0; k < 6; ++k) {
    const hexa::Vector6d dir = j_home_inv * v.col(k);
    std::printf("%7.3f | %6.3f %6.3f %6.3f %6.3f %6.3f %6.3f | %.3f | %.4f | %+.3f | %.4f / %.4f\n",
                eig.eigenvalues()[k], dir[0], dir[1], dir[2], dir[3], dir[4], dir[5],
                1000 * std::sqrt(sq_leg_mode[k] / dn), 100 * std::sqrt(sq_mode[k] / dn),
                sq_lin > 0 ? cross_mode[k] / sq_lin : 0.0, 100 * std::sqrt(sq_home[k] / dn),
                100 * std::sqrt(sq_leak[k] / dn));
  }
  // The desired legs' common (heave) motion: its amplitude at 1-5 x the motion's frequency.
  const double w = MotionOmega(motion);
  std::printf("desired heave coordinate, amplitude mm at 1-5 x f:");
  for (int hk = 1; hk <= 5; ++hk) {
    double a = 0.0, b = 0.0;
    for (std::size_t s = 0; s < t_s.size(); ++s) {
      a += heave_m[s] * std::sin(hk * w * t_s[s]);
      b += heave_m[s] * std::cos(hk * w * t_s[s]);
    }
    std::printf(" %.4f", 1000.0 * 2.0 * std::hypot(a, b) / static_cast<double>(t_s.size()));
  }
  std::printf("\n");
}

// Leg-space modes at home: eigenvalues of J^-T M_p J^-1 + m_leg I (eq 48; the
// rig's platform mass and inertia, the pistons' moving mass), and for each the BS-SMC's
// velocity loop c / (m s) * P(s) * exp(-s tau): c = M lambda + K xi + k_s, P(s) = beta / (s + beta)
// or, with the feedback rate in phi_dot, ((a + beta tf) s + beta) / ((tf s + 1)(s + beta)),
// tau = spool filter + valve spool + the velocity estimate's group delay. Crossover and phase
// margin (docs/measurements/control_light_modes.md "Per-leg lag and leg 2's overshoot on combined").
void Modes(const hexa::LockstepConfig& config, const hexa::study::CoupledLegFeedbackParams& coupled) {
  const hexa::RigParams& rig = config.rig;
  hexa::Pose home;
  home.p_BP_B_m = rig.geometry.home_position_m;
  home.R_BP.setIdentity();
  hexa::Matrix6d J;
  hexa::LegJacobian(rig.geometry, home, J);
  const hexa::Matrix6d j_inv = J.inverse();
  hexa::Matrix6d ml;
  hexa::LegSpaceMassMatrix(rig.geometry, hexa::PlatformInertialParams::FromRig(rig), home, ml);
  const Eigen::SelfAdjointEigenSolver<hexa::Matrix6d> eig(ml);
  const hexa::BsSmcParams& b = config.leg_controller.bssmc;
  const double c = b.effective_mass_kg * b.lambda_1_s + b.switching_gain_n * b.boundary_layer_xi_s_m +
                   b.reaching_proportional_n_s_m;
  hexa::DifferentiatorConfig dc;
  dc.params = config.leg_controller.differentiator;
  dc.sample_period_s = config.tick_s;
  const double tau = b.spool_filter_time_constant_s + rig.valve.spool_time_constant_s +
                     hexa::GaussianDifferentiator(dc).GroupDelaySamples() * config.tick_s;
  const double beta = b.backstepping_beta_1_s;
  // Path from the feedback force to the pressure force (eq 38 with the optional feedback
  // rate in phi_dot): ((a + beta tf) s + beta) / ((tf s + 1)(s + beta)), a the
  // fraction, tf its low-pass; a = 0: beta / (s + beta).
  const double a = b.feedback_rate_fraction;
  const double tf = b.feedback_rate_time_constant_s;
  auto path = [&](double w) {
    const std::complex<double> s(0.0, w);
    return ((a + beta * tf) * s + beta) / ((tf * s + 1.0) * (s + beta));
  };
  std::printf("velocity gain c %.1f N s/m, beta %.1f 1/s, lag %.2f ms, feedback rate fraction %.2f, "
              "low-pass %.2f ms\n", c, beta, 1000 * tau, a, 1000 * tf);
  std::printf("mode mass kg | task direction (x y z m, roll pitch yaw rad per unit) | crossover Hz | phase margin deg\n");
  // Coupled leg feedback (coupled=1): the feedback acts through W = M_ls / M, i.e. with gain
  // (m_k / M) c on mode k: every mode's loop is that of a single mass M.
  const double m_ref = coupled.reference_mass_kg > 0.0 ? coupled.reference_mass_kg : b.effective_mass_kg;
  if (coupled.enabled) {
    // W at home and the gain of independent, equal noise on the six feedback parts to one
    // leg's applied feedback: the Euclidean norm of W's row (1 uncoupled).
    const Eigen::Vector<double, 6> raised =
        coupled.raise_only ? eig.eigenvalues().cwiseMax(m_ref) : eig.eigenvalues();
    const hexa::Matrix6d w = eig.eigenvectors() * raised.asDiagonal() * eig.eigenvectors().transpose() / m_ref;
    std::printf("coupled leg feedback: modes %s m_ref = %.3f kg get the loop of that mass; W row 1: "
                "%.3f %.3f %.3f %.3f %.3f %.3f, noise gain (row norm) %.2f\n",
                coupled.raise_only ? "heavier than" : "all, with", m_ref, w(0, 0), w(0, 1),
                w(0, 2), w(0, 3), w(0, 4), w(0, 5), w.row(0).norm());
  }
  for (int k = 0; k < 6; ++k) {
    const double m = !coupled.enabled   ? eig.eigenvalues()[k]
                     : coupled.raise_only ? std::min(m_ref, eig.eigenvalues()[k])
                                          : m_ref;
    auto gain = [&](double w) { return c / (m * w) * std::abs(path(w)); };
    double lo = 1e-3, hi = 1e5;  // |L| falls monotonically with w (|path| <= 1 + a / (beta tf))
    for (int it = 0; it < 200; ++it) {
      const double mid = std::sqrt(lo * hi);
      (gain(mid) > 1.0 ? lo : hi) = mid;
    }
    const double w = lo;
    const double phase = -0.5 * 3.14159265358979323846 + std::arg(path(w)) - w * tau;
    const hexa::Vector6d dir = j_inv * eig.eigenvectors().col(k);
    std::printf("%8.3f | %7.3f %7.3f %7.3f %7.3f %7.3f %7.3f | %6.1f | %6.1f\n", eig.eigenvalues()[k], dir[0], dir[1], dir[2],
                dir[3], dir[4], dir[5], w / (2 * 3.14159265358979323846),
                180.0 + phase * 57.29577951308232);
  }
}

}  // namespace platform_study
