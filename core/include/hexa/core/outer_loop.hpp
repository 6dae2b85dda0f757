// Task-space outer loop (paper Sec. 4.1, Fig. 7): every 5 ms the pose error
// e = desired - estimated (PoseError, pose.hpp) is mapped to leg-length errors through the
// Jacobian (eq 48), delta_l = J e, and integrated into per-leg corrections:
//   c_i <- clamp(c_i + gain * delta_l_i, -max_correction_m, +max_correction_m)
// The leg controllers track  length_m + correction_m. A constant calibration error (joint
// positions, potentiometer offsets) appears as a constant pose error and is integrated away;
// the clamp bounds what a wrong estimate can do.
#pragma once

#include "hexa/core/control_params.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

struct OuterLoopInput {
  Pose desired;                 // desired pose at this tick
  Pose estimated;               // PoseEstimator output
  bool estimate_valid = true;   // false -> corrections held, nothing integrated
  bool freeze = false;          // supervisor hold -> corrections held
  // Largest |desired leg speed| of this step (eq 46); with OuterLoopParams::gate_leg_speed_m_s
  // the integration is scaled down while the legs move fast.
  double max_leg_speed_m_s = 0.0;
};

struct OuterLoopOutput {
  Vector6d error = Vector6d::Zero();         // [p_d - p; rotation vector], in B
  LegArray<double> mapped_error_m{};         // J e (eq 48)
  LegArray<double> correction_m{};           // accumulated, bounded corrections
  LegArray<bool> saturated{};                // correction at its bound this tick
};

class OuterLoop {
 public:
  // Throws std::invalid_argument for a negative gain or bound.
  OuterLoop(const GeometryParams& geometry, const OuterLoopParams& params);
  void Update(const OuterLoopInput& input, OuterLoopOutput& output) noexcept;
  void Reset() noexcept { correction_m_.fill(0.0); }
  const LegArray<double>& correction_m() const { return correction_m_; }
  const OuterLoopParams& params() const { return params_; }

 private:
  GeometryParams geometry_;
  OuterLoopParams params_;
  LegArray<double> correction_m_{};
};

}  // namespace hexa
