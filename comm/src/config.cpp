#include "hexa/comm/config.hpp"

#include <spdlog/spdlog.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#ifndef HEXA_DEFAULT_CYCLONE_CONFIG
#error "HEXA_DEFAULT_CYCLONE_CONFIG must be defined by comm/CMakeLists.txt"
#endif

namespace hexa::comm {
namespace {

std::string FileUri(const std::string& path) {
  return "file://" + std::filesystem::absolute(path).string();
}

void RequireFile(const std::string& path, const char* what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw std::invalid_argument(std::string(what) + " '" + path +
                                "' does not exist or is not a file");
  }
}

std::string Trim(std::string_view s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) return {};
  const auto end = s.find_last_not_of(" \t\r");
  return std::string(s.substr(begin, end - begin + 1));
}

bool IsLoopbackAddress(const std::string& address) {
  return address.rfind("127.", 0) == 0 || address == "::1" || address == "[::1]";
}

}  // namespace

std::string DefaultDdsConfigPath() { return HEXA_DEFAULT_CYCLONE_CONFIG; }

DdsConfigChoice EnsureDdsConfig(std::optional<std::string> override_path) {
  DdsConfigChoice choice;
  if (override_path.has_value()) {
    RequireFile(*override_path, "DDS config override");
    choice.uri = FileUri(*override_path);
    choice.source = DdsConfigSource::kOverride;
    setenv("CYCLONEDDS_URI", choice.uri.c_str(), 1);
    spdlog::info("DDS config: {} (override)", choice.uri);
    return choice;
  }
  if (const char* env = std::getenv("CYCLONEDDS_URI"); env != nullptr && env[0] != '\0') {
    choice.uri = env;
    choice.source = DdsConfigSource::kEnvironment;
    spdlog::info("DDS config: {} (from CYCLONEDDS_URI)", choice.uri);
    return choice;
  }
  RequireFile(DefaultDdsConfigPath(), "default DDS config (HEXA_DEFAULT_CYCLONE_CONFIG)");
  choice.uri = FileUri(DefaultDdsConfigPath());
  choice.source = DdsConfigSource::kDefault;
  setenv("CYCLONEDDS_URI", choice.uri.c_str(), 1);
  spdlog::info("DDS config: {} (built-in loopback default)", choice.uri);
  return choice;
}

namespace {

// Cyclone merges comma-separated sources in order; a fragment without <CycloneDDS> or
// <Domain> applies to every domain.
void AppendCycloneConfigFragment(const std::string& fragment) {
  const char* env = std::getenv("CYCLONEDDS_URI");
  std::string uri = env != nullptr ? env : "";
  if (!uri.empty()) uri += ",";
  uri += fragment;
  setenv("CYCLONEDDS_URI", uri.c_str(), 1);
}

}  // namespace

void AppendCycloneConfigTrace(const std::string& log_path) {
  AppendCycloneConfigFragment("<Tracing><Verbosity>config</Verbosity><OutputFile>" + log_path +
                              "</OutputFile></Tracing>");
}

void AppendCycloneThreadClass(const std::string& thread_name, const std::string& sched_class) {
  AppendCycloneConfigFragment("<Threads><Thread Name=\"" + thread_name +
                              "\"><Scheduling><Class>" + sched_class +
                              "</Class></Scheduling></Thread></Threads>");
}

CycloneNetworkReport ParseCycloneNetworkLog(std::string_view log_text) {
  // Lines of interest (Cyclone 0.10.2, verbosity config):
  //   "... assuming multicast capable interface lo.selected interfaces: lo (index 1 priority 2)"
  //   "... ownip: udp/127.0.0.1"
  CycloneNetworkReport report;
  std::size_t pos = 0;
  while (pos < log_text.size()) {
    std::size_t eol = log_text.find('\n', pos);
    if (eol == std::string_view::npos) eol = log_text.size();
    const std::string_view line = log_text.substr(pos, eol - pos);
    pos = eol + 1;
    if (const auto at = line.find("selected interfaces: "); at != std::string_view::npos) {
      report.found = true;
      // "lo (index 1 priority 2), eth0 (index 2 priority 0)"
      std::string rest(line.substr(at + std::string_view("selected interfaces: ").size()));
      std::stringstream items(rest);
      std::string item;
      while (std::getline(items, item, ',')) {
        item = Trim(item);
        const auto paren = item.find(" (");
        const std::string name = Trim(item.substr(0, paren));
        if (!name.empty()) report.selected_interfaces.push_back(name);
      }
    }
    if (const auto at = line.find("ownip: "); at != std::string_view::npos) {
      std::string rest = Trim(line.substr(at + std::string_view("ownip: ").size()));
      if (const auto slash = rest.find('/'); slash != std::string::npos) rest = rest.substr(slash + 1);
      if (const auto colon = rest.rfind(':'); colon != std::string::npos && rest.find('.') != std::string::npos) {
        rest = rest.substr(0, colon);  // "127.0.0.1:7410" -> "127.0.0.1"
      }
      report.own_addresses.push_back(rest);
    }
    if (line.find(": error:") != std::string_view::npos ||
        line.find("config: invalid") != std::string_view::npos ||
        line.find("warning:") != std::string_view::npos) {
      report.config_errors.emplace_back(Trim(line));
    }
  }
  return report;
}

bool IsLoopbackOnly(const CycloneNetworkReport& report, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!report.found || report.selected_interfaces.empty()) {
    return fail("no 'selected interfaces' line in the Cyclone log");
  }
  for (const std::string& name : report.selected_interfaces) {
    if (name != "lo") return fail("Cyclone selected interface '" + name + "'");
  }
  if (report.own_addresses.empty()) return fail("no 'ownip' line in the Cyclone log");
  for (const std::string& address : report.own_addresses) {
    if (!IsLoopbackAddress(address)) return fail("Cyclone own address " + address + " is not loopback");
  }
  if (!report.config_errors.empty()) return fail("Cyclone config problem: " + report.config_errors.front());
  return true;
}

}  // namespace hexa::comm
