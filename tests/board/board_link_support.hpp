// Test harness of the board link: hexa_board_emulator as a child process, and a proxy between
// the RemoteBoardDevice and the emulator that can corrupt, duplicate, reorder or drop single
// datagrams in either direction (loopback UDP; the tests run in their own network namespace).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "hexa/device/udp_socket.hpp"

extern char** environ;

namespace hexa::testing {

// hexa_board_emulator with `args`, listening on 127.0.0.1 at a port it chooses; ended (SIGTERM,
// then SIGKILL) by its PID when the object goes.
class EmulatorProcess {
 public:
  EmulatorProcess(const std::string& dir, std::vector<std::string> args) : log_(dir + "/emulator.log") {
    const std::string port_file = dir + "/emulator.port";
    std::vector<std::string> argv = {HEXA_BOARD_EMULATOR_BIN, "--port", "0", "--port-file", port_file,
                                     "--idle-exit-s", "60"};
    argv.insert(argv.end(), args.begin(), args.end());
    pid_ = Spawn(argv, log_);
    for (int i = 0; i < 1000 && port_ == 0; ++i) {
      std::ifstream in(port_file);
      int port = 0;
      if (in >> port && port > 0) port_ = static_cast<std::uint16_t>(port);
      else std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ~EmulatorProcess() { Stop(); }

  // Runs `argv` with stdout and stderr into `log`; returns its PID.
  static pid_t Spawn(const std::vector<std::string>& argv, const std::string& log) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    return rc == 0 ? pid : -1;
  }
  // Exit code of a process, waiting up to `timeout_s` (then SIGKILL, -1).
  static int WaitExit(pid_t pid, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    while (std::chrono::steady_clock::now() < end) {
      if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    return -1;
  }

  void Stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    exit_code_ = WaitExit(pid_, 5.0);
    pid_ = -1;
  }
  std::uint16_t port() const { return port_; }
  int exit_code() const { return exit_code_; }
  std::string Log() const {
    std::ifstream in(log_);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

 private:
  std::string log_;
  pid_t pid_ = -1;
  std::uint16_t port_ = 0;
  int exit_code_ = -1;
};

// Datagrams to deliver in place of one received (empty: dropped).
using Mangle = std::function<std::vector<std::vector<std::uint8_t>>(std::vector<std::uint8_t>)>;
inline std::vector<std::vector<std::uint8_t>> Pass(std::vector<std::uint8_t> d) { return {std::move(d)}; }

// device <-> [device_side | proxy | board_side] <-> emulator
class LinkProxy {
 public:
  explicit LinkProxy(std::uint16_t emulator_port) {
    std::string error;
    const auto local = *device::ParseIpv4("127.0.0.1", 0);
    EXPECT_TRUE(device_side_.Open(local, error)) << error;
    EXPECT_TRUE(board_side_.Open(local, error)) << error;
    emulator_ = *device::ParseIpv4("127.0.0.1", emulator_port);
  }
  // The address the device must take for the board's.
  std::uint16_t board_port() const { return ntohs(device_side_.local_address().sin_port); }

  bool ForwardCommand(const Mangle& mangle = Pass) {
    return Forward(device_side_, board_side_, emulator_, mangle, &device_);
  }
  bool ForwardFrame(const Mangle& mangle = Pass) { return Forward(board_side_, device_side_, device_, mangle, nullptr); }
  // Sends to the device from a socket that is not the board's.
  void SendFromStranger(const std::vector<std::uint8_t>& datagram) {
    device::UdpSocket stranger;
    std::string error;
    ASSERT_TRUE(stranger.Open(*device::ParseIpv4("127.0.0.1", 0), error)) << error;
    int err = 0;
    ASSERT_TRUE(stranger.Send(datagram, device_, err));
  }

 private:
  static bool Forward(device::UdpSocket& in, device::UdpSocket& out, const sockaddr_in& to, const Mangle& mangle,
                      sockaddr_in* sender) {
    if (!in.WaitReadable(5.0)) return false;
    std::vector<std::uint8_t> buffer(2048);
    sockaddr_in from{};
    int err = 0;
    const long n = in.Receive(buffer, from, err);
    if (n < 0) return false;
    if (sender != nullptr) *sender = from;
    buffer.resize(static_cast<std::size_t>(n));
    for (const auto& d : mangle(std::move(buffer))) {
      if (!out.Send(d, to, err)) return false;
    }
    return true;
  }

  device::UdpSocket device_side_, board_side_;
  sockaddr_in emulator_{}, device_{};
};

}  // namespace hexa::testing
