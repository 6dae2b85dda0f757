// hexa_session: runs one complete closed-loop session on this machine. Starts the
// recorder, the six leg controllers, the supervisor and the plant as separate processes
// on loopback DDS (own domain id), runs one trajectory, stops everything cleanly, writes
// the report, and exits 0 only if the session completed. Ctrl-C or the death of any
// process stops all of them; children die with this process even if it is SIGKILLed.
// The processes and their role arguments: deploy/session (shared with hexa_deploy generate).
#include <csignal>

#include "hexa/services/exit_code.hpp"
#include "hexa/services/logging.hpp"
#include "launcher.hpp"

int main(int argc, char** argv) {
  hexa::launcher::Options o;
  if (int rc = hexa::launcher::ParseOptions(argc, argv, o); rc >= 0) return rc;

  hexa::deploy::ProcessGroup group;  // blocks SIGINT/SIGTERM/SIGCHLD before any thread exists
  // A closed console (the terminal or the pipe reading this process's output went away) must
  // not kill the session half-way: the console lines are lost, session.log keeps everything.
  std::signal(SIGPIPE, SIG_IGN);
  auto log = hexa::logging::Init("session", o.out_dir + "/session.log");

  hexa::launcher::Launch launch;
  if (int rc = hexa::launcher::PrepareSession(o, launch, *log); rc >= 0) return rc;
  hexa::launcher::SessionEnd end = hexa::launcher::Supervise(group, o, launch, *log);
  if (end.start_failed) return hexa::exit_code::kRunError;
  return hexa::launcher::PostProcess(group, o, launch, end, *log);
}
