// hexa_task_space: the task-space supervisor (trajectory, GQFK pose estimate, Jacobian outer
// loop, safety state machine) at 5 ms.
#include <cstdio>
#include <exception>

#include "hexa/services/logging.hpp"
#include "supervisor_node.hpp"

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_task_space",
                        "Task-space supervisor: trajectories, pose estimate (IMU + GQFK, eq 47), "
                        "Jacobian outer loop (eq 48), safety state machine; 5 ms.\n"
                        "Exit status: 0 the trajectory finished (--exit-when-done) or shutdown, "
                        "1 error, 2 bad arguments, 3 peers not matched at start-up, 5 held and not "
                        "reset within --hold-timeout, 6 the operator's stop ended the motion "
                        "before the trajectory's end (docs/exit_codes.md).");
  hexa::node::AddCommonOptions(cli);
  cli.AddOption("trajectory", "name|file.csv",
                "trajectory for --autostart: x y z roll pitch yaw combined, or a CSV file",
                "combined");
  cli.AddOption("periods", "N", "periods to track (0 = the trajectory's default)", "0");
  cli.AddFlag("autostart", "start the trajectory as soon as the pose is known");
  cli.AddFlag("exit-when-done",
              "exit 0 when the trajectory has finished; 6 when an operator's stop ended it; in "
              "HOLD wait --hold-timeout for an operator reset, then exit 5");
  cli.AddOption("hold-timeout", "s",
                "--exit-when-done: simulated seconds to wait in HOLD for an operator reset "
                "(real time: wall seconds; lockstep: at the machine's pace); a reset resumes "
                "(with --autostart the trajectory starts again from the held pose)", "30");
  cli.AddOption("hold-report", "file",
                "write one line naming the fault and its cause here when the platform is held "
                "(removed on reset)");
  cli.AddFlag("no-outer-loop", "disable the task-space outer loop");
  cli.AddFlag("no-feedforward",
              "no platform inverse-dynamics feed-forward on the leg setpoints (paper-faithful)");
  cli.AddFlag("least-squares", "six-leg least-squares position estimate instead of GQFK");
  cli.AddOption("startup-timeout", "s", "peers must match within this", "30");
  cli.AddOption("pose-readers", "N",
                "readers of the pose reports to match before running (1 with a recorder, so "
                "that the recording has the first report)", "0");
  cli.AddChoice("fault", {"none", "crash"},
                "fault injection (docs/faults.md): crash = SIGKILL at --fault-at", "none");
  cli.AddOption("fault-at", "s", "simulated time at which the fault starts", "0");
  const bool parsed = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, parsed); rc >= 0) return rc;
  hexa::task_space::SupervisorNodeOptions o;
  const auto periods = cli.GetInt("periods", 0, 1000);
  const auto startup = cli.GetDouble("startup-timeout", 0.1, 3600);
  const auto pose_readers = cli.GetInt("pose-readers", 0, 16);
  const auto fault_at = cli.GetDouble("fault-at", 0, 1e7);
  const auto hold_timeout = cli.GetDouble("hold-timeout", 0.001, 1e6);
  if (!hexa::node::ReadCommonOptions(cli, o.common) || !periods || !startup || !pose_readers ||
      !fault_at || !hold_timeout) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", cli.error().c_str());
    return 2;
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
  o.pose_readers = static_cast<int>(*pose_readers);
  if (cli.Get("fault") == "crash") o.crash_at_s = *fault_at;

  auto log = hexa::logging::Init("supervisor", o.common.log_file, o.common.log_level);
  try {
    hexa::comm::EnsureDdsConfig(o.common.dds_config);
    if (!hexa::node::InstallSessionKey(o.common.session_key_path, *log)) return 2;
    auto config = hexa::node::LoadConfig(o.common, *log);
    if (!config) return 1;
    // Before the participant exists: Cyclone's threads inherit the policy (docs/platform_notes.md).
    auto latency_hold = hexa::node::ApplyScheduling(o.common, 75, *log);
    hexa::task_space::SupervisorNode node(o, *config, log);
    const int rc = node.Run();
    // The loop is over: its teardown must not starve the processes still running (real time).
    hexa::node::LeaveRealtimeScheduling(o.common, latency_hold, *log);
    return rc;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
}
