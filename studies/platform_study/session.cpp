// platform_study: the paper session's start and tick, and the first-harmonic fit.
#include "platform_study.hpp"

namespace platform_study {

hexa::Vector6d g_combined_axis_scale = hexa::Vector6d::Ones();

hexa::StartRequest PaperStart(const hexa::LockstepSimulation& sim, PaperMotion motion, int periods) {
  if (motion != PaperMotion::kCombined || g_combined_axis_scale == hexa::Vector6d::Ones()) {
    return sim.supervisor().PreparePaperStart(motion, periods);
  }
  const auto paper = hexa::MakePaperMotion(motion, sim.supervisor().home_xyz_rpy(), periods);
  hexa::Vector6d phase = hexa::Vector6d::Zero();
  phase[1] = 3.14159265358979323846 / 2.0;  // eq 49: y = 8 cos
  auto scaled = std::make_shared<const hexa::SinusoidMotion>(
      paper->centre(), paper->amplitude().cwiseProduct(g_combined_axis_scale), phase,
      paper->frequency_hz(), periods > 0 ? periods : hexa::DefaultPeriods(motion));
  return sim.supervisor().PrepareStart(hexa::Trajectory(scaled, sim.supervisor().rest_xyz_rpy(),
                                                        sim.supervisor().home_xyz_rpy(),
                                                        sim.supervisor().timing()));
}

std::vector<int> MovingAxes(PaperMotion m) {
  switch (m) {
    case PaperMotion::kX: return {0};
    case PaperMotion::kY: return {1};
    case PaperMotion::kZ: return {2};
    case PaperMotion::kRoll: return {3};
    case PaperMotion::kPitch: return {4};
    case PaperMotion::kYaw: return {5};
    case PaperMotion::kCombined: return {0, 1, 2};
  }
  return {};
}

// One tick of a paper session: the start command goes with the first supervisor tick.
// Returns false when the plant reports an error.
bool TickSession(hexa::LockstepSimulation& sim, const hexa::StartRequest& start, bool due,
                 bool started) {
  const bool starting = due && !started;
  return sim.Tick(starting ? hexa::OperatorCommandKind::kStart : hexa::OperatorCommandKind::kNone,
                  starting ? &start : nullptr) == hexa::PlantStatus::kOk;
}

Harmonic FitHarmonic(const std::vector<double>& t, const std::vector<double>& y, double w) {
  double m[3][3] = {}, r[3] = {};
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double f[3] = {1.0, std::sin(w * t[k]), std::cos(w * t[k])};
    for (int i = 0; i < 3; ++i) {
      r[i] += f[i] * y[k];
      for (int j = 0; j < 3; ++j) m[i][j] += f[i] * f[j];
    }
  }
  // 3x3 Gauss elimination (well conditioned over whole periods).
  for (int i = 0; i < 3; ++i) {
    for (int k = i + 1; k < 3; ++k) {
      const double q = m[k][i] / m[i][i];
      for (int j = i; j < 3; ++j) m[k][j] -= q * m[i][j];
      r[k] -= q * r[i];
    }
  }
  double x[3];
  for (int i = 2; i >= 0; --i) {
    double s = r[i];
    for (int j = i + 1; j < 3; ++j) s -= m[i][j] * x[j];
    x[i] = s / m[i][i];
  }
  return Harmonic{x[0], x[1], x[2]};
}

// Angular frequency of a paper motion (rad/s) and an angle wrapped to (-pi, pi].
double MotionOmega(PaperMotion motion) {
  return 2.0 * 3.14159265358979323846 * (motion == PaperMotion::kCombined ? 1.0 : 0.1);
}
double WrapPi(double a) {
  while (a > 3.14159265358979323846) a -= 2 * 3.14159265358979323846;
  while (a < -3.14159265358979323846) a += 2 * 3.14159265358979323846;
  return a;
}

}  // namespace platform_study
