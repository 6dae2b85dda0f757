// hexa_operator: sends one operator command to the supervisor (reliable, keep-all).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <cstring>
#include <exception>
#include <string>

#include "command_answer.hpp"
#include "hexa/comm/comm.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/logging.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/operator_motion_wire.hpp"
#include "hexa/services/text.hpp"

namespace {

namespace exit_code = hexa::exit_code;

// One command to send, read from the command line.
struct Request {
  int domain = 0;
  double wait_s = 0, linger_s = 0, answer_wait_s = 0;
  std::string what;  // start stop reset home shutdown estop jog goal stream
  bool any_reader = false;
  double jog_duration_s = 0, jog_rate_hz = 0;  // jog: how long and how often to send it
  hexa_msg_OperatorCommand cmd{};
};

void AddOptions(hexa::cli::Parser& cli) {
  cli.AddOption("domain", "id", "DDS domain id", "0");
  cli.AddOption("dds-config", "file", "Cyclone DDS configuration (default: loopback only)");
  cli.AddOption("trajectory", "name|file.csv", "for start: x y z roll pitch yaw combined or CSV",
                "combined");
  cli.AddOption("wait", "s", "how long to wait for the supervisor to match", "5");
  cli.AddChoice("to", {"supervisor", "any-reader"},
                "write once this reader has matched: the supervisor's command reader (it says so in "
                "its USER_DATA), or any reader of the topic (a recorder alone: tests of the wire)",
                "supervisor");
  cli.AddOption("linger", "s",
                "keep the command's writer this long after it was acknowledged: a reader that "
                "matched this writer only just before the write answers at the writer's next "
                "heartbeat, and Cyclone's wait for acknowledgements does not seem to count it yet "
                "(commands were lost between hosts: docs/measurements/deployment.md)", "0.5");
  cli.AddOption("session-key", "file",
                "the session's key (default: $HEXA_SESSION_KEY): without it the supervisor "
                "refuses the command (docs/faults.md, \"Foreign commands\")");
  cli.AddOption("answer-wait", "s",
                "how long to wait for the supervisor's answer (accepted / refused) after the "
                "command was acknowledged; it answers at its next 5 ms tick", "2");
  cli.AddChoice("frame", {"work", "tool"},
                "jog: the twist's axes: work (fixed to the base; the base frame unless a work "
                "frame is set) or tool (turning with the platform)", "work");
  cli.AddOption("velocity-m-s", "vx,vy,vz",
                "jog: the pivot's velocity in the frame's axes, m/s (the supervisor limits each axis "
                "to its jog speed, 0.05 m/s by default)", "0,0,0");
  cli.AddOption("angular-velocity-rad-s", "wx,wy,wz",
                "jog: the angular velocity in the frame's axes, rad/s (0.2 rad/s by default)", "0,0,0");
  cli.AddOption("duration-s", "s",
                "jog: how long to keep sending it; then nothing more is sent and the supervisor's "
                "dead-man (0.25 s) brings the platform to rest", "1");
  cli.AddOption("rate-hz", "hz", "jog: how often to send it (at least 10 Hz: the dead-man is 0.25 s)",
                "50");
  cli.AddOption("position-m", "x,y,z", "goal: the platform's position in the base frame, m");
  cli.AddOption("rpy-deg", "roll,pitch,yaw",
                "goal: the platform's orientation, degrees (R = Rz(yaw) Ry(pitch) Rx(roll))", "0,0,0");
  cli.AddOption("quaternion", "w,x,y,z", "goal: the orientation as a unit quaternion instead of --rpy-deg");
  cli.AddOption("pivot-m", "x,y,z",
                "frames: the pivot point (the centre of every rotation of jog, goals and streams) in "
                "the platform frame, m; 0,0,0 is the platform origin (the supervisor allows up to "
                "0.5 m)");
  cli.AddOption("tool-position-m", "x,y,z", "frames: the tool frame's origin in the platform frame, m",
                "0,0,0");
  cli.AddOption("tool-rpy-deg", "roll,pitch,yaw",
                "frames: the tool frame's orientation in the platform frame, degrees", "0,0,0");
  cli.AddOption("work-position-m", "x,y,z",
                "frames: the work frame's origin in the base frame, m (the supervisor allows up to 1 m)",
                "0,0,0");
  cli.AddOption("work-rpy-deg", "roll,pitch,yaw",
                "frames: the work frame's orientation in the base frame, degrees", "0,0,0");
  cli.AllowPositional("start|stop|reset|home|shutdown|estop|jog|goal|stream|frames", 1);
}

// "a,b,c" -> N finite numbers; false with `error` naming the option.
template <std::size_t N>
bool ParseList(const std::string& option, const std::string& text, double (&out)[N], std::string& error) {
  std::size_t pos = 0;
  for (std::size_t k = 0; k < N; ++k) {
    const std::size_t comma = text.find(',', pos);
    const std::string item = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    char* end = nullptr;
    out[k] = std::strtod(item.c_str(), &end);
    if (item.empty() || end == item.c_str() || *end != '\0' || !std::isfinite(out[k]) ||
        (k + 1 < N) == (comma == std::string::npos)) {
      error = "--" + option + " '" + text + "': expected " + std::to_string(N) +
              " finite numbers separated by commas";
      return false;
    }
    pos = comma + 1;
  }
  return true;
}

// "roll,pitch,yaw" in degrees (R = Rz(yaw) Ry(pitch) Rx(roll)) -> a unit quaternion w, x, y, z.
bool QuaternionFromRpyDeg(const std::string& option, const std::string& text, double (&q_wxyz)[4],
                          std::string& error) {
  double rpy_deg[3];
  if (!ParseList(option, text, rpy_deg, error)) return false;
  const Eigen::Vector3d rpy_rad = Eigen::Vector3d(rpy_deg[0], rpy_deg[1], rpy_deg[2]) * (M_PI / 180.0);
  const Eigen::Quaterniond q(hexa::RotationFromRollPitchYaw(rpy_rad));
  q_wxyz[0] = q.w();
  q_wxyz[1] = q.x();
  q_wxyz[2] = q.y();
  q_wxyz[3] = q.z();
  return true;
}

// The frames' fields from the command line (checked as the supervisor checks them on sight;
// its configured bounds it checks itself). All three frames are sent: the options left out are
// the identity.
bool ReadFrames(hexa::cli::Parser& cli, hexa_msg_OperatorCommand& cmd, std::string& error) {
  if (!cli.Has("pivot-m"))
    return (error = "frames needs --pivot-m x,y,z (0,0,0: the platform origin)", false);
  if (!ParseList("pivot-m", cli.Get("pivot-m"), cmd.pivot_m, error) ||
      !ParseList("tool-position-m", cli.Get("tool-position-m"), cmd.tool_position_m, error) ||
      !QuaternionFromRpyDeg("tool-rpy-deg", cli.Get("tool-rpy-deg"), cmd.tool_orientation_wxyz, error) ||
      !ParseList("work-position-m", cli.Get("work-position-m"), cmd.work_position_m, error) ||
      !QuaternionFromRpyDeg("work-rpy-deg", cli.Get("work-rpy-deg"), cmd.work_orientation_wxyz, error))
    return false;
  char why[160] = "";
  hexa::UserFramesConfig frames;
  if (!hexa::wire::FramesFromWire(cmd, frames, why)) return (error = why, false);
  return true;
}

// The jog's or the goal's fields from the command line (checked as the supervisor checks them).
bool ReadMotion(hexa::cli::Parser& cli, Request& r, std::string& error) {
  hexa_msg_OperatorCommand& cmd = r.cmd;
  char why[160] = "";
  if (r.what == "jog") {
    const auto duration = cli.GetDouble("duration-s", 0, 3600);
    const auto rate = cli.GetDouble("rate-hz", 10, 1000);
    if (!duration || !rate) return (error = cli.error(), false);
    r.jog_duration_s = *duration;
    r.jog_rate_hz = *rate;
    r.linger_s = 0;  // the stream follows at once: a linger would let the dead-man stop it
    cmd.jog_frame = cli.Get("frame") == "tool" ? hexa_msg_JOG_FRAME_TOOL : hexa_msg_JOG_FRAME_WORK;
    if (!ParseList("velocity-m-s", cli.Get("velocity-m-s"), cmd.jog_velocity_m_s, error) ||
        !ParseList("angular-velocity-rad-s", cli.Get("angular-velocity-rad-s"),
                   cmd.jog_angular_velocity_rad_s, error))
      return false;
    hexa::JogRequest jog;
    if (!hexa::wire::JogFromWire(cmd, jog, why)) return (error = why, false);
    return true;
  }
  if (!cli.Has("position-m")) return (error = "goal needs --position-m x,y,z", false);
  if (!ParseList("position-m", cli.Get("position-m"), cmd.goal_position_m, error)) return false;
  if (cli.Has("quaternion")) {
    if (!ParseList("quaternion", cli.Get("quaternion"), cmd.goal_orientation_wxyz, error)) return false;
  } else if (!QuaternionFromRpyDeg("rpy-deg", cli.Get("rpy-deg"), cmd.goal_orientation_wxyz, error)) {
    return false;
  }
  hexa::Pose goal;
  if (!hexa::wire::GoalFromWire(cmd, goal, why)) return (error = why, false);
  return true;
}

// Reads the command line into `r`: -1 to go on, else the exit code (help, usage error).
int ReadRequest(hexa::cli::Parser& cli, int argc, char** argv, Request& r) {
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto domain = cli.GetInt("domain", 0, 230);
  const auto wait_s = cli.GetDouble("wait", 0, 600);
  const auto linger_s = cli.GetDouble("linger", 0, 60);
  const auto answer_wait_s = cli.GetDouble("answer-wait", 0, 600);
  if (!domain || !wait_s || !linger_s || !answer_wait_s || cli.positional().size() != 1) {
    std::fprintf(stderr, "error: %s\n(see --help)\n",
                 cli.error().empty() ? "exactly one command is required" : cli.error().c_str());
    return exit_code::kUsage;
  }
  r.domain = static_cast<int>(*domain);
  r.wait_s = *wait_s;
  r.linger_s = *linger_s;
  r.answer_wait_s = *answer_wait_s;
  r.any_reader = cli.Get("to") == "any-reader";
  r.what = cli.positional()[0];
  hexa_msg_OperatorCommand& cmd = r.cmd;
  const std::string& what = r.what;
  if (what == "start") cmd.kind = hexa_msg_OPERATOR_START;
  else if (what == "stop") cmd.kind = hexa_msg_OPERATOR_STOP;
  else if (what == "reset") cmd.kind = hexa_msg_OPERATOR_RESET;
  else if (what == "home") cmd.kind = hexa_msg_OPERATOR_HOME;
  else if (what == "shutdown") cmd.kind = hexa_msg_OPERATOR_SHUTDOWN;
  else if (what == "estop") cmd.kind = hexa_msg_OPERATOR_ESTOP;
  else if (what == "jog") cmd.kind = hexa_msg_OPERATOR_JOG;
  else if (what == "goal") cmd.kind = hexa_msg_OPERATOR_GOAL;
  else if (what == "stream") cmd.kind = hexa_msg_OPERATOR_STREAM;
  else if (what == "frames") cmd.kind = hexa_msg_OPERATOR_FRAMES;
  else {
    std::fprintf(stderr, "error: unknown command '%s' (start stop reset home shutdown estop jog goal "
                 "stream frames)\n", what.c_str());
    return exit_code::kUsage;
  }
  if (what == "jog" || what == "goal" || what == "frames") {
    std::string error;
    if (!(what == "frames" ? ReadFrames(cli, cmd, error) : ReadMotion(cli, r, error))) {
      std::fprintf(stderr, "error: %s\n(see --help)\n", error.c_str());
      return exit_code::kUsage;
    }
  }
  // A CSV path must reach the supervisor exactly: refuse what the wire cannot carry unchanged
  // (OperatorCommand.csv_path is an IDL string<256>, recorded as a proto3 string: UTF-8).
  const std::string traj = cli.Get("trajectory");
  if (!hexa::text::IsClean(traj, sizeof(cmd.csv_path) - 1)) {
    std::fprintf(stderr,
                 "error: --trajectory '%s': a CSV path must be valid UTF-8 without control "
                 "characters and at most %zu bytes (it is %zu bytes)\n",
                 hexa::text::Excerpt(traj).c_str(), sizeof(cmd.csv_path) - 1, traj.size());
    return exit_code::kUsage;
  }
  const bool is_named = traj == "x" || traj == "y" || traj == "z" || traj == "roll" ||
                        traj == "pitch" || traj == "yaw" || traj == "combined";
  hexa::node::CopyBounded(cmd.trajectory, is_named ? traj.c_str() : "csv");
  if (!is_named) hexa::node::CopyBounded(cmd.csv_path, traj.c_str());
  return -1;
}

// Writes the command once the supervisor's reader (or any reader) matched, and waits for every
// matched reader's acknowledgement: -1 when acknowledged and the supervisor's answer is to be
// awaited, else the exit code.
int SendAcknowledged(Request& r, const hexa::comm::Participant& participant,
                     hexa::comm::Writer<hexa_msg_OperatorCommand>& writer, spdlog::logger& log) {
  hexa::comm::WaitSet ws(participant);
  const int64_t end = hexa::node::MonotonicNow_ns() + static_cast<int64_t>(r.wait_s * 1e9);
  // The supervisor's reader, not any: a recorder (or another tool) reading the topic may
  // match first, and a command written before the supervisor's reader matched never reaches
  // it (volatile). Between secured hosts each new participant's handshakes with the peers
  // complete one by one: the recorder's often first (docs/measurements/deployment.md).
  while (r.any_reader ? writer.Snapshot().publication_matched_current == 0
                      : hexa::comm::CountMatchedReadersWithUserData(writer.get(),
                                                                     hexa::comm::kSupervisorCommandReader) == 0) {
    if (hexa::node::MonotonicNow_ns() > end) {
      log.error("no supervisor on domain {} within {} s ({} other reader(s) of the command topic matched)",
                r.domain, r.wait_s, writer.Snapshot().publication_matched_current);
      return exit_code::kRunError;
    }
    ws.Wait(DDS_MSECS(20));
  }
  // The plant acts on a start or home (the hardware's activation, docs/faults.md "Hardware
  // lifecycle"), a reset (the e-stop latch's reset) and an e-stop: its reader too, for up to
  // 2 s more (a plant that does not have a start lets the supervisor refuse it, naming the
  // plant's silence).
  const auto kind = r.cmd.kind;
  if (!r.any_reader && (kind == hexa_msg_OPERATOR_START || kind == hexa_msg_OPERATOR_HOME ||
                        kind == hexa_msg_OPERATOR_RESET || kind == hexa_msg_OPERATOR_ESTOP)) {
    const int64_t plant_end = hexa::node::MonotonicNow_ns() + 2'000'000'000LL;
    while (hexa::comm::CountMatchedReadersWithUserData(writer.get(), hexa::services::kPlantCommandReader) == 0 &&
           hexa::node::MonotonicNow_ns() < plant_end)
      ws.Wait(DDS_MSECS(20));
  }
  writer.WriteNow(r.cmd);
  // Reliable delivery before the participant goes away. The wait counts only readers that
  // have answered a heartbeat; one whose side of the match completes after the write gets
  // the sample by a repair request after the next heartbeat (10 ms), while this writer
  // still exists.
  dds_wait_for_acks(writer.get(), DDS_SECS(2));
  std::this_thread::sleep_for(std::chrono::duration<double>(r.linger_s));
  const bool acked = dds_wait_for_acks(writer.get(), DDS_SECS(2)) == DDS_RETCODE_OK;
  const auto matched = writer.Snapshot().publication_matched_current;
  if (!acked) {
    // Not a success: the supervisor may not have the command (exit 3, docs/exit_codes.md).
    log.error("sent {} to domain {} but it was NOT acknowledged by every matched reader "
              "({} matched) within 2 s after the {} s linger: the supervisor may not have it",
              r.what, r.domain, matched, r.linger_s);
    return exit_code::kNotAnswered;
  }
  if (r.any_reader) {
    log.info("sent {} to domain {} ({} reader(s) matched, acknowledged)", r.what, r.domain, matched);
    return exit_code::kOk;
  }
  return -1;
}

// Takes the status samples that came; the supervisor's answer to command `sequence` if one of
// them holds it (its NodeStatus detail), else kNone. With `stopping_accepts` (shutdown) the
// supervisor's STOPPING status is the answer too: it publishes its answer and, within the same
// tick, STOPPING, and a reader that takes both at once keeps only the newest of its instance.
hexa::task_space::CommandAnswer PollAnswer(hexa::comm::Reader<hexa_msg_NodeStatus>& status_reader,
                                           std::uint32_t sequence, std::string& detail,
                                           bool stopping_accepts = false) {
  using hexa::task_space::CommandAnswer;
  while (status_reader.Take() > 0) {
    for (std::size_t k = 0; k < status_reader.count(); ++k) {
      if (!status_reader.info(k).valid_data) continue;
      const auto& st = status_reader.sample(k);
      if (std::strcmp(st.node_name, "supervisor") != 0) continue;
      const CommandAnswer answer = hexa::task_space::ParseCommandAnswer(st.detail, sequence);
      if (answer != CommandAnswer::kNone) {
        detail = st.detail;
        return answer;
      }
      if (stopping_accepts && st.state == hexa_msg_NODE_STOPPING) {
        detail = std::string("is stopping (its status: ") + st.detail + ")";
        return CommandAnswer::kAccepted;
      }
    }
  }
  return CommandAnswer::kNone;
}

// The exit code for an answer (kNone: none within --answer-wait), logged.
int ExitForAnswer(const Request& r, hexa::task_space::CommandAnswer answer, const std::string& detail,
                  spdlog::logger& log) {
  using hexa::task_space::CommandAnswer;
  if (answer == CommandAnswer::kAccepted) {
    log.info("sent {} to domain {}: the supervisor {}", r.what, r.domain, detail);
    return exit_code::kOk;
  }
  if (answer != CommandAnswer::kNone) {
    log.error("sent {} to domain {}: the supervisor {} (exit 4)", r.what, r.domain, detail);
    return exit_code::kRefused;
  }
  log.error("sent {} to domain {} and it was acknowledged, but the supervisor did not answer "
            "within {} s (--answer-wait; it answers once it runs, at its next tick): it may "
            "not have acted on it (exit 3)", r.what, r.domain, r.answer_wait_s);
  return exit_code::kNotAnswered;
}

// The supervisor's answer to this command (its sequence number) in its NodeStatus detail.
int AwaitAnswer(const Request& r, const hexa::comm::Participant& participant,
                hexa::comm::Reader<hexa_msg_NodeStatus>& status_reader, spdlog::logger& log) {
  using hexa::task_space::CommandAnswer;
  hexa::comm::WaitSet answer_ws(participant);
  answer_ws.Attach(status_reader.data_condition(), 1);
  const int64_t answer_end =
      hexa::node::MonotonicNow_ns() + static_cast<int64_t>(r.answer_wait_s * 1e9);
  std::string detail;
  for (;;) {
    const CommandAnswer answer = PollAnswer(status_reader, r.cmd.sequence, detail,
                                            r.cmd.kind == hexa_msg_OPERATOR_SHUTDOWN);
    if (answer != CommandAnswer::kNone) return ExitForAnswer(r, answer, detail, log);
    if (hexa::node::MonotonicNow_ns() > answer_end) return ExitForAnswer(r, answer, detail, log);
    answer_ws.Wait(DDS_MSECS(20));
  }
}

// A jog: its first message was acknowledged; the same jog every 1 / rate until the duration is
// over, then nothing (the supervisor's dead-man brings the platform to rest). The stream does not
// wait for the supervisor's answer to the first message (the dead-man would stop the platform
// meanwhile): the answer is looked for between messages, and a refusal ends the stream.
int StreamJog(Request& r, hexa::comm::Writer<hexa_msg_OperatorCommand>& writer,
              hexa::comm::Reader<hexa_msg_NodeStatus>& status_reader, spdlog::logger& log) {
  using hexa::task_space::CommandAnswer;
  using Clock = std::chrono::steady_clock;
  const std::uint32_t first = r.cmd.sequence;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / r.jog_rate_hz));
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(r.jog_duration_s));
  const auto answer_end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(r.answer_wait_s));
  CommandAnswer answer = CommandAnswer::kNone;
  std::string detail;
  int sent = 1;
  for (auto next = start + period;; next += period) {
    if (answer == CommandAnswer::kNone) answer = PollAnswer(status_reader, first, detail);
    if (answer == CommandAnswer::kRefused || answer == CommandAnswer::kRejected) break;
    if (answer == CommandAnswer::kNone && Clock::now() > answer_end) break;
    if (next >= end) {
      if (answer != CommandAnswer::kNone) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the stream is over; the answer is due
      continue;
    }
    std::this_thread::sleep_until(next);
    ++r.cmd.sequence;
    writer.WriteNow(r.cmd);
    ++sent;
  }
  dds_wait_for_acks(writer.get(), DDS_SECS(2));
  log.info("jog: {} message(s) in {:.3f} s, then let go (the supervisor's dead-man stops the "
           "platform)", sent, std::chrono::duration<double>(Clock::now() - start).count());
  r.cmd.sequence = first;
  return ExitForAnswer(r, answer, detail, log);
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_operator",
                        "Sends an operator command to the supervisor: hexa_operator [options] "
                        "start|stop|reset|home|shutdown|estop|jog|goal|stream|frames\n"
                        "  jog: a twist of the pivot (--velocity-m-s, --angular-velocity-rad-s, "
                        "--frame) sent every 1/--rate-hz for --duration-s; at rest 0.25 s (the "
                        "dead-man) plus the braking time after the last one.\n"
                        "  goal: the platform's pose in the base frame (--position-m, --rpy-deg "
                        "or --quaternion), reached by a jerk-limited motion; refused (exit 4, "
                        "the reason logged) when it or the path to it leaves the soft limits.\n"
                        "  stream: from IDLE, the platform follows the external motion stream "
                        "(UDP packets, docs/operate.md) from where it rests, until `stop` brings it "
                        "back there; refused (exit 4) unless hexa_task_space runs with --stream.\n"
                        "  frames: the pivot point (--pivot-m, in the platform frame), the tool "
                        "frame (--tool-position-m, --tool-rpy-deg) and the work frame "
                        "(--work-position-m, --work-rpy-deg, in the base frame) for the jogs, goals "
                        "and streams from now on; all three at once (left out: the identity). The "
                        "platform does not move. Taken in IDLE or with a jog at rest; refused "
                        "(exit 4, the reason logged) while moving or beyond the supervisor's bounds "
                        "(pivot and tool origin 0.5 m, work origin 1 m); more than 2 m away is a "
                        "usage error (exit 2).\n"
                        "Exit status: 0 the supervisor accepted the command (with --to any-reader: "
                        "acknowledged by every matched reader), 1 no supervisor (with --to "
                        "any-reader: no reader) matched within --wait (or a DDS error), 2 bad "
                        "arguments, 3 not acknowledged: sent, but a matched reader did not "
                        "acknowledge it or the supervisor did not answer within --answer-wait, "
                        "4 the supervisor refused the command (not allowed in its state, e.g. "
                        "anything but reset in HOLD) or rejected it (an infeasible trajectory); "
                        "the reason is logged (docs/exit_codes.md).");
  AddOptions(cli);
  Request r;
  if (int rc = ReadRequest(cli, argc, argv, r); rc >= 0) return rc;
  auto log = hexa::logging::Init("operator");
  try {
    std::optional<std::string> dds;
    if (cli.Has("dds-config")) dds = cli.Get("dds-config");
    hexa::comm::EnsureDdsConfig(dds);
    if (!hexa::node::InstallSessionKey(cli.Has("session-key") ? cli.Get("session-key") : "", *log))
      return exit_code::kUsage;
    hexa::comm::Participant participant(static_cast<dds_domainid_t>(r.domain));
    hexa::comm::Topic<hexa_msg_OperatorCommand> topic(participant);
    hexa::comm::Writer<hexa_msg_OperatorCommand> writer(participant, topic);
    // The supervisor answers in its NodeStatus (command_answer.hpp). Created before the write
    // so that the answer cannot come before this reader exists; deep enough that status
    // samples of other nodes cannot push the answer out before it is taken.
    hexa::comm::Topic<hexa_msg_NodeStatus> status_topic(participant);
    hexa::comm::QosParams status_qos;
    status_qos.control_reader_depth = 64;
    hexa::comm::Reader<hexa_msg_NodeStatus> status_reader(
        participant, status_topic, hexa::comm::EndpointRole::kControlReader, status_qos, 64);
    r.cmd.sequence = static_cast<uint32_t>(hexa::comm::RealtimeNow_ns() & 0xffffffff);
    if (int rc = SendAcknowledged(r, participant, writer, *log); rc >= 0) return rc;
    if (r.what == "jog") return StreamJog(r, writer, status_reader, *log);
    return AwaitAnswer(r, participant, status_reader, *log);
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return exit_code::kRunError;
  }
}
