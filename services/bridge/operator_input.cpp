#include "operator_input.hpp"

#include <algorithm>
#include <array>

#include <nlohmann/json.hpp>

namespace hexa::bridge {
namespace {
using nlohmann::json;

OperatorInputResult Refuse(std::string why) {
  OperatorInputResult r;
  r.error = std::move(why);
  return r;
}

constexpr std::array<const char*, 7> kTrajectories = {"x", "y", "z", "roll", "pitch", "yaw",
                                                      "combined"};
}  // namespace

const char* CommandName(OperatorInput::Command c) {
  switch (c) {
    case OperatorInput::Command::kStart: return "start";
    case OperatorInput::Command::kStop: return "stop";
    case OperatorInput::Command::kReset: return "reset";
    case OperatorInput::Command::kHome: return "home";
  }
  return "?";
}

OperatorInputResult ParseOperatorInput(std::string_view text) {
  // nlohmann rejects NaN / Infinity literals: such a message is not JSON.
  const json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Refuse("operator input is not valid JSON");
  if (!j.is_object()) return Refuse("operator input is not a JSON object");
  for (const auto& [key, value] : j.items()) {
    if (key != "command" && key != "trajectory")
      return Refuse("operator input: unknown field '" + key + "' (fields: command, trajectory)");
  }
  const auto cmd = j.find("command");
  if (cmd == j.end()) return Refuse("operator input: field 'command' is absent");
  if (!cmd->is_string()) return Refuse("operator input: 'command' must be a string");
  const std::string name = cmd->get<std::string>();
  OperatorInputResult r;
  if (name == "start") r.input.command = OperatorInput::Command::kStart;
  else if (name == "stop") r.input.command = OperatorInput::Command::kStop;
  else if (name == "reset") r.input.command = OperatorInput::Command::kReset;
  else if (name == "home") r.input.command = OperatorInput::Command::kHome;
  else return Refuse("operator input: unknown command '" + name.substr(0, 40) +
                     "' (start stop reset home)");
  const auto traj = j.find("trajectory");
  if (traj != j.end() && r.input.command != OperatorInput::Command::kStart)
    return Refuse("operator input: 'trajectory' is for start only");
  if (r.input.command == OperatorInput::Command::kStart) {
    r.input.trajectory = "combined";
    if (traj != j.end()) {
      if (!traj->is_string()) return Refuse("operator input: 'trajectory' must be a string");
      const std::string t = traj->get<std::string>();
      if (std::find(kTrajectories.begin(), kTrajectories.end(), t) == kTrajectories.end())
        return Refuse("operator input: trajectory '" + t.substr(0, 40) +
                      "' is not one of x y z roll pitch yaw combined");
      r.input.trajectory = t;
    }
  }
  r.ok = true;
  return r;
}

bool RateLimiter::Allow(int64_t now_ns) {
  if (started_) {
    const double dt_s = std::max<int64_t>(0, now_ns - last_ns_) * 1e-9;
    tokens_ = std::min(burst_, tokens_ + dt_s * rate_hz_);
  }
  started_ = true;
  last_ns_ = now_ns;
  if (tokens_ < 1.0) return false;
  tokens_ -= 1.0;
  return true;
}

}  // namespace hexa::bridge
