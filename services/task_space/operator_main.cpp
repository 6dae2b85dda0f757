// hexa_operator: sends one operator command to the supervisor (reliable, keep-all).
#include <chrono>
#include <cstdio>
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
#include "hexa/services/text.hpp"

namespace {

namespace exit_code = hexa::exit_code;

// One command to send, read from the command line.
struct Request {
  int domain = 0;
  double wait_s = 0, linger_s = 0, answer_wait_s = 0;
  std::string what;  // start stop reset home shutdown estop
  bool any_reader = false;
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
  cli.AllowPositional("start|stop|reset|home|shutdown|estop", 1);
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
  else {
    std::fprintf(stderr, "error: unknown command '%s' (start stop reset home shutdown estop)\n",
                 what.c_str());
    return exit_code::kUsage;
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

// The supervisor's answer to this command (its sequence number) in its NodeStatus detail.
int AwaitAnswer(const Request& r, const hexa::comm::Participant& participant,
                hexa::comm::Reader<hexa_msg_NodeStatus>& status_reader, spdlog::logger& log) {
  using hexa::task_space::CommandAnswer;
  hexa::comm::WaitSet answer_ws(participant);
  answer_ws.Attach(status_reader.data_condition(), 1);
  const int64_t answer_end =
      hexa::node::MonotonicNow_ns() + static_cast<int64_t>(r.answer_wait_s * 1e9);
  for (;;) {
    while (status_reader.Take() > 0) {
      for (std::size_t k = 0; k < status_reader.count(); ++k) {
        if (!status_reader.info(k).valid_data) continue;
        const auto& st = status_reader.sample(k);
        if (std::strcmp(st.node_name, "supervisor") != 0) continue;
        const std::string detail = st.detail;
        const CommandAnswer answer = hexa::task_space::ParseCommandAnswer(detail, r.cmd.sequence);
        if (answer == CommandAnswer::kAccepted) {
          log.info("sent {} to domain {}: the supervisor {}", r.what, r.domain, detail);
          return exit_code::kOk;
        }
        if (answer != CommandAnswer::kNone) {
          log.error("sent {} to domain {}: the supervisor {} (exit 4)", r.what, r.domain, detail);
          return exit_code::kRefused;
        }
      }
    }
    if (hexa::node::MonotonicNow_ns() > answer_end) break;
    answer_ws.Wait(DDS_MSECS(20));
  }
  log.error("sent {} to domain {} and it was acknowledged, but the supervisor did not answer "
            "within {} s (--answer-wait; it answers once it runs, at its next tick): it may "
            "not have acted on it (exit 3)", r.what, r.domain, r.answer_wait_s);
  return exit_code::kNotAnswered;
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_operator",
                        "Sends an operator command to the supervisor: hexa_operator [options] "
                        "start|stop|reset|home|shutdown\n"
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
    return AwaitAnswer(r, participant, status_reader, *log);
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return exit_code::kRunError;
  }
}
