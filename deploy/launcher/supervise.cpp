// hexa_session's children started in the layout's order and watched until the session
// completes (the supervisor finished the trajectory, the plant the experiment) or fails
// (docs/exit_codes.md: the launcher's exit codes and the services' codes it reads).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "child_progress.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/progress.hpp"
#include "launcher.hpp"
#include "udp_ports.hpp"

namespace hexa::launcher {
namespace {

using deploy::ChildExit;
using deploy::ChildSpec;
using deploy::ProcessGroup;

// The board emulator must listen before the plant sends its first command: a datagram to a
// port not yet bound is dropped, and in lockstep the plant awaits the answer to each command
// (a resend could step the emulator twice). Waits until the port is bound, the emulator
// ended, or 30 s (a loaded machine); false in the last two cases.
bool AwaitBoardListening(const ProcessGroup& group, int port, spdlog::logger& log) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30)) {
    if (deploy::UdpLoopbackPortBound(port)) {  // read, not probed: a bind would race the emulator's
      log.info("board emulator listening on UDP 127.0.0.1:{} after {:.3f} s", port,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      return true;
    }
    if (!group.Running("board")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  log.error("the board emulator does not listen on UDP 127.0.0.1:{} ({}): see board.console.log",
            port, group.Running("board") ? "not within 30 s" : "it ended");
  return false;
}

// Starts every child; the legs and the plant are told the pids of their peers started
// before them (the layout's peers). In lockstep a process that ended is then dead at once
// for them, where DDS would see it after its participant's lease (10 s); a stopped or slow
// one is waited for (docs/faults.md). False (everything stopped) if one cannot start.
bool StartChildren(ProcessGroup& group, const Launch& launch, int board_port, spdlog::logger& log) {
  std::vector<std::pair<std::string, pid_t>> started;
  for (std::size_t k = 0; k < launch.children.size(); ++k) {
    ChildSpec s = launch.children[k];
    for (const auto& peer : launch.layout.processes[k].peers)
      for (const auto& [name, pid] : started)
        if (name == peer) s.argv.insert(s.argv.end(), {"--peer-pid", name + "=" + std::to_string(pid)});
    std::string err;
    const pid_t pid = group.Start(s, err);
    if (pid < 0) {
      log.error("cannot start {}: {}", s.name, err);
      group.StopAll(std::chrono::milliseconds(2000));
      return false;
    }
    started.emplace_back(s.name, pid);
    log.info("started {} (pid {})", s.name, pid);
    if (s.name == "board" && board_port > 0 && !AwaitBoardListening(group, board_port, log)) {
      group.StopAll(std::chrono::milliseconds(2000));
      return false;
    }
  }
  return true;
}

class SessionWatch {
 public:
  SessionWatch(ProcessGroup& group, const Options& o, const Launch& launch, spdlog::logger& log)
      : group_(group), o_(o), launch_(launch), log_(log) {}

  void Run(SessionEnd& end);

 private:
  void WatchHold();
  void OnChildExited(const ChildExit& e, double elapsed_s, SessionEnd& end);
  void OnSupervisorExited(const ChildExit& e, double elapsed_s, SessionEnd& end);
  // The supervisor's line on how the session ended (--end-report), "" without one.
  std::string SupervisorEndLine() const;
  void Fail(SessionEnd& end, std::string why, int outcome) {
    end.ended_because = std::move(why);
    end.outcome = outcome;
    end.failed = true;
  }

  ProcessGroup& group_;
  const Options& o_;
  const Launch& launch_;
  spdlog::logger& log_;
  // The supervisor's one-line hold description (--hold-report): shown on the console when it
  // appears, again when a reset removes it.
  std::string hold_line_;
  double supervisor_lost_at_s_ = -1;  // the supervisor died: watch the legs hold for 2 s
};

void SessionWatch::WatchHold() {
  std::ifstream in(launch_.hold_report);
  std::string line;
  if (in && std::getline(in, line) && !line.empty()) {
    if (line != hold_line_)
      log_.error("platform HOLD: {}; waiting up to {} s for an operator reset "
                 "(hexa_operator --domain {} reset), then the session ends held (exit {})",
                 line, o_.hold_timeout_text, o_.domain, exit_code::kSessionHeld);
    hold_line_ = line;
  } else if (!in && !hold_line_.empty()) {
    log_.warn("the operator's reset left HOLD ({}): the session resumes", hold_line_);
    hold_line_.clear();
  }
}

std::string SessionWatch::SupervisorEndLine() const {
  std::string line;
  std::ifstream in(launch_.end_report);
  if (in) std::getline(in, line);
  return line;
}

void SessionWatch::OnSupervisorExited(const ChildExit& e, double elapsed_s, SessionEnd& end) {
  const bool exited = e.signal == 0;
  // Exit 0 is the trajectory's end only when the supervisor says so (--end-report): a
  // supervisor stopped by a signal leaves 0 too.
  const std::string line = SupervisorEndLine();
  const bool finished = o_.is_experiment() || line.rfind("the trajectory finished", 0) == 0;
  if (exited && e.exit_code == exit_code::kOk && !finished) {
    log_.error("{} before the trajectory's end; its last log lines:\n{}", e.Describe(),
               TailOf(o_.out_dir + "/supervisor.console.log", 15));
    Fail(end, line.empty() ? "the supervisor exited before the trajectory's end (no end report)"
                           : line, exit_code::kRunError);
  } else if (exited && e.exit_code == exit_code::kOk) {
    log_.info("supervisor finished the trajectory after {:.1f} s wall", elapsed_s);
    end.completed = true;
  } else if (exited && e.exit_code == exit_code::kSupervisorHeld) {
    WatchHold();
    Fail(end, "held after a fault, no operator reset within --hold-timeout " +
                  o_.hold_timeout_text + " s" +
                  (hold_line_.empty() ? std::string() : ": " + hold_line_),
         exit_code::kSessionHeld);
    log_.error("the supervisor left HOLD unreset (exit {}): {}", exit_code::kSessionHeld,
               end.ended_because);
  } else if (exited && e.exit_code == exit_code::kStoppedByOperator) {
    // The supervisor's words: stopped or shut down, when, and whether the trajectory had
    // started at all.
    std::string line = SupervisorEndLine();
    if (line.empty()) line = "stopped by the operator before the trajectory's end";
    Fail(end, line, exit_code::kSessionStoppedByOperator);
    log_.warn("the session was {} ({:.1f} s wall; exit {})", end.ended_because, elapsed_s,
              exit_code::kSessionStoppedByOperator);
  } else if (o_.fault_supervisor() || !exited) {
    // The legs see its setpoint writer's lease lapse and hold (docs/faults.md): watch
    // that for 2 s, then stop the session with exit 5.
    log_.warn("{}{}: watching the legs hold for 2 s", e.Describe(),
              o_.fault_supervisor() ? " (injected fault)" : "");
    supervisor_lost_at_s_ = elapsed_s;
  } else {
    log_.error("{} before the session completed; its last log lines:\n{}", e.Describe(),
               TailOf(o_.out_dir + "/" + e.name + ".console.log", 15));
    Fail(end, e.Describe(), exit_code::kRunError);
  }
}

void SessionWatch::OnChildExited(const ChildExit& e, double elapsed_s, SessionEnd& end) {
  end.exits.push_back(e);
  const bool is_leg = e.name.rfind("leg", 0) == 0;
  const bool plant_stopped = e.exit_code == exit_code::kPlantLockstepStall ||
                             e.exit_code == exit_code::kPlantNonFinite ||
                             e.exit_code == exit_code::kPlantDeviceLost;
  if (o_.is_experiment() && e.name == "plant" && e.signal == 0 && e.exit_code == exit_code::kOk) {
    log_.info("plant reached the end of the experiment after {:.1f} s wall", elapsed_s);
    end.completed = true;
  } else if (e.name == "supervisor") {
    OnSupervisorExited(e, elapsed_s, end);
  } else if (e.name == "plant" && e.signal == 0 && plant_stopped) {
    log_.error("{}: the plant stopped (exit {}); its last log lines:\n{}", e.Describe(),
               exit_code::kSessionPlantStopped, TailOf(o_.out_dir + "/plant.console.log", 15));
    Fail(end, "the plant stopped (" + e.Describe() + "; plant.log says why)",
         exit_code::kSessionPlantStopped);
  } else if (o_.standby && is_leg && e.name.find("_standby") == std::string::npos &&
             group_.Running(e.name + "_standby")) {
    log_.warn("{}; its hot standby {}_standby takes over the valve", e.Describe(), e.name);
  } else if (e.name == "board") {
    // The rig's I/O board gone (--device board): the plant reports the lost link
    // (FAULT_BOARD_LINK) and ticks on so that the supervisor holds; the hold decides the end.
    log_.error("{}: the I/O board emulator is gone; the plant reports the lost board and the "
               "supervisor holds; its last log lines:\n{}", e.Describe(),
               TailOf(o_.out_dir + "/board.console.log", 5));
  } else if (e.name == "bridge") {
    // A viewer, not part of the control loop: the session goes on without it.
    log_.error("{}; the session goes on without the Foxglove bridge; its last log "
               "lines:\n{}", e.Describe(), TailOf(o_.out_dir + "/bridge.console.log", 15));
  } else if (e.name.size() == 4 && is_leg && o_.FaultOfLeg(e.name[3] - '0') != nullptr) {
    // The death was injected on purpose: let the plant and the supervisor handle it.
    log_.warn("{} (injected fault): watching the plant and the supervisor react", e.Describe());
  } else {
    log_.error("{} before the session completed; its last log lines:\n{}", e.Describe(),
               TailOf(o_.out_dir + "/" + e.name + ".console.log", 15));
    Fail(end, e.Describe(), exit_code::kRunError);
  }
}

void SessionWatch::Run(SessionEnd& end) {
  // Progress: on a terminal one line (the recorder's newest progress line), in session.log a
  // line every 10 s.
  progress::Line progress("session", stderr, 10.0);
  progress.SetLogSink([&](const std::string& line) { log_.info("{}", line); });
  const std::string recorder_console = o_.out_dir + "/recorder.console.log";
  while (!end.completed && !end.failed) {
    auto ev = group_.WaitEvent(std::chrono::milliseconds(supervisor_lost_at_s_ >= 0 ? 100 : 1000));
    const double elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - end.t0).count();
    WatchHold();
    if (ev.kind == ProcessGroup::Event::kChildExited || ev.kind == ProcessGroup::Event::kInterrupted)
      progress.Clear();
    else
      progress.Update(-1, deploy::NewestProgress(recorder_console, {"record: progress: "}));
    if (supervisor_lost_at_s_ >= 0 && elapsed_s > supervisor_lost_at_s_ + 2.0) {
      log_.error("the supervisor was lost {:.1f} s ago: stopping (exit {})",
                 elapsed_s - supervisor_lost_at_s_, exit_code::kSessionSupervisorLost);
      Fail(end, "the supervisor was lost (its process died; the legs held their valves)",
           exit_code::kSessionSupervisorLost);
    }
    if (ev.kind == ProcessGroup::Event::kInterrupted) {
      log_.warn("interrupted by signal {}: stopping every process", ev.signal);
      end.ended_because = "interrupted by signal " + std::to_string(ev.signal);
      end.failed = true;
    } else if (ev.kind == ProcessGroup::Event::kChildExited) {
      OnChildExited(ev.exit, elapsed_s, end);
    } else if (o_.timeout_s > 0 && elapsed_s > o_.timeout_s) {
      log_.error("session exceeded --timeout {} s", o_.timeout_s);
      end.ended_because = "exceeded --timeout " + o_.timeout_text + " s";
      end.failed = true;
    }
  }
  progress.Close();  // the log says how the session ended
}

}  // namespace

SessionEnd Supervise(ProcessGroup& group, const Options& o, const Launch& launch,
                     spdlog::logger& log) {
  SessionEnd end;
  end.t0 = std::chrono::steady_clock::now();
  if (!StartChildren(group, launch, o.device == "board" ? o.board_port : 0, log)) {
    end.start_failed = true;
    return end;
  }
  SessionWatch(group, o, launch, log).Run(end);
  return end;
}

}  // namespace hexa::launcher
