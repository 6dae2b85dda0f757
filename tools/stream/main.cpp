// hexa_stream_send: sends the external motion stream (docs/motion_stream.md "Motion stream") over
// UDP at a fixed rate, for tests and demos: a pose sine, or the washout's worked examples as
// vehicle motion, with optional loss, reordering, duplicates, a gap and bad packets.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <random>
#include <string>

#include "hexa/core/motion_stream.hpp"
#include "hexa/core/washout.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/udp_stream.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Options {
  std::string address;
  long long port = 0;
  double rate_hz = 100.0;
  double duration_s = 10.0;
  std::string motion;
  double amplitude_m = 0.03;
  double amplitude_rad = 0.0;
  double frequency_hz = 0.5;
  double loss = 0.0, reorder = 0.0, duplicate = 0.0;
  double gap_at_s = -1.0, gap_s = 0.0;
  long long bad_every = 0;
  long long first_sequence = 1;
  long long seed = 1;
};

hexa::StreamPacket PacketAt(const Options& o, std::uint64_t sequence, double t) {
  hexa::StreamPacket p;
  p.sequence = sequence;
  p.time_s = t;
  if (o.motion == "sine") {
    p.kind = hexa::StreamKind::kPose;
    const double s = std::sin(2.0 * kPi * o.frequency_hz * t);
    p.values[0] = o.amplitude_m * s;
    p.values[3] = o.amplitude_rad * s;
  } else {
    p.kind = hexa::StreamKind::kVehicle;
    const hexa::WashoutInput w =
        o.motion == "braking" ? hexa::BrakingExample(t) : hexa::LaneChangeExample(t);
    p.values.head<3>() = w.acceleration_m_s2;
    p.values.tail<3>() = w.angular_rate_rad_s;
  }
  return p;
}

// The n-th bad packet: wrong size, wrong version, NaN, absurd value, in turn.
std::size_t MakeBad(std::uint64_t n, const hexa::StreamPacket& good,
                    std::array<std::uint8_t, hexa::kStreamPacketSize>& bytes) {
  hexa::StreamPacket p = good;
  switch (n % 4) {
    case 0:
      hexa::EncodeStreamPacket(p, bytes);
      return 40;
    case 1:
      hexa::EncodeStreamPacket(p, bytes);
      bytes[4] = 9;
      return bytes.size();
    case 2:
      p.values[1] = std::nan("");
      break;
    default:
      p.values[0] = 1e6;
      break;
  }
  hexa::EncodeStreamPacket(p, bytes);
  return bytes.size();
}

bool ParseOptions(hexa::cli::Parser& cli, Options& o) {
  auto port = cli.GetInt("port", 1, 65535);
  auto rate = cli.GetDouble("rate-hz", 1.0, 2000.0);
  auto duration = cli.GetDouble("duration-s", 0.0, 86400.0);
  auto amplitude = cli.GetDouble("amplitude-m", 0.0, 0.5);
  auto amplitude_rad = cli.GetDouble("amplitude-rad", 0.0, 1.0);
  auto frequency = cli.GetDouble("frequency-hz", 0.0, 50.0);
  auto loss = cli.GetDouble("loss", 0.0, 1.0);
  auto reorder = cli.GetDouble("reorder", 0.0, 1.0);
  auto duplicate = cli.GetDouble("duplicate", 0.0, 1.0);
  auto gap_at = cli.GetDouble("gap-at-s", -1.0, 86400.0);
  auto gap = cli.GetDouble("gap-s", 0.0, 86400.0);
  auto bad_every = cli.GetInt("bad-every", 0, 1000000);
  auto first = cli.GetInt("first-sequence", 0, 1LL << 62);
  auto seed = cli.GetInt("seed", 0, 1LL << 62);
  if (!port || !rate || !duration || !amplitude || !amplitude_rad || !frequency || !loss ||
      !reorder || !duplicate || !gap_at || !gap || !bad_every || !first || !seed) {
    return false;
  }
  o = Options{cli.Get("address"), *port, *rate, *duration, cli.Get("motion"), *amplitude,
              *amplitude_rad, *frequency, *loss, *reorder, *duplicate, *gap_at, *gap,
              *bad_every, *first, *seed};
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_stream_send",
                        "Sends the external motion stream (72-byte UDP packets, docs/operate.md) "
                        "at a fixed rate: a pose sine or a worked washout example, with optional "
                        "loss, reordering, duplicates, a gap and bad packets (tests, demos).");
  cli.AddOption("address", "ipv4", "receiver address", "127.0.0.1");
  cli.AddOption("port", "N", "receiver port", std::to_string(hexa::udp::kDefaultStreamPort));
  cli.AddOption("rate-hz", "Hz", "packets per second (1-2000)", "100");
  cli.AddOption("duration-s", "s", "how long to send", "10");
  cli.AddChoice("motion", {"sine", "braking", "lane-change"},
                "sine: pose packets (x, roll); braking / lane-change: vehicle packets of the "
                "washout's worked examples", "sine");
  cli.AddOption("amplitude-m", "m", "sine: x amplitude", "0.03");
  cli.AddOption("amplitude-rad", "rad", "sine: roll amplitude", "0");
  cli.AddOption("frequency-hz", "Hz", "sine: frequency", "0.5");
  cli.AddOption("loss", "p", "drop each packet with this probability", "0");
  cli.AddOption("reorder", "p", "swap a packet with the next one with this probability", "0");
  cli.AddOption("duplicate", "p", "send a packet twice with this probability", "0");
  cli.AddOption("gap-at-s", "s", "stop sending at this time (-1: no gap)", "-1");
  cli.AddOption("gap-s", "s", "for this long", "0");
  cli.AddOption("bad-every", "N", "after every N-th packet send a bad one (wrong size, "
                "version, NaN, absurd value in turn); 0: none", "0");
  cli.AddOption("first-sequence", "N", "sequence number of the first packet", "1");
  cli.AddOption("seed", "N", "seed of the loss / reorder / duplicate draws", "1");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  Options o;
  if (!ParseOptions(cli, o)) {
    std::fprintf(stderr, "error: %s\n", cli.error().c_str());
    return 2;
  }
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(o.port));
  if (inet_pton(AF_INET, o.address.c_str(), &to.sin_addr) != 1) {
    std::fprintf(stderr, "error: --address '%s' is not an IPv4 address\n", o.address.c_str());
    return 2;
  }
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    std::fprintf(stderr, "error: socket(): %s\n", std::strerror(errno));
    return 1;
  }
  std::mt19937_64 rng(static_cast<std::uint64_t>(o.seed));
  const auto draw = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const auto send = [&](const std::uint8_t* data, std::size_t size) {
    return sendto(fd, data, size, 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) ==
           static_cast<ssize_t>(size);
  };
  unsigned long long sent = 0, dropped = 0, duplicated = 0, reordered = 0, bad = 0, failed = 0;
  std::deque<std::array<std::uint8_t, hexa::kStreamPacketSize>> held;  // one held back to reorder
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const long period_ns = static_cast<long>(1e9 / o.rate_hz);
  const long long count = static_cast<long long>(std::floor(o.duration_s * o.rate_hz));
  for (long long k = 0; k < count; ++k) {
    const double t = static_cast<double>(k) / o.rate_hz;
    const hexa::StreamPacket packet = PacketAt(o, static_cast<std::uint64_t>(o.first_sequence + k), t);
    const bool in_gap = o.gap_at_s >= 0.0 && t >= o.gap_at_s && t < o.gap_at_s + o.gap_s;
    std::array<std::uint8_t, hexa::kStreamPacketSize> bytes{};
    hexa::EncodeStreamPacket(packet, bytes);
    if (in_gap || draw() < o.loss) {
      ++dropped;
    } else if (held.empty() && draw() < o.reorder) {
      held.push_back(bytes);  // sent after the next one
      ++reordered;
    } else {
      failed += !send(bytes.data(), bytes.size());
      ++sent;
      if (draw() < o.duplicate) {
        failed += !send(bytes.data(), bytes.size());
        ++duplicated;
      }
      while (!held.empty()) {
        failed += !send(held.front().data(), held.front().size());
        held.pop_front();
        ++sent;
      }
    }
    if (o.bad_every > 0 && (k + 1) % o.bad_every == 0) {
      std::array<std::uint8_t, hexa::kStreamPacketSize> wrong{};
      const std::size_t size = MakeBad(bad, packet, wrong);
      failed += !send(wrong.data(), size);
      ++bad;
    }
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  close(fd);
  std::printf("hexa_stream_send: %s to %s:%lld at %g Hz: %lld packets, sent %llu, dropped %llu, "
              "reordered %llu, duplicated %llu, bad %llu, send failures %llu\n", o.motion.c_str(),
              o.address.c_str(), o.port, o.rate_hz, count, sent, dropped, reordered, duplicated,
              bad, failed);
  return failed == 0 ? 0 : 1;
}
