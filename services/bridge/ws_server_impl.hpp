// hexa_bridge's WebSocket server, inside (not installed): the state its I/O thread owns
// (websocketpp's server, the clients with their queues, subscriptions and operator input
// channels), shared by the files that implement Server: ws_server.cpp (connections,
// subscriptions, queues) and ws_client_input.cpp (what clients publish).
#pragma once

#define ASIO_STANDALONE
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <chrono>
#include <map>

#include "ws_server.hpp"

namespace hexa::bridge {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;

// Steady clock, for the clients' rates and reports.
inline int64_t SteadyNow_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Server::Impl {
  struct Queued {
    std::shared_ptr<const Pending> message;  // shared by every client that queues it
    uint32_t subscription;
  };
  struct Client {
    ClientStats stats;
    std::map<uint32_t, uint32_t> subscription_channel;  // subscription id -> channel id
    std::map<uint32_t, uint32_t> channel_subscription;  // channel id -> subscription id
    std::deque<Queued> queue;
    std::map<uint32_t, ClientChannel> advertised;  // the client's operator input channels
    RateLimiter operator_limiter{10, 10};
    RateLimiter jog_limiter{25, 25};      // jog messages: a stream, limited on their own
    uint64_t rate_refused = 0;            // operator inputs over the rate, not yet reported
    int64_t rate_reported_ns = -(int64_t{1} << 62);  // last status about them
  };
  WsServer ws;
  mutable std::mutex clients_mutex;  // clients: written on the I/O thread, read by Stats()
  // Every connection past its handshake's validation (counted against max_clients).
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;
  uint64_t next_client_id = 1;
  std::string frame;  // scratch of Pump()
  std::unique_ptr<asio::steady_timer> tick;
  bool trim_due = false;  // a client left: give its memory back to the system
  std::chrono::steady_clock::time_point last_trim{}, last_departure{};
};

}  // namespace hexa::bridge
