#include "hexa/core/hardware_lifecycle.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace hexa {

const char* ToString(HardwareState state) {
  switch (state) {
    case HardwareState::kUnconfigured: return "unconfigured";
    case HardwareState::kInactive: return "inactive";
    case HardwareState::kActive: return "active";
  }
  return "unknown";
}

const char* ToString(ActivationRefusal refusal) {
  switch (refusal) {
    case ActivationRefusal::kNone: return "none";
    case ActivationRefusal::kNotConfigured: return "device not configured";
    case ActivationRefusal::kEstopOpen: return "e-stop open";
    case ActivationRefusal::kNoLiveController: return "no live controller";
    case ActivationRefusal::kSensorOutOfRange: return "sensor out of range";
    case ActivationRefusal::kSupplyPressureLow: return "supply pressure low";
  }
  return "unknown";
}

HardwareLifecycleConfig HardwareLifecycleConfig::FromLegController(const LegControllerConfig& leg,
                                                                   int expected_legs) {
  HardwareLifecycleConfig c;
  c.mid_stroke_length_m = leg.model.cylinder.mid_stroke_length_m;
  c.stroke_m = leg.model.cylinder.stroke_m;
  c.length_margin_m = leg.length_margin_m;
  c.min_pressure_pa = leg.min_pressure_pa;
  c.max_pressure_pa = leg.max_pressure_pa;
  c.min_supply_pressure_pa = leg.min_supply_pressure_pa;
  c.expected_legs = expected_legs;
  return c;
}

void HardwareLifecycleConfig::Validate() const {
  auto fail = [](const char* field, double value, const char* limit) {
    char text[200];
    std::snprintf(text, sizeof text, "hardware lifecycle: %s = %g: must be %s", field, value, limit);
    throw std::invalid_argument(text);
  };
  if (!(std::isfinite(mid_stroke_length_m) && mid_stroke_length_m > 0.0))
    fail("mid_stroke_length_m", mid_stroke_length_m, "finite and > 0");
  if (!(std::isfinite(stroke_m) && stroke_m > 0.0)) fail("stroke_m", stroke_m, "finite and > 0");
  if (!(std::isfinite(length_margin_m) && length_margin_m >= 0.0))
    fail("length_margin_m", length_margin_m, "finite and >= 0");
  if (!(std::isfinite(min_pressure_pa) && min_pressure_pa >= 0.0))
    fail("min_pressure_pa", min_pressure_pa, "finite and >= 0");
  if (!(std::isfinite(max_pressure_pa) && max_pressure_pa > min_pressure_pa))
    fail("max_pressure_pa", max_pressure_pa, "finite and > min_pressure_pa");
  if (!(std::isfinite(min_supply_pressure_pa) && min_supply_pressure_pa >= min_pressure_pa &&
        min_supply_pressure_pa < max_pressure_pa))
    fail("min_supply_pressure_pa", min_supply_pressure_pa, "in [min_pressure_pa, max_pressure_pa)");
  if (expected_legs < 0 || expected_legs > static_cast<int>(kNumLegs))
    fail("expected_legs", expected_legs, "in [0, 6]");
}

HardwareLifecycle::HardwareLifecycle(const HardwareLifecycleConfig& config) : config_(config) {
  config_.Validate();
}

ActivationRefusal HardwareLifecycle::Check(const HardwareLifecycleInput& in, int& leg,
                                           std::array<char, 160>& detail) const noexcept {
  leg = 0;
  detail[0] = '\0';
  if (!in.device_configured) {
    std::snprintf(detail.data(), detail.size(), "device not configured (or its link is lost)");
    return ActivationRefusal::kNotConfigured;
  }
  if (in.estop_loop_open || in.estop_latched) {
    std::snprintf(detail.data(), detail.size(), "e-stop open (%s): close the loop and reset first",
                  in.estop_loop_open ? "the loop input is open" : "the latch is set");
    return ActivationRefusal::kEstopOpen;
  }
  for (int i = 1; i <= config_.expected_legs; ++i) {
    if (in.leg_controller_live[static_cast<std::size_t>(i - 1)]) continue;
    leg = i;
    std::snprintf(detail.data(), detail.size(), "no live controller for leg %d", i);
    return ActivationRefusal::kNoLiveController;
  }
  const double half = 0.5 * config_.stroke_m + config_.length_margin_m;
  const double min_length_m = config_.mid_stroke_length_m - half;
  const double max_length_m = config_.mid_stroke_length_m + half;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegSensorReading& s = in.sensors[i];
    struct Reading {
      const char* name;
      double value, low, high;
    };
    const Reading readings[] = {
        {"length_m", s.length_m, min_length_m, max_length_m},
        {"cap_pressure_pa", s.chamber1_pressure_pa, config_.min_pressure_pa, config_.max_pressure_pa},
        {"rod_pressure_pa", s.chamber2_pressure_pa, config_.min_pressure_pa, config_.max_pressure_pa},
        {"supply_pressure_pa", s.supply_pressure_pa, config_.min_pressure_pa, config_.max_pressure_pa},
    };
    for (const Reading& r : readings) {
      if (std::isfinite(r.value) && r.value >= r.low && r.value <= r.high) continue;
      leg = static_cast<int>(i) + 1;
      std::snprintf(detail.data(), detail.size(), "sensor out of range: leg %d %s = %.6g outside [%.6g, %.6g]",
                    leg, r.name, r.value, r.low, r.high);
      return ActivationRefusal::kSensorOutOfRange;
    }
  }
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const double ps = in.sensors[i].supply_pressure_pa;
    if (ps >= config_.min_supply_pressure_pa) continue;
    leg = static_cast<int>(i) + 1;
    std::snprintf(detail.data(), detail.size(),
                  "supply pressure low: %.3f bar at leg %d, below the %.3f bar the legs need", ps * 1e-5,
                  leg, config_.min_supply_pressure_pa * 1e-5);
    return ActivationRefusal::kSupplyPressureLow;
  }
  return ActivationRefusal::kNone;
}

void HardwareLifecycle::Update(const HardwareLifecycleInput& in, HardwareLifecycleOutput& out) noexcept {
  const HardwareState before = state_;
  out.activation_asked = in.activate;
  out.refusal = ActivationRefusal::kNone;
  out.refusal_leg = 0;
  out.detail[0] = '\0';
  if (!in.device_configured) {
    state_ = HardwareState::kUnconfigured;
  } else if (state_ == HardwareState::kUnconfigured) {
    state_ = HardwareState::kInactive;
  }
  if (in.deactivate && state_ == HardwareState::kActive) state_ = HardwareState::kInactive;
  if (in.activate && state_ == HardwareState::kActive) {
    std::snprintf(out.detail.data(), out.detail.size(), "hardware already active");
  } else if (in.activate) {
    out.refusal = Check(in, out.refusal_leg, out.detail);
    if (out.refusal == ActivationRefusal::kNone && state_ == HardwareState::kInactive && !in.deactivate)
      state_ = HardwareState::kActive;
  }
  out.state = state_;
  out.apply_commands = state_ == HardwareState::kActive;
  out.changed = state_ != before;
  if (out.detail[0] == '\0') std::snprintf(out.detail.data(), out.detail.size(), "hardware %s", ToString(state_));
}

}  // namespace hexa
