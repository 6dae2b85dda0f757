#include "hexa/core/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace hexa {

const char* ToString(LegDisplayState state) {
  switch (state) {
    case LegDisplayState::kUnknown: return "unknown";
    case LegDisplayState::kOk: return "ok";
    case LegDisplayState::kStandbyActive: return "standby active";
    case LegDisplayState::kHold: return "hold";
    case LegDisplayState::kFault: return "fault";
  }
  return "unknown";
}

LegArray<LegSegment> LegSegments(const GeometryParams& geometry, const Pose& pose) {
  LegArray<LegSegment> legs;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    legs[i].p_BA_B_m = geometry.p_BA_B[i];
    legs[i].p_BB_B_m = pose.p_BP_B_m + pose.R_BP * geometry.p_PB_P[i];  // eq 46
    legs[i].length_m = (legs[i].p_BB_B_m - legs[i].p_BA_B_m).norm();
  }
  return legs;
}

LegArray<std::size_t> OutlineOrder(const GeometryParams& geometry, bool platform_side) {
  const auto& joints = platform_side ? geometry.p_PB_P : geometry.p_BA_B;
  LegArray<std::size_t> order;
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::atan2(joints[a].y(), joints[a].x()) < std::atan2(joints[b].y(), joints[b].x());
  });
  return order;
}

void LegStateTracker::OnValveCommand(std::uint32_t leg_id, bool status_ok, bool standby) {
  if (leg_id < 1 || leg_id > kNumLegs) return;
  controller_[leg_id - 1] = !status_ok ? LegDisplayState::kHold
                            : standby  ? LegDisplayState::kStandbyActive
                                       : LegDisplayState::kOk;
}

void LegStateTracker::OnLegFault(std::uint32_t leg_id) {
  if (leg_id < 1 || leg_id > kNumLegs) return;
  fault_[leg_id - 1] = true;
}

void LegStateTracker::OnSupervisorHold(bool hold) {
  if (supervisor_hold_ && !hold) fault_.fill(false);  // reset: the operator cleared the hold
  supervisor_hold_ = hold;
}

LegDisplayState LegStateTracker::State(std::size_t leg_index) const {
  if (leg_index >= kNumLegs) return LegDisplayState::kUnknown;
  if (fault_[leg_index]) return LegDisplayState::kFault;
  return controller_[leg_index];
}

}  // namespace hexa
