// Pivot point and user frames (see user_frames.hpp, docs/operate.md).
#include "hexa/core/user_frames.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hexa/core/param_checks.hpp"

namespace hexa {
namespace {

void CheckVector(ParamChecker& c, const std::string& field, const Eigen::Vector3d& v,
                 double max_norm_m, const char* what) {
  bool finite = true;
  for (int i = 0; i < 3; ++i) finite = c.Finite(field + "[" + std::to_string(i) + "]", v[i]) && finite;
  if (finite && !(v.norm() <= max_norm_m)) {
    c.Fail(field, std::string(what) + " is too far away", FormatParam(v.norm()) + " m",
           "<= " + FormatParam(max_norm_m) + " m");
  }
}

void CheckRotation(ParamChecker& c, const std::string& field, const Eigen::Matrix3d& R) {
  if (!R.allFinite()) {
    c.Fail(field, "rotation must be finite", "non-finite", "finite");
    return;
  }
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(orthogonality <= 1e-9) || !(R.determinant() > 0.0)) {
    c.Fail(field, "rotation must be orthonormal and proper",
           "|R^T R - I| = " + FormatParam(orthogonality), "<= 1e-09, det = +1");
  }
}

}  // namespace

void UserFramesConfig::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.Positive("frames.max_pivot_distance_m", max_pivot_distance_m, "pivot distance bound");
  c.Positive("frames.max_work_offset_m", max_work_offset_m, "work offset bound");
  CheckVector(c, "frames.p_PC_P_m", p_PC_P_m, max_pivot_distance_m, "pivot point");
  CheckVector(c, "frames.tool.p_PT_P_m", X_PT.p_BP_B_m, max_pivot_distance_m, "tool origin");
  CheckRotation(c, "frames.tool.R_PT", X_PT.R_BP);
  CheckVector(c, "frames.work.p_BW_B_m", X_BW.p_BP_B_m, max_work_offset_m, "work origin");
  CheckRotation(c, "frames.work.R_BW", X_BW.R_BP);
  ThrowIfIssues(issues, "user frames");
}

namespace {

bool OffsetOk(const char* field, const Eigen::Vector3d& v, double max_norm_m, const char* what,
              char* message, std::size_t size) noexcept {
  if (!v.allFinite()) {
    std::snprintf(message, size, "%s: %s must be finite (value %g %g %g)", field, what, v.x(),
                  v.y(), v.z());
    return false;
  }
  if (!(v.norm() <= max_norm_m)) {
    std::snprintf(message, size, "%s: %s is too far away (value %.4g m, limit <= %.4g m)", field,
                  what, v.norm(), max_norm_m);
    return false;
  }
  return true;
}

bool RotationOk(const char* field, const Eigen::Matrix3d& R, char* message, std::size_t size) noexcept {
  const double orthogonality =
      R.allFinite() ? (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() : INFINITY;
  if (!(orthogonality <= 1e-9) || !(R.determinant() > 0.0)) {
    std::snprintf(message, size,
                  "%s: rotation must be orthonormal and proper (|R^T R - I| = %.3g, limit <= "
                  "1e-09, det = +1)",
                  field, orthogonality);
    return false;
  }
  return true;
}

}  // namespace

bool CheckFramesRequest(const UserFramesConfig& request, const UserFramesConfig& bounds,
                        char* message, std::size_t message_size) noexcept {
  if (message_size > 0) message[0] = '\0';
  return OffsetOk("frames.p_PC_P_m", request.p_PC_P_m, bounds.max_pivot_distance_m,
                  "pivot point (from the platform origin)", message, message_size) &&
         OffsetOk("frames.tool.p_PT_P_m", request.X_PT.p_BP_B_m, bounds.max_pivot_distance_m,
                  "tool origin (from the platform origin)", message, message_size) &&
         RotationOk("frames.tool.R_PT", request.X_PT.R_BP, message, message_size) &&
         OffsetOk("frames.work.p_BW_B_m", request.X_BW.p_BP_B_m, bounds.max_work_offset_m,
                  "work origin (from the base origin)", message, message_size) &&
         RotationOk("frames.work.R_BW", request.X_BW.R_BP, message, message_size);
}

bool RotationFromUnitQuaternion(double w, double x, double y, double z, Eigen::Matrix3d& R) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (!std::isfinite(norm) || !(std::abs(norm - 1.0) <= 1e-6)) return false;
  R = Eigen::Quaterniond(w / norm, x / norm, y / norm, z / norm).toRotationMatrix();
  return true;
}

Pose Compose(const Pose& X_AB, const Pose& X_BC) {
  Pose X_AC;
  X_AC.R_BP = X_AB.R_BP * X_BC.R_BP;
  X_AC.p_BP_B_m = X_AB.p_BP_B_m + X_AB.R_BP * X_BC.p_BP_B_m;
  return X_AC;
}

Pose Inverse(const Pose& X_AB) {
  Pose X_BA;
  X_BA.R_BP = X_AB.R_BP.transpose();
  X_BA.p_BP_B_m = -(X_BA.R_BP * X_AB.p_BP_B_m);
  return X_BA;
}

Eigen::Matrix3d RotationFromVector(const Eigen::Vector3d& rotation_vector_rad) {
  const double angle = rotation_vector_rad.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector_rad / angle).toRotationMatrix();
}

Pose PivotPose(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m) {
  Pose X_BC;
  X_BC.R_BP = X_BP.R_BP;
  X_BC.p_BP_B_m = X_BP.p_BP_B_m + X_BP.R_BP * p_PC_P_m;
  return X_BC;
}

Pose PlatformFromPivot(const Pose& X_BC, const Eigen::Vector3d& p_PC_P_m) {
  Pose X_BP;
  X_BP.R_BP = X_BC.R_BP;
  X_BP.p_BP_B_m = X_BC.p_BP_B_m - X_BC.R_BP * p_PC_P_m;
  return X_BP;
}

Pose IntegratePivotTwist(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m,
                         const Vector6d& twist_C_B, double dt_s) {
  Pose X_BC = PivotPose(X_BP, p_PC_P_m);
  X_BC.p_BP_B_m += twist_C_B.head<3>() * dt_s;
  X_BC.R_BP = RotationFromVector(twist_C_B.tail<3>() * dt_s) * X_BC.R_BP;
  return PlatformFromPivot(X_BC, p_PC_P_m);
}

Vector6d PlatformTwistFromPivotTwist(const Pose& X_BP, const Eigen::Vector3d& p_PC_P_m,
                                     const Vector6d& twist_C_B) {
  Vector6d twist_P_B = twist_C_B;
  const Eigen::Vector3d p_CP_B = -(X_BP.R_BP * p_PC_P_m);
  twist_P_B.head<3>() += twist_C_B.tail<3>().cross(p_CP_B);
  return twist_P_B;
}

const char* ToString(JogFrame frame) {
  switch (frame) {
    case JogFrame::kWork: return "work";
    case JogFrame::kTool: return "tool";
  }
  return "unknown";
}

Eigen::Matrix3d JogAxes(JogFrame frame, const Pose& X_BP, const UserFramesConfig& frames) {
  return frame == JogFrame::kTool ? Eigen::Matrix3d(X_BP.R_BP * frames.X_PT.R_BP)
                                  : frames.X_BW.R_BP;
}

Vector6d TwistInBase(const Vector6d& twist_jog, const Eigen::Matrix3d& R_B_jog) {
  Vector6d twist_B;
  twist_B.head<3>() = R_B_jog * twist_jog.head<3>();
  twist_B.tail<3>() = R_B_jog * twist_jog.tail<3>();
  return twist_B;
}

Pose PlatformPoseFromToolGoal(const Pose& X_WT, const UserFramesConfig& frames) {
  return Compose(Compose(frames.X_BW, X_WT), Inverse(frames.X_PT));
}

Pose ToolPoseInWork(const Pose& X_BP, const UserFramesConfig& frames) {
  return Compose(Compose(Inverse(frames.X_BW), X_BP), frames.X_PT);
}

Pose PlatformPoseFromDisplacement(const Pose& X_BP_neutral, const Vector6d& displacement,
                                  const UserFramesConfig& frames) {
  const Eigen::Matrix3d& R_BW = frames.X_BW.R_BP;
  Pose X_BC = PivotPose(X_BP_neutral, frames.p_PC_P_m);
  X_BC.p_BP_B_m += R_BW * displacement.head<3>();
  X_BC.R_BP = R_BW * RotationFromRollPitchYaw(displacement.tail<3>()) * R_BW.transpose() *
              X_BC.R_BP;
  return PlatformFromPivot(X_BC, frames.p_PC_P_m);
}

}  // namespace hexa
