// hexa_bridge as a node on the service runtime: serves a running session's DDS topics, and
// the 3-D scene, to Foxglove over the Foxglove WebSocket protocol (docs/foxglove.md). A topic
// is read from DDS only while some client subscribes to it (dds_sources.hpp); a slow client
// costs only its own drops (ws_server.hpp). Optionally forwards the operator's commands from
// Foxglove clients to the supervisor (operator_forward.hpp).
//
// Threads: the main thread owns the DDS readers and the scene (read -> convert -> hand to the
// server); the server's I/O thread owns the sockets; they meet in the server's queues.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "dds_sources.hpp"
#include "hexa/services/runtime.hpp"
#include "operator_forward.hpp"
#include "ws_server.hpp"

namespace hexa::bridge {

struct BridgeOptions {
  int domain_id = 0;
  std::optional<std::string> dds_config;  // --dds-config; else CYCLONEDDS_URI; else loopback
  std::string log_file;
  ServerConfig server;                   // listen address, port, queues, operator input
  std::vector<int> cpus;                 // empty: any CPU
  int nice = 10;
  double stats_s = 5.0;                  // 0: only when a client leaves
  std::string rig_path;
  std::string profile;
  std::optional<std::uint64_t> seed;
  double scene_hz = 50.0;
  bool loopback() const;                 // --listen is a loopback address
};

// hexa_bridge's command line into `options`: -1 to go on, else the exit code (0 --help,
// exit_code::kUsage with the message on stderr).
int ParseOptions(int argc, char** argv, BridgeOptions& options);

// The session key ($HEXA_SESSION_KEY, set by hexa_session) signs the operator commands the
// bridge forwards, or the supervisor refuses them (docs/faults.md). Before any participant
// exists. False, logged, on a bad key file.
bool InstallSessionKey(const BridgeOptions& options, spdlog::logger& log);

class BridgeNode {
 public:
  BridgeNode(const BridgeOptions& options, std::shared_ptr<spdlog::logger> log);
  int Run();

 private:
  std::vector<ChannelInfo> Channels() const;
  // Creates the readers of the channels some client watches, deletes the others'.
  void UpdateReaders();
  void LogStats();
  void LogServing();

  BridgeOptions options_;
  std::shared_ptr<spdlog::logger> log_;
  services::Runtime runtime_;
  recorder::SceneOptions scene_options_;
  recorder::SceneBuilder scene_;
  comm::GuardCondition demand_;         // set by the server when watched channels change
  comm::GuardCondition operator_wake_;  // set by the forwarder on each operator input
  comm::WaitSet waitset_;
  std::unique_ptr<OperatorForwarder> forwarder_;
  std::vector<std::unique_ptr<SourceBase>> sources_;
  std::unique_ptr<Server> server_;
  Context context_;
};

}  // namespace hexa::bridge
