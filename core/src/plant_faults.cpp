#include "hexa/core/plant_faults.hpp"

#include "hexa/core/param_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace hexa {
namespace {

constexpr std::pair<const char*, PlantFaultKind> kKinds[] = {
    {"pot-stuck", PlantFaultKind::kPotStuck},
    {"pot-drift", PlantFaultKind::kPotDrift},
    {"pressure-dead", PlantFaultKind::kPressureDead},
    {"imu-dropout", PlantFaultKind::kImuDropout},
    {"supply-loss", PlantFaultKind::kSupplyLoss},
};

constexpr const char* kUsage =
    "expected kind:leg:time_s with kind one of pot-stuck pot-drift pressure-dead (leg 1..6) or "
    "imu-dropout supply-loss (leg 0), time_s >= 0 and finite (e.g. pot-stuck:3:1.5)";

}  // namespace

const char* ToString(PlantFaultKind kind) {
  for (const auto& [name, k] : kKinds)
    if (k == kind) return name;
  return "?";
}

bool ParsePlantFaultKind(std::string_view text, PlantFaultKind& kind) {
  for (const auto& [name, k] : kKinds) {
    if (text == name) {
      kind = k;
      return true;
    }
  }
  return false;
}

bool PlantFaultHasLeg(PlantFaultKind kind) {
  return kind == PlantFaultKind::kPotStuck || kind == PlantFaultKind::kPotDrift ||
         kind == PlantFaultKind::kPressureDead;
}

std::string ParsePlantFault(std::string_view text, PlantFault& fault) {
  const std::size_t a = text.find(':');
  const std::size_t b = a == std::string_view::npos ? a : text.find(':', a + 1);
  if (b == std::string_view::npos) return std::string(kUsage);
  const std::string_view kind = text.substr(0, a);
  const std::string_view leg = text.substr(a + 1, b - a - 1);
  const std::string time(text.substr(b + 1));
  PlantFault f;
  if (!ParsePlantFaultKind(kind, f.kind)) return "unknown kind '" + std::string(kind) + "': " + kUsage;
  if (leg.size() != 1 || leg[0] < '0' || leg[0] > '6') return "leg '" + std::string(leg) + "': " + kUsage;
  f.leg = leg[0] - '0';
  if (PlantFaultHasLeg(f.kind) != (f.leg != 0))
    return std::string(ToString(f.kind)) + (f.leg == 0 ? " needs a leg 1..6" : " takes leg 0") +
           ": " + kUsage;
  char* end = nullptr;
  f.at_time_s = std::strtod(time.c_str(), &end);
  if (time.empty() || end == nullptr || *end != '\0' || !std::isfinite(f.at_time_s) || f.at_time_s < 0)
    return "time '" + time + "': " + kUsage;
  fault = f;
  return "";
}

std::string ParsePlantFaultList(std::string_view list, std::vector<PlantFault>& faults) {
  std::vector<PlantFault> parsed;
  for (std::size_t begin = 0; begin <= list.size();) {
    const std::size_t comma = std::min(list.find(',', begin), list.size());
    const std::string_view item = list.substr(begin, comma - begin);
    PlantFault f;
    const std::string error = ParsePlantFault(item, f);
    if (!error.empty()) {
      std::string message = "'";  // built in steps: GCC 12's -Wrestrict misfires on "'" + string
      message.append(item).append("': ").append(error);
      return message;
    }
    parsed.push_back(f);
    begin = comma + 1;
  }
  faults.insert(faults.end(), parsed.begin(), parsed.end());
  return "";
}

void PlantFaultParams::Validate() const {
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  CheckPlantFaultParams(c, *this);
  ThrowIfIssues(issues, "PlantFaultParams");
}

}  // namespace hexa
