#include "unit_file.hpp"

#include <cstdlib>
#include <fstream>

#include "generate.hpp"

namespace hexa::deploy {

std::string UnitFile::Get(const std::string& section_key) const {
  const auto it = keys.find(section_key);
  return it == keys.end() || it->second.empty() ? std::string() : it->second.back();
}

double ParseTimeSpan_s(const std::string& text) {
  if (text.empty()) return -1;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !(v >= 0)) return -1;
  const std::string unit(end);
  if (unit.empty() || unit == "s" || unit == "sec") return v;
  if (unit == "ms" || unit == "msec") return v * 1e-3;
  if (unit == "us" || unit == "usec") return v * 1e-6;
  if (unit == "min" || unit == "m") return v * 60;
  if (unit == "h") return v * 3600;
  return -1;
}

bool ParseUnitFile(const std::string& path, UnitFile& unit, std::string& error) {
  unit = UnitFile{};
  unit.path = path;
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open the unit file";
    return false;
  }
  std::string section;
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line[0] == '[') {
      const auto close = line.find(']');
      if (close == std::string::npos) {
        error = path + ":" + std::to_string(line_no) + ": malformed section header";
        return false;
      }
      section = line.substr(1, close - 1);
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos || section.empty()) {
      error = path + ":" + std::to_string(line_no) + ": expected Key=Value inside a section";
      return false;
    }
    const std::string key = line.substr(0, eq);
    const std::string value = line.substr(eq + 1);
    unit.keys[section + "." + key].push_back(value);
    if (section != "Service") continue;
    if (key == "Environment") {
      for (const std::string& word : SplitCommandLine(value)) {
        const auto e = word.find('=');
        if (e == std::string::npos) {
          error = path + ":" + std::to_string(line_no) + ": Environment word without '='";
          return false;
        }
        unit.environment.emplace_back(word.substr(0, e), word.substr(e + 1));
      }
    } else if (key == "ExecStartPre") {
      unit.exec_start_pre.push_back(SplitCommandLine(value));
    } else if (key == "ExecStart") {
      unit.exec_start = SplitCommandLine(value);
    } else if (key == "WatchdogSec") {
      unit.watchdog_s = ParseTimeSpan_s(value);
      if (unit.watchdog_s < 0) {
        error = path + ":" + std::to_string(line_no) + ": WatchdogSec '" + value + "' is not a time span";
        return false;
      }
    }
  }
  if (unit.exec_start.empty() && !unit.keys.count("Unit.Description")) {
    error = path + ": no ExecStart= and no [Unit]";
    return false;
  }
  return true;
}

}  // namespace hexa::deploy
