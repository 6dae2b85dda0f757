#include "ws_server.hpp"

#define ASIO_STANDALONE
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <algorithm>
#include <map>
#include <stdexcept>

namespace hexa::bridge {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;

void ServerConfig::Validate() const {
  if (client_queue_bytes < 1024)
    throw std::invalid_argument("client queue bytes = " + std::to_string(client_queue_bytes) +
                                " is below 1024");
  if (inbox_messages < 16)
    throw std::invalid_argument("inbox messages = " + std::to_string(inbox_messages) +
                                " is below 16");
}

struct Server::Impl {
  struct Client {
    ClientStats stats;
    std::map<uint32_t, uint32_t> subscription_channel;  // subscription id -> channel id
    std::map<uint32_t, uint32_t> channel_subscription;  // channel id -> subscription id
  };
  WsServer ws;
  mutable std::mutex clients_mutex;  // clients: written on the I/O thread, read by Stats()
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;
  uint64_t next_client_id = 1;
  std::string frame;  // scratch of Flush()
};

Server::Server(ServerConfig config, std::vector<ChannelInfo> channels,
               std::shared_ptr<spdlog::logger> log)
    : impl_(std::make_unique<Impl>()),
      config_(std::move(config)),
      channels_(std::move(channels)),
      log_(std::move(log)) {
  config_.Validate();
  uint32_t max_id = 0;
  for (const auto& c : channels_) max_id = std::max(max_id, c.id);
  for (uint32_t i = 0; i <= max_id; ++i) watchers_.push_back(std::make_unique<std::atomic<int>>(0));
}

Server::~Server() { Stop(); }

bool Server::Watched(uint32_t channel_id) const {
  return channel_id < watchers_.size() && watchers_[channel_id]->load() > 0;
}

std::vector<ClientStats> Server::Stats() const {
  std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  std::vector<ClientStats> out;
  for (const auto& [hdl, c] : impl_->clients) {
    out.push_back(c.stats);
  }
  return out;
}

void Server::Start() {
  WsServer& ws = impl_->ws;
  ws.clear_access_channels(websocketpp::log::alevel::all);
  ws.clear_error_channels(websocketpp::log::elevel::all);
  ws.set_error_channels(websocketpp::log::elevel::fatal);
  ws.init_asio();
  ws.set_reuse_addr(true);
  ws.set_max_message_size(config_.max_client_message_bytes);
  // Handshake: the client must offer the Foxglove subprotocol.
  ws.set_validate_handler([this](Hdl hdl) {
    auto con = impl_->ws.get_con_from_hdl(hdl);
    for (const auto& p : con->get_requested_subprotocols()) {
      if (p == kSubprotocol) {
        con->select_subprotocol(kSubprotocol);
        return true;
      }
    }
    log_->warn("refused a WebSocket handshake from {}: subprotocol {} not offered",
               con->get_remote_endpoint(), kSubprotocol);
    con->set_status(websocketpp::http::status_code::bad_request);
    return false;
  });
  ws.set_open_handler([this](Hdl hdl) {
    auto con = impl_->ws.get_con_from_hdl(hdl);
    asio::error_code nodelay_ec;  // small frames go out at once (best effort)
    con->get_socket().set_option(asio::ip::tcp::no_delay(true), nodelay_ec);
    Impl::Client c;
    {
      std::lock_guard<std::mutex> lock(impl_->clients_mutex);
      c.stats.id = impl_->next_client_id++;
      c.stats.remote = con->get_remote_endpoint();
      impl_->clients[hdl] = c;
    }
    log_->info("client {} connected from {}", c.stats.id, c.stats.remote);
    websocketpp::lib::error_code ec;
    impl_->ws.send(hdl, ServerInfoJson(config_.name, std::to_string(bound_port_)),
                   websocketpp::frame::opcode::text, ec);
    if (!ec)
      impl_->ws.send(hdl, AdvertiseJson(channels_), websocketpp::frame::opcode::text, ec);
  });
  auto closed = [this](Hdl hdl, const char* how) {
    Impl::Client c;
    bool demand_changed = false;
    {
      std::lock_guard<std::mutex> lock(impl_->clients_mutex);
      auto it = impl_->clients.find(hdl);
      if (it == impl_->clients.end()) return;
      c = std::move(it->second);
      impl_->clients.erase(it);
    }
    for (const auto& [channel, sub] : c.channel_subscription) {
      if (channel < watchers_.size() && watchers_[channel]->fetch_sub(1) == 1) demand_changed = true;
    }
    log_->info("client {} ({}) {}: sent {} messages ({} bytes), dropped {} (queue full)",
               c.stats.id, c.stats.remote, how, c.stats.sent, c.stats.sent_bytes,
               c.stats.dropped);
    if (demand_changed && on_demand_) on_demand_();
  };
  ws.set_close_handler([closed](Hdl hdl) { closed(hdl, "closed"); });
  ws.set_fail_handler([closed](Hdl hdl) { closed(hdl, "failed"); });
  ws.set_message_handler([this](Hdl hdl, WsServer::message_ptr msg) {
    auto protocol_error = [&](const std::string& why) {
      ++protocol_errors_;
      uint64_t id = 0;
      {
        std::lock_guard<std::mutex> lock(impl_->clients_mutex);
        auto it = impl_->clients.find(hdl);
        if (it != impl_->clients.end()) id = it->second.stats.id;
      }
      log_->warn("client {}: protocol error: {}; closing the connection", id, why);
      websocketpp::lib::error_code ec;
      impl_->ws.send(hdl, StatusJson(StatusLevel::kError, "protocol error: " + why),
                     websocketpp::frame::opcode::text, ec);
      impl_->ws.close(hdl, websocketpp::close::status::protocol_error,
                      why.substr(0, 120), ec);
    };
    if (msg->get_opcode() != websocketpp::frame::opcode::text) {
      protocol_error("binary messages from clients are not accepted (no clientPublish capability)");
      return;
    }
    const ClientRequest req = ParseClientText(msg->get_payload());
    if (req.kind == ClientRequest::Kind::kError) {
      protocol_error(req.error);
      return;
    }
    std::string warning;
    bool demand_changed = false;
    {
      std::lock_guard<std::mutex> lock(impl_->clients_mutex);
      auto it = impl_->clients.find(hdl);
      if (it == impl_->clients.end()) return;
      Impl::Client& c = it->second;
      if (req.kind == ClientRequest::Kind::kSubscribe) {
        for (const auto& [sub, channel] : req.subscriptions) {
          const bool known = std::any_of(channels_.begin(), channels_.end(),
                                         [&](const ChannelInfo& ch) { return ch.id == channel; });
          if (!known) {
            warning += "subscription " + std::to_string(sub) + ": no channel " +
                       std::to_string(channel) + "; ";
          } else if (c.subscription_channel.count(sub)) {
            warning += "subscription id " + std::to_string(sub) + " is already in use; ";
          } else if (c.channel_subscription.count(channel)) {
            warning += "channel " + std::to_string(channel) + " is already subscribed; ";
          } else {
            c.subscription_channel[sub] = channel;
            c.channel_subscription[channel] = sub;
            if (watchers_[channel]->fetch_add(1) == 0) demand_changed = true;
          }
        }
      } else {
        for (uint32_t sub : req.unsubscribe_ids) {
          auto s = c.subscription_channel.find(sub);
          if (s == c.subscription_channel.end()) {
            warning += "no subscription " + std::to_string(sub) + "; ";
            continue;
          }
          c.channel_subscription.erase(s->second);
          if (watchers_[s->second]->fetch_sub(1) == 1) demand_changed = true;
          c.subscription_channel.erase(s);
        }
      }
      c.stats.subscriptions = c.subscription_channel.size();
    }
    if (!warning.empty()) {
      websocketpp::lib::error_code ec;
      impl_->ws.send(hdl, StatusJson(StatusLevel::kWarning, warning),
                     websocketpp::frame::opcode::text, ec);
    }
    if (demand_changed && on_demand_) on_demand_();
  });

  websocketpp::lib::error_code ec;
  const asio::ip::address address = asio::ip::make_address(config_.listen_address, ec);
  if (ec)
    throw std::runtime_error("--listen: '" + config_.listen_address +
                             "' is not an IP address: " + ec.message());
  ws.listen(asio::ip::tcp::endpoint(address, config_.port), ec);
  if (ec)
    throw std::runtime_error("cannot listen on " + config_.listen_address + ":" +
                             std::to_string(config_.port) + ": " + ec.message());
  ws.start_accept(ec);
  if (ec) throw std::runtime_error("cannot accept connections: " + ec.message());
  asio::error_code aec;
  const auto local = ws.get_local_endpoint(aec);
  bound_port_ = aec ? config_.port : local.port();
  io_thread_ = std::thread([this] {
    try {
      impl_->ws.run();
    } catch (const std::exception& e) {
      log_->error("WebSocket I/O thread stopped: {}", e.what());
    }
  });
}

void Server::Stop() {
  if (!io_thread_.joinable()) return;
  asio::post(impl_->ws.get_io_service(), [this] {
    websocketpp::lib::error_code ec;
    impl_->ws.stop_listening(ec);
    std::vector<Hdl> all;
    {
      std::lock_guard<std::mutex> lock(impl_->clients_mutex);
      for (const auto& [hdl, c] : impl_->clients) all.push_back(hdl);
    }
    for (auto& hdl : all) impl_->ws.close(hdl, websocketpp::close::status::going_away, "bridge stops", ec);
    // A client that does not answer the close handshake (one that never reads) is cut here.
    auto timer = std::make_shared<asio::steady_timer>(impl_->ws.get_io_service(),
                                                      std::chrono::seconds(2));
    timer->async_wait([this, timer](const asio::error_code&) { impl_->ws.stop(); });
  });
  io_thread_.join();
}

void Server::Publish(uint32_t channel_id, uint64_t timestamp_ns, std::string payload) {
  bool post = false;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    if (inbox_.size() >= config_.inbox_messages) {
      ++inbox_drops_;
      return;
    }
    inbox_.push_back({channel_id, timestamp_ns, std::move(payload)});
    if (!flush_posted_) post = flush_posted_ = true;
  }
  if (post) asio::post(impl_->ws.get_io_service(), [this] { Flush(); });
}

void Server::Flush() {
  std::deque<Pending> batch;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    batch.swap(inbox_);
    flush_posted_ = false;
  }
  std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  for (auto& [hdl, c] : impl_->clients) {
    if (c.channel_subscription.empty()) continue;
    websocketpp::lib::error_code ec;
    WsServer::connection_ptr con = impl_->ws.get_con_from_hdl(hdl, ec);
    if (ec || con->get_state() != websocketpp::session::state::open) continue;
    for (const Pending& m : batch) {
      auto sub = c.channel_subscription.find(m.channel);
      if (sub == c.channel_subscription.end()) continue;
      const std::size_t size = 13 + m.payload.size();
      const std::size_t queued = con->get_buffered_amount();
      c.stats.queued_bytes = queued;
      if (queued + size > config_.client_queue_bytes) {
        ++c.stats.dropped;  // this client's queue is full: drop for this client only
        continue;
      }
      MessageDataFrame(sub->second, m.timestamp_ns, m.payload, impl_->frame);
      con->send(impl_->frame.data(), impl_->frame.size(), websocketpp::frame::opcode::binary);
      ++c.stats.sent;
      c.stats.sent_bytes += size;
    }
    c.stats.queued_bytes = con->get_buffered_amount();
  }
}

}  // namespace hexa::bridge
