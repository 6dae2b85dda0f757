// hexa_task_space's command line: the common service options and the supervisor's own.
#include <cstdio>

#include "hexa/services/exit_code.hpp"
#include "hexa/services/runtime.hpp"
#include "supervisor_node.hpp"

namespace hexa::task_space {

int ParseOptions(int argc, char** argv, SupervisorNodeOptions& o) {
  cli::Parser cli("hexa_task_space",
                  "Task-space supervisor: trajectories, pose estimate (IMU + GQFK, eq 47), "
                  "Jacobian outer loop (eq 48), safety state machine; 5 ms.\n"
                  "Exit status: 0 the trajectory finished (--exit-when-done), a shutdown without "
                  "--exit-when-done, or SIGINT / SIGTERM (--end-report says which); 1 error, 2 "
                  "bad arguments, 3 peers not matched at start-up, 5 held and not reset within "
                  "--hold-timeout, 6 an operator's stop or shutdown before the trajectory's end, "
                  "or before it started (docs/exit_codes.md).");
  node::AddCommonOptions(cli);
  cli.AddOption("trajectory", "name|file.csv",
                "trajectory for --autostart: x y z roll pitch yaw combined, or a CSV file",
                "combined");
  cli.AddOption("periods", "N", "periods to track (0 = the trajectory's default)", "0");
  cli.AddFlag("autostart", "start the trajectory as soon as the pose is known");
  cli.AddFlag("exit-when-done",
              "exit 0 when the trajectory has finished; 6 when an operator's stop or shutdown "
              "came before its end (a jog, goal, stream or home does not end it); in HOLD wait "
              "--hold-timeout for an operator reset, then exit 5");
  cli.AddOption("hold-timeout", "s",
                "--exit-when-done: simulated seconds to wait in HOLD for an operator reset "
                "(real time: wall seconds; lockstep: at the machine's pace); a reset resumes "
                "(with --autostart the trajectory starts again from the held pose)", "30");
  cli.AddOption("hold-report", "file",
                "write one line naming the fault and its cause here when the platform is held "
                "(removed on reset)");
  cli.AddOption("end-report", "file",
                "--exit-when-done: write one line here saying how the session ended (the "
                "trajectory finished; stopped or shut down by the operator, and when; held; "
                "stopped by a signal)");
  cli.AddFlag("no-outer-loop", "disable the task-space outer loop");
  cli.AddFlag("no-feedforward",
              "no platform inverse-dynamics feed-forward on the leg setpoints (paper-faithful)");
  cli.AddFlag("least-squares", "six-leg least-squares position estimate instead of GQFK");
  cli.AddOption("startup-timeout", "s", "peers must match within this", "30");
  cli.AddOption("pose-readers", "N",
                "readers of the pose reports to match before running (1 with a recorder, so "
                "that the recording has the first report)", "0");
  cli.AddFlag("stream",
              "accept the external motion stream (docs/operate.md) on UDP: the operator's "
              "`stream` command then moves the platform as the packets say; off: it is refused");
  cli.AddOption("stream-address", "IPv4",
                "--stream: address to bind; anything that can send to it can move the platform",
                "127.0.0.1");
  cli.AddOption("stream-port", "port", "--stream: UDP port to bind", "47800");
  cli.AddChoice("stream-kind", {"pose", "vehicle"},
                "--stream: the packets' kind: pose (a displacement from neutral) or vehicle "
                "(accelerations and angular rates, through the classical washout)", "pose");
  cli.AddOption("washout", "file",
                "--stream-kind vehicle: the washout parameters (protobuf text, e.g. "
                "deploy/cueing/washout.textproto; default: the same values built in)");
  cli.AddChoice("activation", {"auto", "operator"},
                "the plant's hardware lifecycle (docs/faults.md, \"Hardware lifecycle\"), as "
                "hexa_plant_sim --activation: with operator, a start or home waits for the plant's "
                "answer to the activation it asks for (refused with the plant's reason), and jog, "
                "goal and stream are refused while the hardware is inactive; not with --autostart",
                "auto");
  cli.AddChoice("fault", {"none", "crash"},
                "fault injection (docs/faults.md): crash = SIGKILL at --fault-at", "none");
  cli.AddOption("fault-at", "s", "simulated time at which the fault starts", "0");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  const auto periods = cli.GetInt("periods", 0, 1000);
  const auto startup = cli.GetDouble("startup-timeout", 0.1, 3600);
  const auto pose_readers = cli.GetInt("pose-readers", 0, 16);
  const auto fault_at = cli.GetDouble("fault-at", 0, 1e7);
  const auto hold_timeout = cli.GetDouble("hold-timeout", 0.001, 1e6);
  const auto stream_port = cli.GetInt("stream-port", 1, 65535);
  if (!node::ReadCommonOptions(cli, o.common) || !periods || !startup || !pose_readers ||
      !fault_at || !hold_timeout || !stream_port) {
    return services::UsageError(cli);
  }
  o.trajectory = cli.Get("trajectory");
  o.periods = static_cast<int>(*periods);
  o.autostart = cli.Flag("autostart");
  o.exit_when_done = cli.Flag("exit-when-done");
  o.outer_loop = !cli.Flag("no-outer-loop");
  o.least_squares = cli.Flag("least-squares");
  o.feedforward = !cli.Flag("no-feedforward");
  o.startup_timeout_s = *startup;
  o.hold_timeout_s = *hold_timeout;
  if (cli.Has("hold-report")) o.hold_report_path = cli.Get("hold-report");
  if (cli.Has("end-report")) o.end_report_path = cli.Get("end-report");
  o.pose_readers = static_cast<int>(*pose_readers);
  o.stream = cli.Flag("stream");
  o.stream_endpoint.address = cli.Get("stream-address");
  o.stream_endpoint.port = static_cast<std::uint16_t>(*stream_port);
  o.stream_kind = cli.Get("stream-kind") == "vehicle" ? StreamKind::kVehicle : StreamKind::kPose;
  if (cli.Has("washout")) o.washout_path = cli.Get("washout");
  if (cli.Get("fault") == "crash") o.crash_at_s = *fault_at;
  o.operator_activation = cli.Get("activation") == "operator";
  if (o.operator_activation && o.autostart) {
    std::fprintf(stderr, "error: --autostart with --activation operator: the operator's start "
                 "activates the hardware (docs/faults.md, \"Hardware lifecycle\")\n(see --help)\n");
    return exit_code::kUsage;
  }
  return -1;
}

}  // namespace hexa::task_space
