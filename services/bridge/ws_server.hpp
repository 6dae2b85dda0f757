// The WebSocket side of hexa_bridge (docs/foxglove.md): a websocketpp server on its own I/O
// thread that speaks the Foxglove protocol (protocol.hpp) to any number of clients.
//
// Back-pressure: Publish() (called by the DDS thread) only appends to a bounded inbox and
// wakes the I/O thread; it never touches a socket and never waits for a client. The I/O
// thread queues each message for every subscribed client whose queue has room, otherwise the
// message is dropped for that client only and counted. So a slow or stuck client costs the
// others nothing and the DDS side nothing.
//
// Memory: a client's queue is the server's own (a reference to the message shared by every
// client, not a copy), charged at what it really holds: frame bytes plus kQueuedMessageBytes
// per message for the allocations around it. websocketpp only ever holds one small hand-off
// per client (at most kHandOffBytes / kHandOffMessages waiting plus the same in the write in
// flight): its own queue is not counted by get_buffered_amount() once a write starts, so it
// must never be the queue. Every client's queue is capped at
// min(client_queue_bytes, total_queue_bytes / max_clients), and at most max_clients clients
// are served (more get HTTP 503), so the whole is bounded (docs/foxglove.md, "Cost").
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

#include "operator_input.hpp"
#include "protocol.hpp"

namespace hexa::bridge {

// Allocator and container bytes charged per queued message beyond its frame (13 + payload):
// the shared message (control block, timestamp, string header, malloc chunk headers) and its
// queue slot. Measured real cost is below it (docs/foxglove.md, "Cost").
inline constexpr std::size_t kQueuedMessageBytes = 160;
// What websocketpp holds per client at most twice (queued + in flight).
inline constexpr std::size_t kHandOffBytes = 32u << 10;
inline constexpr std::size_t kHandOffMessages = 64;

struct ServerConfig {
  std::string listen_address = "127.0.0.1";  // loopback by default (docs/foxglove.md)
  uint16_t port = 8765;                      // Foxglove's default; 0 = any free port
  std::size_t client_queue_bytes = 4u << 20;  // per client: charged bytes waiting for its socket
  std::size_t total_queue_bytes = 128u << 20;  // every client together
  std::size_t max_clients = 32;              // more connections are refused (HTTP 503)
  std::size_t inbox_messages = 65536;        // DDS thread -> I/O thread, all clients
  std::size_t inbox_bytes = 16u << 20;       // the same, charged like a client queue
  std::size_t max_client_message_bytes = 64u << 10;  // a larger client message is refused
  std::string name = "hexa_bridge";
  // Operator input (clientPublish on kOperatorInputTopic only); off unless enabled.
  bool operator_input = false;
  double operator_input_rate_hz = 10;  // per client, sustained
  double operator_input_burst = 10;    // per client, at once
  double operator_jog_rate_hz = 25;    // per client: jog messages (their own stream), sustained and at once
  void Validate() const;  // throws std::invalid_argument naming the field
  // What each client's queue may hold: min(client_queue_bytes, total_queue_bytes / max_clients).
  std::size_t EffectiveClientQueueBytes() const;
};

// Charged bytes of one queued message of `payload_bytes`.
inline std::size_t QueuedMessageCost(std::size_t payload_bytes) {
  return 13 + payload_bytes + kQueuedMessageBytes;
}

struct ClientStats {
  uint64_t id = 0;
  std::string remote;
  std::size_t subscriptions = 0;
  uint64_t sent = 0;          // messages handed to the socket
  uint64_t dropped = 0;       // messages not sent because the client's queue was full
  uint64_t sent_bytes = 0;
  std::size_t queued_messages = 0;  // in the server's queue now
  std::size_t queued_bytes = 0;     // their charged bytes (QueuedMessageCost)
  std::size_t queued_peak_bytes = 0;
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
  // Called on the I/O thread with each operator input that passed every check; returns what
  // the client is told (an empty string: refused, the reason was logged). Must not block.
  using OperatorInputHandler =
      std::function<std::string(uint64_t client_id, const std::string& remote, const OperatorInput&)>;
  void OnOperatorInput(OperatorInputHandler fn) { on_operator_input_ = std::move(fn); }
  uint64_t operator_inputs_refused() const { return operator_inputs_refused_.load(); }

  std::vector<ClientStats> Stats() const;  // any thread
  uint64_t inbox_drops() const { return inbox_drops_.load(); }
  uint64_t protocol_errors() const { return protocol_errors_.load(); }
  uint64_t refused_connections() const { return refused_connections_.load(); }
  std::size_t client_count() const;  // any thread
  // Charged bytes of every client queue together, now and at most so far (any thread).
  std::size_t queued_bytes() const { return queued_bytes_.load(); }
  std::size_t queued_peak_bytes() const { return queued_peak_bytes_.load(); }

 private:
  struct Impl;
  struct Pending {
    uint32_t channel;
    uint64_t timestamp_ns;
    std::string payload;
  };
  void Flush();
  void Pump();  // hands each client's queue to its socket, a little at a time
  void ScheduleTick();
  void ReturnFreedMemory();
  // I/O thread: a client's binary message (operator input) and a status to one client that is
  // dropped when the client does not read (its socket holds 64 KiB already).
  bool OnHandshake(const std::weak_ptr<void>& hdl);
  void OnOpen(const std::weak_ptr<void>& hdl);
  void OnClosed(const std::weak_ptr<void>& hdl, const char* how);
  void OnMessage(const std::weak_ptr<void>& hdl, const std::string& payload, bool text);
  void ProtocolError(const std::weak_ptr<void>& hdl, const std::string& why);
  void OnSubscriptionRequest(const std::weak_ptr<void>& hdl, const ClientRequest& req);
  void OnClientBinary(const std::weak_ptr<void>& hdl, const std::string& frame);
  void OnClientChannels(const std::weak_ptr<void>& hdl, const ClientRequest& req);
  void SendStatus(const std::weak_ptr<void>& hdl, StatusLevel level, const std::string& message);
  void ReportRateRefusals(const std::weak_ptr<void>& hdl, uint64_t id, const std::string& remote,
                          uint64_t count);
  void ReportPendingRateRefusals();
  std::unique_ptr<Impl> impl_;
  ServerConfig config_;
  std::vector<ChannelInfo> channels_;
  std::shared_ptr<spdlog::logger> log_;
  std::vector<std::unique_ptr<std::atomic<int>>> watchers_;  // by channel id
  std::function<void()> on_demand_;
  OperatorInputHandler on_operator_input_;
  std::atomic<uint64_t> operator_inputs_refused_{0};
  std::mutex inbox_mutex_;
  std::deque<std::shared_ptr<const Pending>> inbox_;
  std::size_t inbox_charge_ = 0;
  bool flush_posted_ = false;
  std::atomic<uint64_t> inbox_drops_{0};
  std::atomic<uint64_t> protocol_errors_{0};
  std::atomic<uint64_t> refused_connections_{0};
  std::atomic<std::size_t> queued_bytes_{0};
  std::atomic<std::size_t> queued_peak_bytes_{0};
  uint16_t bound_port_ = 0;
  std::thread io_thread_;
};

}  // namespace hexa::bridge
