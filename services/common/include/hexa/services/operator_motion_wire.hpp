// OperatorCommand's jog, goal and frames fields (idl/hexa.idl) -> the core's requests
// (core/operator_motion.hpp, core/user_frames.hpp), checked by operator_motion_checks.hpp. No
// allocation.
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

// The frames' fields -> the core's request (its bounds left at their defaults: the supervisor
// checks the request against its configured ones, OperatorMotion::SetFrames).
template <std::size_t N>
bool FramesFromWire(const hexa_msg_OperatorCommand& c, UserFramesConfig& frames, char (&why)[N]) {
  if (!CheckFrames(c.pivot_m, c.tool_position_m, c.tool_orientation_wxyz, c.work_position_m,
                   c.work_orientation_wxyz, why, N))
    return false;
  for (int k = 0; k < 3; ++k) {
    frames.p_PC_P_m[k] = c.pivot_m[k];
    frames.X_PT.p_BP_B_m[k] = c.tool_position_m[k];
    frames.X_BW.p_BP_B_m[k] = c.work_position_m[k];
  }
  const double* t = c.tool_orientation_wxyz;
  const double* w = c.work_orientation_wxyz;
  return RotationFromUnitQuaternion(t[0], t[1], t[2], t[3], frames.X_PT.R_BP) &&  // checked above
         RotationFromUnitQuaternion(w[0], w[1], w[2], w[3], frames.X_BW.R_BP);
}

}  // namespace hexa::wire
