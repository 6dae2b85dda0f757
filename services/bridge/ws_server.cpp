#include "ws_server.hpp"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "ws_server_impl.hpp"

namespace hexa::bridge {

void ServerConfig::Validate() const {
  if (client_queue_bytes < 1024)
    throw std::invalid_argument("client queue bytes = " + std::to_string(client_queue_bytes) +
                                " is below 1024");
  if (inbox_messages < 16)
    throw std::invalid_argument("inbox messages = " + std::to_string(inbox_messages) +
                                " is below 16");
  if (max_clients < 1 || max_clients > 4096)
    throw std::invalid_argument("max clients = " + std::to_string(max_clients) +
                                " is outside [1, 4096]");
  if (total_queue_bytes / max_clients < 64u << 10)
    throw std::invalid_argument(
        "total queue bytes = " + std::to_string(total_queue_bytes) + " leaves " +
        std::to_string(total_queue_bytes / max_clients) + " bytes to each of " +
        std::to_string(max_clients) + " clients, below 65536");
  if (inbox_bytes < 64u << 10)
    throw std::invalid_argument("inbox bytes = " + std::to_string(inbox_bytes) +
                                " is below 65536");
}

std::size_t ServerConfig::EffectiveClientQueueBytes() const {
  return std::min(client_queue_bytes, total_queue_bytes / std::max<std::size_t>(max_clients, 1));
}

namespace {
// The process's resident set (/proc/self/statm), 0 if unreadable.
std::size_t ResidentBytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0;
  unsigned long pages = 0, resident = 0;
  const int n = std::fscanf(f, "%lu %lu", &pages, &resident);
  std::fclose(f);
  return n == 2 ? resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE)) : 0;
}
}  // namespace

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
  out.reserve(impl_->clients.size());
  for (const auto& [hdl, c] : impl_->clients) {
    out.push_back(c.stats);
  }
  return out;
}

std::size_t Server::client_count() const {
  std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  return impl_->clients.size();
}

void Server::Start() {
  WsServer& ws = impl_->ws;
  ws.clear_access_channels(websocketpp::log::alevel::all);
  ws.clear_error_channels(websocketpp::log::elevel::all);
  ws.set_error_channels(websocketpp::log::elevel::fatal);
  ws.init_asio();
  ws.set_reuse_addr(true);
  ws.set_max_message_size(config_.max_client_message_bytes);
  ws.set_validate_handler([this](Hdl hdl) { return OnHandshake(hdl); });
  ws.set_open_handler([this](Hdl hdl) { OnOpen(hdl); });
  ws.set_close_handler([this](Hdl hdl) { OnClosed(hdl, "closed"); });
  ws.set_fail_handler([this](Hdl hdl) { OnClosed(hdl, "failed"); });
  ws.set_message_handler([this](Hdl hdl, WsServer::message_ptr msg) {
    OnMessage(hdl, msg->get_payload(), msg->get_opcode() == websocketpp::frame::opcode::text);
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
  impl_->tick = std::make_unique<asio::steady_timer>(ws.get_io_service());
  impl_->last_trim = std::chrono::steady_clock::now();
  ScheduleTick();
  io_thread_ = std::thread([this] {
    try {
      impl_->ws.run();
    } catch (const std::exception& e) {
      log_->error("WebSocket I/O thread stopped: {}", e.what());
    }
  });
}

// Handshake: the client must offer the Foxglove subprotocol, and there must be room.
bool Server::OnHandshake(const std::weak_ptr<void>& hdl) {
  auto con = impl_->ws.get_con_from_hdl(hdl);
  const auto& offered = con->get_requested_subprotocols();
  if (std::find(offered.begin(), offered.end(), kSubprotocol) == offered.end()) {
    log_->warn("refused a WebSocket handshake from {}: subprotocol {} not offered",
               con->get_remote_endpoint(), kSubprotocol);
    con->set_status(websocketpp::http::status_code::bad_request);
    return false;
  }
  std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  if (impl_->clients.size() >= config_.max_clients) {
    const uint64_t n = ++refused_connections_;
    // Every refusal is answered; the log says so for the first ten and then every 100th.
    if (n <= 10 || n % 100 == 0)
      log_->warn("refused a connection from {}: {} clients connected, the limit "
                 "(--max-clients); {} refused so far", con->get_remote_endpoint(),
                 impl_->clients.size(), n);
    con->set_status(websocketpp::http::status_code::service_unavailable);
    con->set_body("hexa_bridge: too many clients (limit " +
                  std::to_string(config_.max_clients) + ")\n");
    return false;
  }
  con->select_subprotocol(kSubprotocol);
  Impl::Client& c = impl_->clients[hdl];
  c.operator_limiter = RateLimiter(config_.operator_input_rate_hz, config_.operator_input_burst);
  c.jog_limiter = RateLimiter(config_.operator_jog_rate_hz, config_.operator_jog_rate_hz);
  c.stats.id = impl_->next_client_id++;
  c.stats.remote = con->get_remote_endpoint();
  return true;
}

void Server::OnOpen(const std::weak_ptr<void>& hdl) {
  auto con = impl_->ws.get_con_from_hdl(hdl);
  asio::error_code nodelay_ec;  // small frames go out at once (best effort)
  con->get_socket().set_option(asio::ip::tcp::no_delay(true), nodelay_ec);
  ClientStats c;
  std::size_t connected = 0;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    auto it = impl_->clients.find(hdl);
    if (it == impl_->clients.end()) return;
    c = it->second.stats;
    connected = impl_->clients.size();
  }
  log_->info("client {} connected from {} ({} of at most {})", c.id, c.remote, connected,
             config_.max_clients);
  websocketpp::lib::error_code ec;
  impl_->ws.send(hdl, ServerInfoJson(config_.name, std::to_string(bound_port_), config_.operator_input),
                 websocketpp::frame::opcode::text, ec);
  if (!ec)
    impl_->ws.send(hdl, AdvertiseJson(channels_), websocketpp::frame::opcode::text, ec);
}

void Server::OnClosed(const std::weak_ptr<void>& hdl, const char* how) {
  Impl::Client c;
  bool demand_changed = false;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    auto it = impl_->clients.find(hdl);
    if (it == impl_->clients.end()) return;
    c = std::move(it->second);
    impl_->clients.erase(it);
    queued_bytes_ -= c.stats.queued_bytes;
    impl_->trim_due = true;
    impl_->last_departure = std::chrono::steady_clock::now();
  }
  c.queue = {};
  for (const auto& [channel, sub] : c.channel_subscription) {
    if (channel < watchers_.size() && watchers_[channel]->fetch_sub(1) == 1) demand_changed = true;
  }
  log_->info("client {} ({}) {}: sent {} messages ({} bytes), dropped {} (queue full), "
             "queue peak {} bytes", c.stats.id, c.stats.remote, how, c.stats.sent,
             c.stats.sent_bytes, c.stats.dropped, c.stats.queued_peak_bytes);
  if (demand_changed && on_demand_) on_demand_();
}

// A message the protocol does not allow: counted, answered with an error status, and the
// connection closed.
void Server::ProtocolError(const std::weak_ptr<void>& hdl, const std::string& why) {
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
}

void Server::OnMessage(const std::weak_ptr<void>& hdl, const std::string& payload, bool text) {
  if (!text) {
    if (!config_.operator_input) {
      ProtocolError(hdl, "binary messages from clients are not accepted (no clientPublish capability)");
      return;
    }
    const ClientMessageData data = ParseClientBinary(payload);
    if (!data.ok) {
      ProtocolError(hdl, data.error);
      return;
    }
    OnClientBinary(hdl, payload);
    return;
  }
  const ClientRequest req = ParseClientText(payload, config_.operator_input);
  if (req.kind == ClientRequest::Kind::kError) {
    ProtocolError(hdl, req.error);
    return;
  }
  if (req.kind == ClientRequest::Kind::kAdvertise || req.kind == ClientRequest::Kind::kUnadvertise) {
    OnClientChannels(hdl, req);
    return;
  }
  OnSubscriptionRequest(hdl, req);
}

// subscribe / unsubscribe: the client's subscriptions and the channels' demand.
void Server::OnSubscriptionRequest(const std::weak_ptr<void>& hdl, const ClientRequest& req) {
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
    impl_->tick->cancel();
    auto timer = std::make_shared<asio::steady_timer>(impl_->ws.get_io_service(),
                                                      std::chrono::seconds(2));
    timer->async_wait([this, timer](const asio::error_code&) { impl_->ws.stop(); });
  });
  io_thread_.join();
}

void Server::SendStatus(const std::weak_ptr<void>& hdl, StatusLevel level,
                        const std::string& message) {
  websocketpp::lib::error_code ec;
  WsServer::connection_ptr con = impl_->ws.get_con_from_hdl(hdl, ec);
  if (ec || con->get_state() != websocketpp::session::state::open) return;
  if (con->get_buffered_amount() > (64u << 10)) return;  // a client that does not read
  con->send(StatusJson(level, message), websocketpp::frame::opcode::text);
}


void Server::Publish(uint32_t channel_id, uint64_t timestamp_ns, std::string payload) {
  const std::size_t cost = QueuedMessageCost(payload.size());
  bool post = false;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    if (inbox_.size() >= config_.inbox_messages || inbox_charge_ + cost > config_.inbox_bytes) {
      ++inbox_drops_;
      return;
    }
    inbox_.push_back(std::make_shared<const Pending>(
        Pending{channel_id, timestamp_ns, std::move(payload)}));
    inbox_charge_ += cost;
    if (!flush_posted_) post = flush_posted_ = true;
  }
  if (post) asio::post(impl_->ws.get_io_service(), [this] { Flush(); });
}

// I/O thread: the inbox into each subscribed client's queue, within its cap.
void Server::Flush() {
  std::deque<std::shared_ptr<const Pending>> batch;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    batch.swap(inbox_);
    inbox_charge_ = 0;
    flush_posted_ = false;
  }
  const std::size_t cap = config_.EffectiveClientQueueBytes();
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    std::size_t added = 0;
    for (auto& [hdl, c] : impl_->clients) {
      if (c.channel_subscription.empty()) continue;
      for (const auto& m : batch) {
        auto sub = c.channel_subscription.find(m->channel);
        if (sub == c.channel_subscription.end()) continue;
        const std::size_t cost = QueuedMessageCost(m->payload.size());
        if (c.stats.queued_bytes + cost > cap) {
          ++c.stats.dropped;  // this client's queue is full: drop for this client only
          continue;
        }
        c.queue.push_back({m, sub->second});
        c.stats.queued_bytes += cost;
        added += cost;
      }
      c.stats.queued_messages = c.queue.size();
      c.stats.queued_peak_bytes = std::max(c.stats.queued_peak_bytes, c.stats.queued_bytes);
    }
    const std::size_t total = queued_bytes_ += added;
    if (total > queued_peak_bytes_.load()) queued_peak_bytes_ = total;
  }
  batch = {};  // messages no client queued are freed here
  Pump();
}

// I/O thread: a client whose socket has taken everything handed to it so far (websocketpp's
// queue empty; one write may be in flight) gets the next hand-off from its queue.
void Server::Pump() {
  std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  std::size_t sent_charge = 0;
  for (auto& [hdl, c] : impl_->clients) {
    if (c.queue.empty()) continue;
    websocketpp::lib::error_code ec;
    WsServer::connection_ptr con = impl_->ws.get_con_from_hdl(hdl, ec);
    if (ec || con->get_state() != websocketpp::session::state::open) continue;
    if (con->get_buffered_amount() > 0) continue;
    std::size_t bytes = 0, count = 0;
    while (!c.queue.empty() && count < kHandOffMessages && bytes < kHandOffBytes) {
      const Impl::Queued& q = c.queue.front();
      MessageDataFrame(q.subscription, q.message->timestamp_ns, q.message->payload, impl_->frame);
      con->send(impl_->frame.data(), impl_->frame.size(), websocketpp::frame::opcode::binary);
      const std::size_t cost = QueuedMessageCost(q.message->payload.size());
      c.stats.queued_bytes -= cost;
      sent_charge += cost;
      bytes += impl_->frame.size();
      ++count;
      ++c.stats.sent;
      c.stats.sent_bytes += impl_->frame.size();
      c.queue.pop_front();
    }
    c.stats.queued_messages = c.queue.size();
  }
  queued_bytes_ -= sent_charge;
}

// I/O thread: hand-offs continue while no new message arrives; freed memory goes back.
void Server::ScheduleTick() {
  bool busy = false;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    for (const auto& [hdl, c] : impl_->clients) busy = busy || !c.queue.empty();
  }
  impl_->tick->expires_after(std::chrono::milliseconds(busy ? 2 : 50));
  impl_->tick->async_wait([this](const asio::error_code& ec) {
    if (ec) return;  // cancelled: the server stops
    Pump();
    ReturnFreedMemory();
    if (config_.operator_input) ReportPendingRateRefusals();
    ScheduleTick();
  });
}

// glibc keeps freed memory in its arenas (the I/O thread's and Cyclone's threads' arenas are
// not the main heap and are trimmed only on request): once departures have settled for 1 s
// (by then the DDS thread has deleted the readers no client needs), or every 10 s while
// clients keep leaving, malloc_trim returns every free page to the system.
void Server::ReturnFreedMemory() {
  if (!impl_->trim_due) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - impl_->last_departure < std::chrono::seconds(1) &&
      now - impl_->last_trim < std::chrono::seconds(10))
    return;
  impl_->trim_due = false;
  impl_->last_trim = now;
  const std::size_t before = ResidentBytes();
  malloc_trim(0);
  const struct mallinfo2 mi = mallinfo2();
  log_->info("clients left: freed memory returned to the system, resident {:.1f} -> {:.1f} MiB "
             "({:.1f} MiB allocated, {:.1f} MiB free in the allocator)", before / 1048576.0,
             ResidentBytes() / 1048576.0, mi.uordblks / 1048576.0, mi.fordblks / 1048576.0);
}

}  // namespace hexa::bridge
