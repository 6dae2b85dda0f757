#include "operator_input.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <nlohmann/json.hpp>

#include "hexa/services/operator_motion_checks.hpp"

namespace hexa::bridge {
namespace {
using nlohmann::json;

OperatorInputResult Refuse(std::string why) {
  OperatorInputResult r;
  r.error = std::move(why);
  return r;
}

// An array of N finite numbers at `key`; "" or what is wrong.
template <std::size_t N>
std::string ReadNumbers(const json& j, const char* key, double (&out)[N]) {
  const auto it = j.find(key);
  if (it == j.end()) return std::string("operator input: field '") + key + "' is absent";
  if (!it->is_array() || it->size() != N)
    return std::string("operator input: '") + key + "' must be an array of " + std::to_string(N) +
           " numbers";
  for (std::size_t k = 0; k < N; ++k) {
    const json& v = (*it)[k];
    if (!v.is_number()) return std::string("operator input: '") + key + "' must hold numbers only";
    out[k] = v.get<double>();
    if (!std::isfinite(out[k]))
      return std::string("operator input: '") + key + "' holds a value that is not finite";
  }
  return "";
}

// The frames' fields: pivot_m required, the tool's and work frame's optional (the identity).
std::string ReadFrames(const json& j, OperatorInput& in) {
  if (std::string e = ReadNumbers(j, "pivot_m", in.pivot_m); !e.empty()) return e;
  const auto optional = [&](const char* key, auto& out) {
    return j.contains(key) ? ReadNumbers(j, key, out) : std::string();
  };
  for (std::string e : {optional("tool_position_m", in.tool_position_m),
                        optional("tool_orientation_wxyz", in.tool_orientation_wxyz),
                        optional("work_position_m", in.work_position_m),
                        optional("work_orientation_wxyz", in.work_orientation_wxyz)})
    if (!e.empty()) return e;
  char why[160] = "";
  if (!wire::CheckFrames(in.pivot_m, in.tool_position_m, in.tool_orientation_wxyz,
                         in.work_position_m, in.work_orientation_wxyz, why, sizeof why))
    return std::string("operator input: ") + why;
  return "";
}

// The jog's, goal's or frames' fields, checked as the supervisor checks them.
std::string ReadMotion(const json& j, OperatorInput& in) {
  char why[160] = "";
  if (in.command == OperatorInput::Command::kFrames) return ReadFrames(j, in);
  if (in.command == OperatorInput::Command::kJog) {
    if (const auto f = j.find("frame"); f != j.end()) {
      if (!f->is_string() || (*f != "work" && *f != "tool"))
        return "operator input: 'frame' must be \"work\" or \"tool\"";
      in.tool_frame = *f == "tool";
    }
    if (std::string e = ReadNumbers(j, "velocity_m_s", in.velocity_m_s); !e.empty()) return e;
    if (std::string e = ReadNumbers(j, "angular_velocity_rad_s", in.angular_velocity_rad_s); !e.empty())
      return e;
    if (!wire::CheckJog(in.velocity_m_s, in.angular_velocity_rad_s, why, sizeof why))
      return std::string("operator input: ") + why;
    return "";
  }
  if (std::string e = ReadNumbers(j, "position_m", in.position_m); !e.empty()) return e;
  if (std::string e = ReadNumbers(j, "orientation_wxyz", in.orientation_wxyz); !e.empty()) return e;
  if (!wire::CheckGoal(in.position_m, in.orientation_wxyz, why, sizeof why))
    return std::string("operator input: ") + why;
  return "";
}

constexpr std::array<const char*, 7> kTrajectories = {"x", "y", "z", "roll", "pitch", "yaw",
                                                      "combined"};

// Every field a message may hold, and the one command it belongs to (null: any command).
struct Field {
  const char* name;
  const char* command;
};
constexpr std::array<Field, 12> kFields = {{{"command", nullptr},
                                            {"trajectory", "start"},
                                            {"frame", "jog"},
                                            {"velocity_m_s", "jog"},
                                            {"angular_velocity_rad_s", "jog"},
                                            {"position_m", "goal"},
                                            {"orientation_wxyz", "goal"},
                                            {"pivot_m", "frames"},
                                            {"tool_position_m", "frames"},
                                            {"tool_orientation_wxyz", "frames"},
                                            {"work_position_m", "frames"},
                                            {"work_orientation_wxyz", "frames"}}};
}  // namespace

const char* CommandName(OperatorInput::Command c) {
  switch (c) {
    case OperatorInput::Command::kStart: return "start";
    case OperatorInput::Command::kStop: return "stop";
    case OperatorInput::Command::kReset: return "reset";
    case OperatorInput::Command::kHome: return "home";
    case OperatorInput::Command::kJog: return "jog";
    case OperatorInput::Command::kGoal: return "goal";
    case OperatorInput::Command::kStream: return "stream";
    case OperatorInput::Command::kFrames: return "frames";
  }
  return "?";
}

OperatorInputResult ParseOperatorInput(std::string_view text) {
  // nlohmann rejects NaN / Infinity literals: such a message is not JSON.
  const json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Refuse("operator input is not valid JSON");
  if (!j.is_object()) return Refuse("operator input is not a JSON object");
  for (const auto& [key, value] : j.items()) {
    if (std::find_if(kFields.begin(), kFields.end(), [&](const Field& f) { return key == f.name; }) ==
        kFields.end())
      return Refuse("operator input: unknown field '" + key.substr(0, 40) +
                    "' (fields: command, trajectory, frame, velocity_m_s, angular_velocity_rad_s, "
                    "position_m, orientation_wxyz, pivot_m, tool_position_m, tool_orientation_wxyz, "
                    "work_position_m, work_orientation_wxyz)");
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
  else if (name == "jog") r.input.command = OperatorInput::Command::kJog;
  else if (name == "goal") r.input.command = OperatorInput::Command::kGoal;
  else if (name == "stream") r.input.command = OperatorInput::Command::kStream;
  else if (name == "frames") r.input.command = OperatorInput::Command::kFrames;
  else return Refuse("operator input: unknown command '" + name.substr(0, 40) +
                     "' (start stop reset home jog goal stream frames)");
  for (const Field& f : kFields) {
    if (f.command != nullptr && f.command != name && j.contains(f.name))
      return Refuse(std::string("operator input: '") + f.name + "' is for " + f.command + " only");
  }
  const OperatorInput::Command c = r.input.command;
  if (c == OperatorInput::Command::kJog || c == OperatorInput::Command::kGoal ||
      c == OperatorInput::Command::kFrames) {
    if (std::string e = ReadMotion(j, r.input); !e.empty()) return Refuse(e);
  }
  const auto traj = j.find("trajectory");
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
