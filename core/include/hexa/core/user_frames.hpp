// Pivot point and user frames (docs/operate.md "Pivot point and user frames"): the pose algebra
// used by jog, pose goals and streams. Pure functions of fixed-size Eigen types; no allocation.
//
// Frames (Drake-style names, X_AB = pose of B in A):
//   B  base frame (pose.hpp), P  platform frame,
//   C  pivot frame: origin at the pivot point p_PC_P (fixed to the platform), axes of P;
//      every rotation commanded by jog, goals and streams turns about this point,
//   T  tool frame X_PT (fixed to the platform): tool-frame jog axes, goal poses,
//   W  work frame X_BW (fixed to the base): base-frame jog axes, goal poses, stream axes.
// Changing any of them never moves the platform: X_BP is kept, only the meaning of the next
// command changes.
#pragma once

#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexa/core/pose.hpp"

namespace hexa {

struct UserFramesConfig {
  Eigen::Vector3d p_PC_P_m = Eigen::Vector3d::Zero();  // pivot point, in P
  Pose X_PT;                                           // tool frame in P
  Pose X_BW;                                           // work frame in B
  // Plausibility bounds: a pivot or tool 10 m from the platform is a typing error, not a
  // centre of rotation (|p_PC_P|, |p_PT_P| <= max_pivot_distance_m; |p_BW_B| <= max_work_offset_m).
  double max_pivot_distance_m = 0.5;
  double max_work_offset_m = 1.0;
  // Throws std::invalid_argument naming field, value and limit: non-finite values, offsets
  // beyond the bounds, rotations that are not orthonormal (|R^T R - I| > 1e-9, det != 1).
  void Validate() const;
};

// The rules of Validate() for frames asked for at run time, with the bounds of `bounds` (the
// configured max_pivot_distance_m and max_work_offset_m, not the request's own): false with
// `message` (NUL-terminated) naming the field, the value and the limit. Neither throws nor
// allocates.
bool CheckFramesRequest(const UserFramesConfig& request, const UserFramesConfig& bounds,
                        char* message, std::size_t message_size) noexcept;

// Rotation from a quaternion (w, x, y, z) given by a user: kept only if its norm is within
// 1e-6 of 1 (a non-unit quaternion is refused, not normalised). False otherwise.
bool RotationFromUnitQuaternion(double w, double x, double y, double z, Eigen::Matrix3d& R);

Pose Compose(const Pose& X_AB, const Pose& X_BC);
Pose Inverse(const Pose& X_AB);
// R = Exp(rotation_vector) (Rodrigues), exact for any angle.
Eigen::Matrix3d RotationFromVector(const Eigen::Vector3d& rotation_vector_rad);

// X_BC of the pivot frame for a platform pose, and back.
Pose PivotPose(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m);
Pose PlatformFromPivot(const Pose& X_BC, const Eigen::Vector3d& p_PC_P_m);

// The platform pose after moving for `dt_s` with a constant twist of the pivot frame
// [v_BC_B; w_BC_B] (linear velocity of the pivot point, angular velocity, both in B):
//   R' = Exp(w dt) R,  p_C' = p_C + v dt,  p_P' = p_C' - R' p_PC_P.
// Exact for a constant twist; with v = 0 the pivot point does not move, whatever w.
Pose IntegratePivotTwist(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m,
                         const Vector6d& twist_C_B, double dt_s);

// Velocity of the platform origin for a pivot twist: v_P = v_C + w x (p_P - p_C).
Vector6d PlatformTwistFromPivotTwist(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m,
                                     const Vector6d& twist_C_B);

enum class JogFrame { kWork, kTool };
const char* ToString(JogFrame frame);  // "work", "tool"

// Rotation of the jog axes in B: R_BW for kWork, R_BP R_PT for kTool (turns with the platform).
Eigen::Matrix3d JogAxes(JogFrame frame, const Pose& X_BP, const UserFramesConfig& frames);
// A twist given in the jog axes, re-expressed in B (both halves rotated).
Vector6d TwistInBase(const Vector6d& twist_jog, const Eigen::Matrix3d& R_B_jog);

// Pose goal: the tool frame's pose in the work frame, X_WT -> X_BP = X_BW X_WT X_PT^-1.
Pose PlatformPoseFromToolGoal(const Pose& X_WT, const UserFramesConfig& frames);
// And back: X_WT of a platform pose.
Pose ToolPoseInWork(const Pose& X_BP, const UserFramesConfig& frames);

// Stream / cueing displacement d = [x y z roll pitch yaw] of the pivot frame from its neutral
// pose, in the work frame's axes: p_C = p_C0 + R_BW d_p, R_BC = R_BW R(d_rpy) R_BW^T R_BC0.
// The pivot point moves by d_p only: a pure rotation keeps it still.
Pose PlatformPoseFromDisplacement(const Pose& X_BP_neutral, const Vector6d& displacement,
                                  const UserFramesConfig& frames);

}  // namespace hexa
