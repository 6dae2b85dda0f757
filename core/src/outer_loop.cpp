// Task-space outer loop: Jacobian (eq 48) mapping of the pose error, bounded integration.
#include "hexa/core/outer_loop.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/param_checks.hpp"

namespace hexa {

OuterLoop::OuterLoop(const GeometryParams& geometry, const OuterLoopParams& params)
    : geometry_(geometry), params_(params) {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckOuterLoopParams(c, params_, "outer_loop");
  ThrowIfIssues(issues, "OuterLoop");
}

void OuterLoop::Update(const OuterLoopInput& input, OuterLoopOutput& output) noexcept {
  output.saturated.fill(false);
  if (!params_.enabled) {
    correction_m_.fill(0.0);
  }
  if (!input.estimate_valid) {
    output.error.setZero();
    output.mapped_error_m.fill(0.0);
    output.correction_m = correction_m_;
    return;
  }
  output.error = PoseError(input.desired, input.estimated);
  // eq 48 at the desired pose: to first order a small pose displacement e changes the leg
  // lengths by J e. The desired pose is noise-free and is where the legs should be.
  Matrix6d J;
  LegJacobian(geometry_, input.desired, J);
  const Vector6d mapped = J * output.error;
  // What is integrated: translation and orientation errors weighted separately
  // (docs/measurements/tuning.md, "Outer loop"); mapped_error_m stays the plain J e.
  Vector6d weighted = output.error;
  weighted.head<3>() *= params_.translation_gain_scale;
  const Vector6d step = J * weighted;
  const bool integrate = params_.enabled && !input.freeze && step.allFinite();
  // Speed gate (control_params.hpp): full gain at rest, gain / (1 + r^2) as the legs move.
  double gain = params_.gain;
  if (params_.gate_leg_speed_m_s > 0.0) {
    const double r = input.max_leg_speed_m_s / params_.gate_leg_speed_m_s;
    if (std::isfinite(r)) gain /= 1.0 + r * r;
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    output.mapped_error_m[i] = mapped[static_cast<Eigen::Index>(i)];
    if (integrate) {
      const double next =
          correction_m_[i] + gain * step[static_cast<Eigen::Index>(i)];
      correction_m_[i] = std::clamp(next, -params_.max_correction_m, params_.max_correction_m);
    }
    output.saturated[i] = std::abs(correction_m_[i]) >= params_.max_correction_m &&
                          params_.max_correction_m > 0.0;
  }
  output.correction_m = correction_m_;
}

}  // namespace hexa
