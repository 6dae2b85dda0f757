// What a jog, a goal or frames on the operator topic may hold (idl/hexa.idl OperatorCommand):
// one place for the checks, used by the supervisor (any writer's sample, operator_motion_wire.hpp) and by
// the tools that write them (hexa_operator, the Foxglove bridge). Standard C++ only (the bridge's
// WebSocket library is C++17), no allocation; the reason is written into `why`.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdio>

namespace hexa::wire {

// Beyond these a jog is absurd, not just fast (the supervisor's jog limits, 0.05 m/s and
// 0.2 rad/s per axis by default, clamp any smaller one).
inline constexpr double kMaxJogSpeed_m_s = 1.0;
inline constexpr double kMaxJogRate_rad_s = 3.0;
// A goal farther than this from the base origin is absurd (the soft limits refuse far less).
inline constexpr double kMaxGoalDistance_m = 2.0;
// A pivot, tool or work origin farther than this from its frame's origin is absurd, whatever
// the configuration (the supervisor's own bounds, 0.5 m for the pivot and the tool origin from
// the platform origin and 1 m for the work origin from the base origin, refuse far less).
inline constexpr double kMaxFrameOffset_m = 2.0;
// |q| - 1 beyond this: not a unit quaternion (it is not normalised silently; the same
// tolerance as core RotationFromUnitQuaternion).
inline constexpr double kUnitQuaternionTolerance = 1e-6;

namespace detail {
inline bool UnitQuaternion(const char* field, const double (&q)[4], char* why, std::size_t n) {
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!std::isfinite(norm) || !(std::abs(norm - 1.0) <= kUnitQuaternionTolerance)) {
    std::snprintf(why, n, "%s (%g %g %g %g) is not a unit quaternion (|q| = %.9g, tolerance %g)",
                  field, q[0], q[1], q[2], q[3], norm, kUnitQuaternionTolerance);
    return false;
  }
  return true;
}

inline bool FrameOffset(const char* field, const char* from, const double (&p_m)[3], char* why,
                        std::size_t n) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(p_m[k])) {
      std::snprintf(why, n, "%s[%d] is not finite", field, k);
      return false;
    }
  }
  const double distance = std::sqrt(p_m[0] * p_m[0] + p_m[1] * p_m[1] + p_m[2] * p_m[2]);
  if (distance > kMaxFrameOffset_m) {
    std::snprintf(why, n, "%s (%g, %g, %g) is %.4g m from the %s origin: absurd (limit %g m)",
                  field, p_m[0], p_m[1], p_m[2], distance, from, kMaxFrameOffset_m);
    return false;
  }
  return true;
}
}  // namespace detail

inline bool CheckJog(const double (&v_m_s)[3], const double (&w_rad_s)[3], char* why, std::size_t n) {
  static const char* const kAxis[6] = {"vx", "vy", "vz", "wx", "wy", "wz"};
  for (int k = 0; k < 6; ++k) {
    const double v = k < 3 ? v_m_s[k] : w_rad_s[k - 3];
    const double limit = k < 3 ? kMaxJogSpeed_m_s : kMaxJogRate_rad_s;
    if (!std::isfinite(v)) {
      std::snprintf(why, n, "jog %s is not finite", kAxis[k]);
      return false;
    }
    if (std::abs(v) > limit) {
      std::snprintf(why, n, "jog %s = %g %s is absurd (limit %g)", kAxis[k], v,
                    k < 3 ? "m/s" : "rad/s", limit);
      return false;
    }
  }
  return true;
}

inline bool CheckGoal(const double (&p_m)[3], const double (&q_wxyz)[4], char* why, std::size_t n) {
  static const char* const kAxis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(p_m[k])) {
      std::snprintf(why, n, "goal position %s is not finite", kAxis[k]);
      return false;
    }
  }
  const double distance = std::sqrt(p_m[0] * p_m[0] + p_m[1] * p_m[1] + p_m[2] * p_m[2]);
  if (distance > kMaxGoalDistance_m) {
    std::snprintf(why, n, "goal position %.3f m from the base origin is absurd (limit %g m)",
                  distance, kMaxGoalDistance_m);
    return false;
  }
  return detail::UnitQuaternion("goal orientation", q_wxyz, why, n);
}

// FRAMES: the pivot point and the tool frame's origin in the platform frame, the work frame's
// origin in the base frame (m), the tool's and the work frame's orientations (unit quaternions).
// Each value finite, each origin within kMaxFrameOffset_m; the reason names the field, the
// value and the limit. The supervisor then applies its configured bounds (core user_frames.hpp).
inline bool CheckFrames(const double (&pivot_m)[3], const double (&tool_position_m)[3],
                        const double (&tool_orientation_wxyz)[4], const double (&work_position_m)[3],
                        const double (&work_orientation_wxyz)[4], char* why, std::size_t n) {
  return detail::FrameOffset("pivot_m", "platform", pivot_m, why, n) &&
         detail::FrameOffset("tool_position_m", "platform", tool_position_m, why, n) &&
         detail::UnitQuaternion("tool_orientation_wxyz", tool_orientation_wxyz, why, n) &&
         detail::FrameOffset("work_position_m", "base", work_position_m, why, n) &&
         detail::UnitQuaternion("work_orientation_wxyz", work_orientation_wxyz, why, n);
}

}  // namespace hexa::wire
