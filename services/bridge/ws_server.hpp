// The WebSocket side of hexa_bridge (docs/foxglove.md): a websocketpp server on its own I/O
// thread that speaks the Foxglove protocol (protocol.hpp) to any number of clients.
//
// Back-pressure: Publish() (called by the DDS thread) only appends to a bounded inbox and
// wakes the I/O thread; it never touches a socket and never waits for a client. The I/O
// thread hands each message to every subscribed client whose bytes not yet written to its
// socket stay under client_queue_bytes; otherwise the message is dropped for that client only
// and counted. So a slow or stuck client costs the others nothing and the DDS side nothing.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/logger.h>

#include "protocol.hpp"

namespace hexa::bridge {

struct ServerConfig {
  std::string listen_address = "127.0.0.1";  // loopback by default (docs/foxglove.md)
  uint16_t port = 8765;                      // Foxglove's default; 0 = any free port
  std::size_t client_queue_bytes = 4u << 20;  // per client: bytes waiting for its socket
  std::size_t inbox_messages = 65536;        // DDS thread -> I/O thread, all clients
  std::size_t max_client_message_bytes = 64u << 10;  // a larger client message is refused
  std::string name = "hexa_bridge";
  void Validate() const;  // throws std::invalid_argument naming the field
};

struct ClientStats {
  uint64_t id = 0;
  std::string remote;
  std::size_t subscriptions = 0;
  uint64_t sent = 0;          // messages handed to the socket
  uint64_t dropped = 0;       // messages not sent because the client's queue was full
  uint64_t sent_bytes = 0;
  std::size_t queued_bytes = 0;  // bytes waiting for the socket now
};

class Server {
 public:
  Server(ServerConfig config, std::vector<ChannelInfo> channels,
         std::shared_ptr<spdlog::logger> log);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and starts the I/O thread. Throws std::runtime_error naming the address.
  void Start();
  void Stop();  // closes every client, joins the I/O thread
  uint16_t port() const { return bound_port_; }

  // Any thread: queue one message of `channel_id` for its subscribers. Never blocks on a
  // client; when the inbox is full the message is dropped and counted (inbox_drops()).
  void Publish(uint32_t channel_id, uint64_t timestamp_ns, std::string payload);
  // Any thread: whether any client subscribes to the channel now.
  bool Watched(uint32_t channel_id) const;
  // Called on the I/O thread whenever the set of watched channels changes.
  void OnDemandChange(std::function<void()> fn) { on_demand_ = std::move(fn); }

  std::vector<ClientStats> Stats() const;  // any thread
  uint64_t inbox_drops() const { return inbox_drops_.load(); }
  uint64_t protocol_errors() const { return protocol_errors_.load(); }

 private:
  struct Impl;
  void Flush();
  std::unique_ptr<Impl> impl_;
  ServerConfig config_;
  std::vector<ChannelInfo> channels_;
  std::shared_ptr<spdlog::logger> log_;
  std::vector<std::unique_ptr<std::atomic<int>>> watchers_;  // by channel id
  std::function<void()> on_demand_;
  struct Pending {
    uint32_t channel;
    uint64_t timestamp_ns;
    std::string payload;
  };
  std::mutex inbox_mutex_;
  std::deque<Pending> inbox_;
  bool flush_posted_ = false;
  std::atomic<uint64_t> inbox_drops_{0};
  std::atomic<uint64_t> protocol_errors_{0};
  uint16_t bound_port_ = 0;
  std::thread io_thread_;
};

}  // namespace hexa::bridge
