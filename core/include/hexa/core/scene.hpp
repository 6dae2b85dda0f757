// What the 3-D scene of the platform shows (docs/foxglove.md), as plain geometry: leg segments
// between their joints for a pose (eq 46), the joint outlines of base and platform, and a
// display state per leg latched from what the leg controllers, the plant and the supervisor
// report. No protobuf, no clock: the recorder and the bridge turn this into Foxglove messages.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// Colour classes of a leg in the scene, in increasing precedence.
enum class LegDisplayState : std::uint8_t {
  kUnknown,        // nothing heard from the leg's controller yet
  kOk,             // the primary controller commands the valve
  kStandbyActive,  // the hot standby commands the valve (the primary is gone)
  kHold,           // the controller holds (no / stale setpoint, bad input, supervisor hold)
  kFault,          // the plant or a node reported a fault of this leg (latched, see below)
};
const char* ToString(LegDisplayState state);

// One leg drawn between its base joint A_i and its platform joint B_i, both in B.
struct LegSegment {
  Eigen::Vector3d p_BA_B_m = Eigen::Vector3d::Zero();  // base joint
  Eigen::Vector3d p_BB_B_m = Eigen::Vector3d::Zero();  // platform joint, p + R b_i
  double length_m = 0.0;                               // |p + R b_i - a_i| (eq 46)
};
LegArray<LegSegment> LegSegments(const GeometryParams& geometry, const Pose& pose);

// Joint indices ordered by azimuth about z: the outline polygon through the six joints of the
// base (platform_side false) or of the platform (true).
LegArray<std::size_t> OutlineOrder(const GeometryParams& geometry, bool platform_side);

// Display state per leg from the event streams. A fault naming a leg is latched until the
// supervisor is seen leaving HOLD after it (an operator reset); the controller's own status
// (valve command) decides otherwise.
class LegStateTracker {
 public:
  // leg_id 1..6; other ids are ignored.
  void OnValveCommand(std::uint32_t leg_id, bool status_ok, bool standby);
  void OnLegFault(std::uint32_t leg_id);
  void OnSupervisorHold(bool hold);
  LegDisplayState State(std::size_t leg_index) const;

 private:
  LegArray<LegDisplayState> controller_{};  // kUnknown until the first command
  LegArray<bool> fault_{};
  bool supervisor_hold_ = false;
};

}  // namespace hexa
