// OperatorCommand's jog and goal fields (idl/hexa.idl) -> the core's requests
// (core/operator_motion.hpp), checked by operator_motion_checks.hpp. No allocation.
#pragma once

#include <cstddef>
#include <cstdio>

#include "hexa.h"
#include "hexa/core/operator_motion.hpp"
#include "hexa/core/user_frames.hpp"
#include "hexa/services/operator_motion_checks.hpp"

namespace hexa::wire {

template <std::size_t N>
bool JogFromWire(const hexa_msg_OperatorCommand& c, JogRequest& jog, char (&why)[N]) {
  if (c.jog_frame != hexa_msg_JOG_FRAME_WORK && c.jog_frame != hexa_msg_JOG_FRAME_TOOL) {
    std::snprintf(why, N, "jog frame %d is neither work (0) nor tool (1)", static_cast<int>(c.jog_frame));
    return false;
  }
  if (!CheckJog(c.jog_velocity_m_s, c.jog_angular_velocity_rad_s, why, N)) return false;
  for (int k = 0; k < 3; ++k) {
    jog.twist[k] = c.jog_velocity_m_s[k];
    jog.twist[k + 3] = c.jog_angular_velocity_rad_s[k];
  }
  jog.frame = c.jog_frame == hexa_msg_JOG_FRAME_TOOL ? JogFrame::kTool : JogFrame::kWork;
  return true;
}

template <std::size_t N>
bool GoalFromWire(const hexa_msg_OperatorCommand& c, Pose& goal_X_BP, char (&why)[N]) {
  if (!CheckGoal(c.goal_position_m, c.goal_orientation_wxyz, why, N)) return false;
  for (int k = 0; k < 3; ++k) goal_X_BP.p_BP_B_m[k] = c.goal_position_m[k];
  const double* q = c.goal_orientation_wxyz;
  return RotationFromUnitQuaternion(q[0], q[1], q[2], q[3], goal_X_BP.R_BP);  // checked above
}

}  // namespace hexa::wire
