// hexa_bridge's WebSocket server: what clients publish (docs/foxglove.md, "Operator input: Foxglove as the operator console").
// A client advertises the operator input channel, then sends Client Message Data frames on
// it; each is checked for its channel, the client's rate and its content before the operator
// input handler sees it, and the client is told the outcome by a status.
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "ws_server_impl.hpp"

namespace hexa::bridge {

// I/O thread: a client advertises (or withdraws) the channels it will publish on. Only the
// operator input topic, JSON-encoded, is accepted; anything else is refused with a status.
void Server::OnClientChannels(const std::weak_ptr<void>& hdl, const ClientRequest& req) {
  std::string refused, accepted;
  uint64_t id = 0;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    auto it = impl_->clients.find(hdl);
    if (it == impl_->clients.end()) return;
    Impl::Client& c = it->second;
    id = c.stats.id;
    for (const ClientChannel& ch : req.channels) {
      if (ch.topic != kOperatorInputTopic) {
        refused += "channel " + std::to_string(ch.id) + ": topic '" + ch.topic.substr(0, 60) +
                   "' is not accepted (only " + kOperatorInputTopic + "); ";
      } else if (ch.encoding != kOperatorInputEncoding) {
        refused += "channel " + std::to_string(ch.id) + ": encoding '" + ch.encoding.substr(0, 20) +
                   "' is not accepted (only json); ";
      } else if (c.advertised.count(ch.id) != 0) {
        refused += "channel " + std::to_string(ch.id) + " is already advertised; ";
      } else {
        c.advertised[ch.id] = ch;
        accepted += " " + std::to_string(ch.id);
      }
    }
    for (uint32_t ch : req.unadvertise_ids) {
      if (c.advertised.erase(ch) == 0)
        refused += "no advertised channel " + std::to_string(ch) + "; ";
    }
  }
  if (!accepted.empty())
    log_->info("client {}: operator input channel{} advertised", id, accepted);
  if (!refused.empty()) {
    ++operator_inputs_refused_;
    log_->warn("client {}: {}", id, refused);
    SendStatus(hdl, StatusLevel::kError, refused);
  }
}

// I/O thread: one Client Message Data frame (well-formed: ParseClientBinary). Checked for its
// channel, the client's rate and its content, then handed to the operator input handler; the
// client is told the outcome by a status (errors level 2), except that refusals for rate are
// summed up once a second.
void Server::OnClientBinary(const std::weak_ptr<void>& hdl, const std::string& frame) {
  const ClientMessageData data = ParseClientBinary(frame);
  const int64_t now_ns = SteadyNow_ns();
  // A jog (a stream, tens a second) and the other commands have their own rates. The rate is
  // checked before the message is parsed (a flood costs no parsing): a valid message that holds
  // the token "jog" is a jog (no other valid input can hold it: its fields and values are fixed),
  // one that does not is charged to the commands' rate.
  const bool jog = data.payload.find("\"jog\"") != std::string::npos;
  uint64_t id = 0;
  std::string remote, refusal;
  uint64_t rate_refused = 0;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    auto it = impl_->clients.find(hdl);
    if (it == impl_->clients.end()) return;
    Impl::Client& c = it->second;
    id = c.stats.id;
    remote = c.stats.remote;
    if (c.advertised.count(data.channel_id) == 0) {
      refusal = "message on channel " + std::to_string(data.channel_id) +
                ", which this client has not advertised (advertise " + kOperatorInputTopic +
                " first)";
    } else if (!(jog ? c.jog_limiter : c.operator_limiter).Allow(now_ns)) {
      ++c.rate_refused;
      ++operator_inputs_refused_;
      if (now_ns - c.rate_reported_ns < 1'000'000'000) return;
      c.rate_reported_ns = now_ns;
      rate_refused = c.rate_refused;
      c.rate_refused = 0;
    }
  }
  if (rate_refused > 0) {
    ReportRateRefusals(hdl, id, remote, rate_refused);
    return;
  }
  OperatorInputResult parsed;
  if (refusal.empty()) {
    parsed = ParseOperatorInput(data.payload);
    if (!parsed.ok) refusal = parsed.error;
  }
  std::string answer;
  if (refusal.empty()) {
    answer = on_operator_input_ ? on_operator_input_(id, remote, parsed.input) : "";
    if (answer.empty()) refusal = "operator input is not forwarded (see the bridge's log)";
  }
  if (!refusal.empty()) {
    ++operator_inputs_refused_;
    log_->warn("client {} ({}): operator input refused: {}", id, remote, refusal);
    SendStatus(hdl, StatusLevel::kError, "refused: " + refusal);
    return;
  }
  SendStatus(hdl, StatusLevel::kInfo, answer);
}

void Server::ReportRateRefusals(const std::weak_ptr<void>& hdl, uint64_t id,
                                const std::string& remote, uint64_t count) {
  char rate[32];
  std::snprintf(rate, sizeof rate, "%g", config_.operator_input_rate_hz);
  char jog_rate[32];
  std::snprintf(jog_rate, sizeof jog_rate, "%g", config_.operator_jog_rate_hz);
  const std::string why = std::to_string(count) + " operator input(s) refused: more than " +
                          rate + " commands or " + jog_rate +
                          " jog messages a second from this client (rate limit)";
  log_->warn("client {} ({}): {}", id, remote, why);
  SendStatus(hdl, StatusLevel::kError, why);
}

// I/O thread: refusals for rate not yet reported (at most one report a second per client).
void Server::ReportPendingRateRefusals() {
  const int64_t now_ns = SteadyNow_ns();
  std::vector<std::tuple<Hdl, uint64_t, std::string, uint64_t>> due;
  {
    std::lock_guard<std::mutex> lock(impl_->clients_mutex);
    for (auto& [hdl, c] : impl_->clients) {
      if (c.rate_refused == 0 || now_ns - c.rate_reported_ns < 1'000'000'000) continue;
      due.emplace_back(hdl, c.stats.id, c.stats.remote, c.rate_refused);
      c.rate_refused = 0;
      c.rate_reported_ns = now_ns;
    }
  }
  for (const auto& [hdl, id, remote, count] : due) ReportRateRefusals(hdl, id, remote, count);
}

}  // namespace hexa::bridge
