#include "hexa/recording/csv_columns.hpp"

#include <array>
#include <map>
#include <utility>

namespace hexa::recorder {
namespace gp = google::protobuf;
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Pose vectors [x y z roll pitch yaw] in m and rad (PoseReport).
bool IsPoseVector(const std::string& name) {
  return name == "desired_pose" || name == "estimated_pose" || name == "error_pose";
}

// Repeated fields of six values, one per leg (GroundTruth).
bool IsPerLeg(const gp::FieldDescriptor& f) {
  static const char* kPerLeg[] = {"leg_length_m",    "piston_velocity_m_s", "cap_pressure_pa",
                                  "rod_pressure_pa", "spool_position_m",    "applied_valve_v",
                                  "command_age_ticks"};
  if (!f.is_repeated()) return false;
  for (const char* n : kPerLeg)
    if (f.name() == n) return true;
  return false;
}

// Repeated fields of three values, a vector's x y z.
bool IsXyz(const std::string& name) {
  return name == "position_m" || name == "linear_velocity_m_s" || name == "angular_velocity_rad_s" ||
         name == "angular_rate_rad_s" || name == "p_BA_B_m" || name == "p_PB_P_m" ||
         name == "platform_inertia_diag_kg_m2" || name == "jog_velocity_m_s" ||
         name == "jog_angular_velocity_rad_s" || name == "goal_position_m" || name == "pivot_m" ||
         name == "tool_position_m" || name == "work_position_m";
}

// Suffixes of the SI naming rule (docs/style.md), longest first where one ends another.
const std::array<std::pair<const char*, const char*>, 17> kSuffixUnits = {{
    {"_m_s2", "m/s^2"}, {"_rad_s", "rad/s"}, {"_n_s_m", "N s/m"}, {"_kg_m2", "kg m^2"},
    {"_m_s", "m/s"},    {"_n_m", "N/m"},     {"_n_s", "N/s"},     {"_ns", "ns"},
    {"_hz", "Hz"},      {"_pa", "Pa"},       {"_kg", "kg"},       {"_rad", "rad"},
    {"_m", "m"},        {"_s", "s"},         {"_v", "V"},         {"_n", "N"},
    {"_ticks", "1"},
}};

// Doubles that are dimensionless by nature (no suffix).
bool IsDimensionlessDouble(const std::string& name) {
  static const char* kNames[] = {"friction_scale", "potentiometer_gain", "discharge_coefficient",
                                 "inflow", "outflow", "volume", "payload_scale"};
  for (const char* n : kNames)
    if (name == n) return true;
  return false;
}

}  // namespace

std::string ColumnUnit(const gp::FieldDescriptor& f, int index) {
  const std::string& name = f.name();
  switch (f.cpp_type()) {
    case gp::FieldDescriptor::CPPTYPE_STRING:
    case gp::FieldDescriptor::CPPTYPE_ENUM:
      return "-";
    case gp::FieldDescriptor::CPPTYPE_BOOL:
      return "1";
    default:
      break;
  }
  if (IsPoseVector(name)) return index >= 0 && index < 3 ? "m" : index < 6 ? "rad" : "?";
  if (EndsWith(name, "orientation_wxyz")) return "1";  // a unit quaternion
  for (const auto& [suffix, unit] : kSuffixUnits)
    if (EndsWith(name, suffix)) return unit;
  const bool integer = f.cpp_type() != gp::FieldDescriptor::CPPTYPE_DOUBLE &&
                       f.cpp_type() != gp::FieldDescriptor::CPPTYPE_FLOAT;
  // Integers without a unit suffix are counts, ids and tick numbers.
  if (integer || IsDimensionlessDouble(name)) return "1";
  return "?";
}

std::string ElementName(const gp::FieldDescriptor& f, int index) {
  static const char* kPose[] = {"x", "y", "z", "roll", "pitch", "yaw"};
  static const char* kWxyz[] = {"w", "x", "y", "z"};
  const std::string& name = f.name();
  if (IsPoseVector(name) && index < 6) return name + "." + kPose[index];
  if (EndsWith(name, "orientation_wxyz") && index < 4) return name + "." + kWxyz[index];
  if (IsXyz(name) && index < 3) return name + "." + kPose[index];
  if (IsPerLeg(f) && index < 6) return name + ".leg" + std::to_string(index + 1);
  return name + "[" + std::to_string(index) + "]";
}

std::string MessageDescription(const std::string& full_name) {
  static const std::map<std::string, std::string> kWhat = {
      {"hexa.rec.LegSensors", "plant -> leg controllers, 1 kHz per leg: measured leg length "
                              "(potentiometer) and chamber / supply pressures"},
      {"hexa.rec.ValveCommand", "leg controller -> plant, 1 kHz per leg: valve voltage (5 V = "
                                "closed), controller, status, desired length, sliding surface, "
                                "compute time, adapted friction scale"},
      {"hexa.rec.ImuSample", "plant -> supervisor, 200 Hz: platform orientation and angular rate"},
      {"hexa.rec.LegSetpoint", "supervisor -> leg controllers, 200 Hz per leg: desired length, "
                               "velocity, acceleration, outer-loop correction, feed-forward"},
      {"hexa.rec.TrackerPose", "external instrument (laser tracker) -> recorder, 100 Hz when on: "
                               "platform pose, for calibration"},
      {"hexa.rec.PoseReport", "supervisor -> recorder, 200 Hz: state, desired and estimated "
                              "(GQFK + IMU) pose [x y z roll pitch yaw], their difference"},
      {"hexa.rec.GroundTruth", "plant -> recorder only, 1 kHz: the simulated plant's true "
                               "state (pose, velocities, legs, pressures, spools, applied "
                               "voltages, command age)"},
      {"hexa.rec.OperatorCommand", "operator -> supervisor, event: start / stop / reset / home / "
                                   "shutdown / estop / jog / goal / stream / frames"},
      {"hexa.rec.NodeStatus", "every process, 10 Hz and on change: state, deadline misses, "
                              "cycle counts and times"},
      {"hexa.rec.FaultEvent", "every process, event: a detected fault, its leg, tick and reason"},
      {"hexa.rec.PlantTruth", "identification recordings: the simulated plant's true "
                              "parameters, for evaluation only"},
      {"hexa.rec.SessionInfo", "identification recordings: how the recording was made"},
  };
  const auto it = kWhat.find(full_name);
  return it == kWhat.end() ? "" : it->second;
}

}  // namespace hexa::recorder
