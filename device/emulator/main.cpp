// hexa_board_emulator: the remote I/O board emulated over UDP (board_emulator.hpp,
// docs/board_protocol.md "Emulator"). Wall clock: one board tick per millisecond, each
// sending a sensor frame to the host that sent the last accepted command. Step: one tick per
// received datagram, answered to its sender (deterministic: lockstep tests).
//
// Exit codes: 0 stopped (signal, --duration-s, --idle-exit-s), 1 rig file invalid or without
// a `board` block, 2 usage, 3 the UDP socket cannot be opened (bad --bind address, port in
// use), 4 the plant stopped (non-finite state).
#include <algorithm>
#include <array>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <memory>
#include <span>
#include <string>

#include "board_emulator.hpp"
#include "link_faults.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/device/udp_socket.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/logging.hpp"
#include "hexa/services/scheduling.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;
std::timespec g_stop_time{};  // when the stop signal came (set before g_stop)
void OnSignal(int) {
  clock_gettime(CLOCK_MONOTONIC, &g_stop_time);  // async-signal-safe
  g_stop = 1;
}

bool Before(const std::timespec& a, const std::timespec& b) {
  return a.tv_sec < b.tv_sec || (a.tv_sec == b.tv_sec && a.tv_nsec < b.tv_nsec);
}

struct Options {
  std::string rig, profile, bind, port_file;
  std::uint64_t seed = 1;
  int port = 0;
  bool step = false;
  double duration_s = 0.0, idle_exit_s = 0.0;
  std::vector<hexa::device::EstopOpenWindow> estop_open;
  std::vector<hexa::device::LinkFault> link_faults;
  std::uint64_t fault_seed = 1;
  int rt_priority = 0;
  std::string cpus;
};

bool ParseWindow(const std::string& text, hexa::device::EstopOpenWindow& w) {
  unsigned long long from = 0, to = 0;
  char colon = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%llu%c%llu%c", &from, &colon, &to, &extra) != 3 || colon != ':' || to <= from) {
    return false;
  }
  w = {from, to};
  return true;
}

int ParseOptions(int argc, char** argv, Options& o) {
  hexa::cli::Parser p("hexa_board_emulator",
                      "The remote I/O board emulated: the board's C code with the simulated rig behind its "
                      "ADC and DAC channels, answering over UDP (docs/board_protocol.md).");
  p.AddOption("rig", "FILE", "rig file with a `board` block", hexa::config::DefaultRigFile());
  p.AddOption("profile", "NAME", "disturbance profile of the rig file (default: the file's)", "");
  p.AddOption("seed", "N", "seed of the plant's disturbances and sensor noise", "1");
  p.AddOption("bind", "ADDRESS", "IPv4 address to listen on", "127.0.0.1");
  p.AddOption("port", "N", "UDP port to listen on (0: any free port)", "0");
  p.AddOption("port-file", "FILE", "write the bound port here once listening", "");
  p.AddChoice("clock", {"wall", "step"}, "wall: tick every 1 ms; step: one tick per received datagram", "wall");
  p.AddRepeatable("estop-open", "FROM:TO", "open the e-stop loop during board ticks [FROM, TO)");
  p.AddRepeatable("link-fault", "KIND:ARG",
                   "inject a link fault (deterministic): drop:PERCENT (datagrams lost either way, seeded), "
                   "or bad-crc|old-version|out-of-range|reorder:N[:FROM[:TO]] (every Nth sensor frame in "
                   "board ticks [FROM, TO); out-of-range: leg 1's potentiometer at 0 counts; reorder: held "
                   "back and sent after the next frame)");
  p.AddOption("fault-seed", "N", "seed of --link-fault drop", "1");
  p.AddOption("duration-s", "S", "stop after this many seconds of board time (0: never)", "0");
  p.AddOption("idle-exit-s", "S", "step: stop when no datagram came for this long (0: never)", "0");
  p.AddOption("rt-priority", "N", "wall clock: run SCHED_FIFO at this priority (0: normal scheduling)", "0");
  p.AddOption("cpus", "LIST", "pin the emulator to these CPUs (\"1\", \"0-1\"; empty: any)", "");
  const int r = hexa::cli::HandleParseResult(p, p.Parse(argc, argv));
  if (r >= 0) return r;
  o.rig = p.Get("rig");
  o.profile = p.Get("profile");
  o.bind = p.Get("bind");
  o.port_file = p.Get("port-file");
  o.step = p.Get("clock") == "step";
  const auto seed = p.GetInt("seed", 0, 1LL << 62);
  const auto fault_seed = p.GetInt("fault-seed", 0, 1LL << 62);
  const auto port = p.GetInt("port", 0, 65535);
  const auto duration = p.GetDouble("duration-s", 0.0, 1e6);
  const auto idle = p.GetDouble("idle-exit-s", 0.0, 1e6);
  const auto rt_priority = p.GetInt("rt-priority", 0, 98);
  o.cpus = p.Get("cpus");
  for (const std::string& w : p.GetAll("estop-open")) {
    hexa::device::EstopOpenWindow window;
    if (!ParseWindow(w, window)) p.Fail("--estop-open: expected FROM:TO ticks with FROM < TO, got '" + w + "'");
    o.estop_open.push_back(window);
  }
  for (const std::string& f : p.GetAll("link-fault")) {
    hexa::device::LinkFault fault;
    std::string error;
    if (!hexa::device::ParseLinkFault(f, fault, error)) p.Fail(error);
    o.link_faults.push_back(fault);
  }
  if (!seed || !fault_seed || !port || !duration || !idle || !rt_priority || !p.error().empty())
    return hexa::cli::HandleParseResult(p, false);
  o.rt_priority = static_cast<int>(*rt_priority);
  o.seed = static_cast<std::uint64_t>(*seed);
  o.fault_seed = static_cast<std::uint64_t>(*fault_seed);
  o.port = static_cast<int>(*port);
  o.duration_s = *duration;
  o.idle_exit_s = *idle;
  return -1;
}

std::timespec Add(std::timespec t, long ns) {
  t.tv_nsec += ns;
  while (t.tv_nsec >= 1'000'000'000L) {
    t.tv_nsec -= 1'000'000'000L;
    ++t.tv_sec;
  }
  return t;
}

// The rig file's plant, profile and board calibration; 0 or the exit code (logged).
int LoadConfig(const Options& o, spdlog::logger& log, hexa::device::BoardEmulatorConfig& ec, std::string& summary) {
  const hexa::config::ConfigResult rig = hexa::config::LoadSystemConfig(o.rig);
  if (!rig.ok) {
    log.error("{}", rig.error);
    return 1;
  }
  if (!rig.config.board) {
    log.error("{}: no `board` block: the emulator needs the board's calibration (docs/board_protocol.md)", o.rig);
    return 1;
  }
  const hexa::config::ProfileResult profile = hexa::config::SelectProfile(rig.config, o.profile);
  if (!profile.ok) {
    log.error("{}", profile.error);
    return 1;
  }
  ec.plant.rig = rig.config.rig;
  ec.plant.disturbance = profile.profile;
  ec.plant.seed = o.seed;
  ec.calibration = *rig.config.board;
  ec.valve_null_v = rig.config.rig.valve.null_voltage_v;
  ec.estop_open = o.estop_open;
  summary = "rig " + rig.config.rig_name + ", profile " + profile.name + ", seed " + std::to_string(o.seed);
  return 0;
}

// The emulated board on its UDP socket: datagrams in, ticks, frames out, through the link's
// injected faults (--link-fault).
class Server {
 public:
  Server(const hexa::device::BoardEmulatorConfig& config, hexa::device::UdpSocket socket,
         hexa::device::LinkFaultInjector faults, spdlog::logger& log)
      : emulator_(std::make_unique<hexa::device::BoardEmulator>(config)),
        socket_(std::move(socket)),
        faults_(std::move(faults)),
        log_(log) {}

  // Step: one tick per received datagram, answered to its sender with one datagram. A frame
  // the link loses or holds back is answered with a zero-length datagram, so that a host in
  // lockstep learns at once that this tick brings no frame (it counts it `short`).
  void RunStep(const Options& o) {
    double idle_s = 0.0;
    while (Running(o) && !g_stop) {
      if (!socket_.WaitReadable(0.1)) {
        idle_s += 0.1;
        if (o.idle_exit_s > 0.0 && idle_s >= o.idle_exit_s) return;
        continue;
      }
      idle_s = 0.0;
      sockaddr_in from{};
      while (!g_stop && Running(o) && ReceiveOne(from)) TickAndSend(from, true);
    }
  }

  // Wall clock: a tick every millisecond, its frame to the sender of the last accepted command.
  // A stop signal ends the loop once the ticks due before it have run: the board's time is the
  // wall clock, whoever is being stopped around it.
  void RunWall(const Options& o) {
    std::timespec next{};
    clock_gettime(CLOCK_MONOTONIC, &next);
    while (Running(o)) {
      next = Add(next, 1'000'000L);
      while (!g_stop && clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
      }
      if (g_stop && !Before(next, g_stop_time)) return;
      sockaddr_in from{};
      while (ReceiveOne(from)) {
      }
      if (have_peer_) TickAndSend(peer_, false);
      else Tick();
    }
  }

  bool plant_failed() const { return emulator_->plant().output().status == hexa::PlantStatus::kNonFiniteState; }

  std::string Summary() const {
    std::string counts;
    for (int r = 0; r < HB_FRAME_REASON_COUNT; ++r) {
      if (received_[r] == 0) continue;
      counts += (counts.empty() ? "" : ", ") + std::string(hb_frame_reason_name(static_cast<hb_frame_reason>(r))) +
                " " + std::to_string(received_[r]);
    }
    const hb_board& b = emulator_->board();
    std::string text = "stopped at board tick " + std::to_string(emulator_->tick()) + ": datagrams received: " +
                       (counts.empty() ? "none" : counts) + "; last valid command at board tick " +
                       (b.have_command ? std::to_string(b.last_command_us / 1000u) : std::string("none")) +
                       "; watchdog fired " + std::to_string(b.watchdog_count) + " times; send errors " +
                       std::to_string(send_errors_);
    if (!faults_.empty()) text += "; link faults injected: " + faults_.counts().Describe();
    return text;
  }

 private:
  bool Running(const Options& o) const {
    const auto duration_ticks = static_cast<std::uint64_t>(o.duration_s * 1000.0);
    return !plant_failed() && (duration_ticks == 0 || emulator_->tick() < duration_ticks);
  }
  // One board tick; a watchdog firing is logged with the last valid command's tick.
  void Tick() {
    const std::uint16_t fired_before = emulator_->board().watchdog_count;
    emulator_->Tick(tx_);
    const hb_board& b = emulator_->board();
    if (b.watchdog_count != fired_before) {
      const std::uint64_t tick = emulator_->tick() - 1;
      if (b.have_command) {
        const std::uint64_t last = b.last_command_us / 1000u;
        log_.warn("board tick {}: watchdog fired: no valid command for {} ticks (the last at board tick {}; "
                  "watchdog {} ms): every valve to its safe value", tick, tick - last, last, b.watchdog_ms);
      } else {
        log_.info("board tick {}: watchdog: no valid command since power-up: every valve at its safe value", tick);
      }
    }
  }
  void TickAndSend(const sockaddr_in& to, bool step) {
    Tick();
    const std::uint64_t tick = emulator_->tick() - 1;
    const hexa::device::FrameFate fate = faults_.Apply(tick, tx_, holding_);
    if (fate == hexa::device::FrameFate::kHold) {
      held_ = tx_;
      holding_ = true;
    }
    if (fate == hexa::device::FrameFate::kSend || fate == hexa::device::FrameFate::kSendAltered) {
      SendTo(tx_, to);
      // The held frame after a newer one (out of order), after an intact one only: a host
      // that refused the newer one would take the held one as new.
      if (holding_ && fate == hexa::device::FrameFate::kSend) {
        SendTo(held_, to);
        holding_ = false;
      }
    } else if (step) {
      SendTo(std::span<const std::uint8_t>(), to);
    }
  }
  bool ReceiveOne(sockaddr_in& from) {
    int err = 0;
    const long n = socket_.Receive(rx_, from, err);
    if (n < 0) return false;
    if (faults_.DropCommand(emulator_->tick())) return true;  // lost on the way
    const std::size_t size = std::min<std::size_t>(static_cast<std::size_t>(n), rx_.size());
    const hb_frame_reason r = emulator_->Receive(std::span<const std::uint8_t>(rx_.data(), size));
    ++received_[r];
    if (r == HB_FRAME_OK) {
      peer_ = from;
      have_peer_ = true;
    }
    return true;
  }
  void SendTo(std::span<const std::uint8_t> datagram, const sockaddr_in& to) {
    int err = 0;
    if (!socket_.Send(datagram, to, err)) ++send_errors_;
  }

  std::unique_ptr<hexa::device::BoardEmulator> emulator_;  // the plant is large: on the heap
  hexa::device::UdpSocket socket_;
  hexa::device::LinkFaultInjector faults_;
  spdlog::logger& log_;
  std::array<std::uint64_t, HB_FRAME_REASON_COUNT> received_{};
  std::array<std::uint8_t, HB_MAX_FRAME_SIZE + 1> rx_{};
  std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE> tx_{}, held_{};
  bool holding_ = false;
  sockaddr_in peer_{};
  bool have_peer_ = false;
  std::uint64_t send_errors_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  using namespace hexa::device;
  Options o;
  if (const int r = ParseOptions(argc, argv, o); r >= 0) return r;
  auto log = hexa::logging::Init("board_emulator");
  BoardEmulatorConfig config;
  std::string summary;
  if (const int r = LoadConfig(o, *log, config, summary); r != 0) return r;

  const auto local = ParseIpv4(o.bind, static_cast<std::uint16_t>(o.port));
  if (!local) {
    log->error("--bind: not a dotted IPv4 address: '{}'", o.bind);
    return 3;
  }
  UdpSocket socket;
  std::string error;
  if (!socket.Open(*local, error)) {
    log->error("{}", error);
    return 3;
  }
  const sockaddr_in bound = socket.local_address();
  if (!o.port_file.empty()) std::ofstream(o.port_file) << ntohs(bound.sin_port) << "\n";
  log->info("listening on UDP {} ({} clock, {}, watchdog {} ms)", ToString(bound), o.step ? "step" : "wall", summary,
            std::lround(config.calibration.watchdog_timeout_s * 1000.0));
  // A board keeps its 1 ms tick whatever the host does: scheduling as asked, best effort.
  std::string message;
  if (!o.cpus.empty()) {
    std::vector<int> cpus;
    if (!hexa::sched::ParseCpuList(o.cpus, cpus)) {
      log->error("--cpus '{}': expected a CPU list (1, 0,1, 0-1)", o.cpus);
      return 2;
    }
    if (!hexa::sched::SetCpuAffinity(cpus, message)) log->warn("{}", message);
  }
  if (o.rt_priority > 0 && !hexa::sched::SetRealtime(o.rt_priority, message)) log->warn("{}", message);
  else if (o.rt_priority > 0) log->info("{}", message);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);

  hexa::device::LinkFaultInjector faults(o.link_faults, o.fault_seed);
  if (!faults.empty()) log->warn("LINK FAULT INJECTION: {} (fault seed {})", faults.Describe(), o.fault_seed);
  Server server(config, std::move(socket), std::move(faults), *log);
  if (o.step) server.RunStep(o);
  else server.RunWall(o);
  log->info("{}", server.Summary());
  if (server.plant_failed()) {
    log->error("the plant's state became non-finite: stopped");
    return 4;
  }
  return 0;
}
