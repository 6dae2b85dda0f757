// Which Cyclone DDS configuration a process uses. Every binary calls EnsureDdsConfig()
// before creating a participant: without an explicit choice the loopback-only file
// deploy/cyclonedds-loopback.xml (HEXA_DEFAULT_CYCLONE_CONFIG, baked in at build time) is
// used, so no default can send a packet on eth0. A networked deployment passes its own file
// (--dds-config) or sets CYCLONEDDS_URI.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hexa::comm {

enum class DdsConfigSource { kOverride, kEnvironment, kDefault };

struct DdsConfigChoice {
  std::string uri;  // the value CYCLONEDDS_URI now has
  DdsConfigSource source = DdsConfigSource::kDefault;
};

// override_path set: CYCLONEDDS_URI := file://<override_path> (the file must exist).
// Else CYCLONEDDS_URI already set: kept. Else: file://HEXA_DEFAULT_CYCLONE_CONFIG.
// Logs the choice (spdlog, info). Throws std::invalid_argument for a missing file. Call it
// first thing in main(), before any thread exists (it calls setenv).
DdsConfigChoice EnsureDdsConfig(std::optional<std::string> override_path = std::nullopt);

// Appends to CYCLONEDDS_URI a fragment that gives Cyclone's thread `thread_name` ("tev",
// "recvUC", "gc", ...: Cyclone's Domain/Threads/Thread[@Name]) the scheduling class
// `sched_class` ("timeshare", "realtime" or "default") when the participant creates it.
// Call after EnsureDdsConfig(), before the participant, before any other thread exists.
void AppendCycloneThreadClass(const std::string& thread_name, const std::string& sched_class);

// The built-in default configuration file (absolute path).
std::string DefaultDdsConfigPath();

// Appends a Tracing fragment to CYCLONEDDS_URI so that Cyclone writes its configuration and
// its network interface choice ("selected interfaces: ...", "ownip: ...") to `log_path`.
// Call after EnsureDdsConfig(), before the participant. Used by tests and --dds-trace.
void AppendCycloneConfigTrace(const std::string& log_path);

// What a Cyclone log (verbosity "config" or more) says about the network it uses.
struct CycloneNetworkReport {
  bool found = false;                            // the log had the interface lines
  std::vector<std::string> selected_interfaces;  // e.g. {"lo"}
  std::vector<std::string> own_addresses;        // e.g. {"127.0.0.1"}
  std::vector<std::string> config_errors;        // "error:" / "warning:" lines
};
CycloneNetworkReport ParseCycloneNetworkLog(std::string_view log_text);

// True iff the report shows Cyclone on the loopback interface only: at least one interface,
// every selected interface is "lo", every own address is in 127.0.0.0/8 (or ::1), and no
// config error. `why` receives the reason when false.
bool IsLoopbackOnly(const CycloneNetworkReport& report, std::string* why = nullptr);

}  // namespace hexa::comm
