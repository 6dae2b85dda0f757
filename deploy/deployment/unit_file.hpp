// Reading back the systemd units hexa_deploy writes: what the multi-host test needs to start
// every process exactly as its unit would (environment, ExecStartPre, ExecStart, watchdog).
// Not a systemd replacement: only the keys the generator writes, with systemd's quoting.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace hexa::deploy {

struct UnitFile {
  std::string path;
  // "Service.Type" -> values in file order (a key may repeat, e.g. Environment).
  std::map<std::string, std::vector<std::string>> keys;
  std::vector<std::pair<std::string, std::string>> environment;  // Environment=K=V
  std::vector<std::vector<std::string>> exec_start_pre;
  std::vector<std::string> exec_start;
  double watchdog_s = 0.0;  // WatchdogSec (0 = none)

  // The last value of "Section.Key", or "" when absent.
  std::string Get(const std::string& section_key) const;
};

// Parses a unit file; false + error naming the file and line on a malformed line.
bool ParseUnitFile(const std::string& path, UnitFile& unit, std::string& error);

// systemd time span: "1s", "500ms", "2min", "1.5s", "30" (seconds); -1 when malformed.
double ParseTimeSpan_s(const std::string& text);

}  // namespace hexa::deploy
