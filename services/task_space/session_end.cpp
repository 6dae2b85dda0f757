// How a session ends, as the supervisor (--exit-when-done) tells it: the exit code
// (docs/exit_codes.md) and one line for the launcher's console and report.md (--end-report).
// A session ends when its trajectory ends (exit 0), when an operator's stop or shutdown comes
// before that (exit 6, even before the trajectory started: it did not complete), or held
// (exit 5). The operator's own motions (jog, goal, stream, home) do not end it.
#include <cstdio>
#include <string>
#include <utility>

#include "hexa/services/exit_code.hpp"
#include "supervisor_node.hpp"

namespace hexa::task_space {
namespace {

enum : unsigned { kMotionJog = 1, kMotionGoal = 2, kMotionStream = 4, kMotionHome = 8 };

// "jog / goal" for the motions that ran (no commas: report.md's header is a comma list).
std::string MotionList(unsigned motions) {
  std::string list;
  const std::pair<unsigned, const char*> names[] = {
      {kMotionJog, "jog"}, {kMotionGoal, "goal"}, {kMotionStream, "stream"}, {kMotionHome, "home"}};
  for (const auto& [bit, name] : names)
    if (motions & bit) list += std::string(list.empty() ? "" : " / ") + name;
  return list;
}

bool InTrajectoryPhase(SupervisorState s) {
  return s == SupervisorState::kBlending || s == SupervisorState::kTracking ||
         s == SupervisorState::kStopping;
}

}  // namespace

void SupervisorNode::NoteSessionMotion(double time_s) {
  const SupervisorState s = output_.state;
  if (s == SupervisorState::kJogging) operator_motions_ |= kMotionJog;
  if (s == SupervisorState::kGoal) operator_motions_ |= kMotionGoal;
  if (s == SupervisorState::kStreaming) operator_motions_ |= kMotionStream;
  const bool home_motion = homing_ && InTrajectoryPhase(s);
  if (home_motion) operator_motions_ |= kMotionHome;
  if (homing_ && !home_motion) {
    homing_ = false;
    if (s == SupervisorState::kIdle)
      log_->info("home motion at rest at t = {:.3f} s{}", time_s,
                 options_.exit_when_done ? ": the session goes on (a home is not its trajectory)" : "");
  }
  const bool operator_mode = s == SupervisorState::kJogging || s == SupervisorState::kGoal ||
                             s == SupervisorState::kStreaming;
  if (s != SupervisorState::kIdle && !operator_mode && !home_motion) left_idle_ = true;
  if (!options_.exit_when_done || !left_idle_ || s != SupervisorState::kIdle || exit_code_ >= 0)
    return;
  char line[sizeof end_line_];
  if (stopped_by_operator_) {
    std::snprintf(line, sizeof line, "stopped by the operator at trajectory time %.3f s before "
                  "the trajectory's end", stopped_at_trajectory_s_);
    log_->warn("motion ended at t = {:.3f} s: {} (exit {})", time_s, line,
               exit_code::kStoppedByOperator);
    EndSession(exit_code::kStoppedByOperator, line);
  } else {
    std::snprintf(line, sizeof line, "the trajectory finished at t = %.3f s", time_s);
    log_->info("trajectory finished at t = {:.3f} s", time_s);
    EndSession(exit_code::kOk, line);
  }
}

void SupervisorNode::EndSession(int exit_code, const char* line) {
  exit_code_ = exit_code;
  std::snprintf(end_line_, sizeof end_line_, "%s", line);
}

void SupervisorNode::EndByShutdown() {
  char line[sizeof end_line_];
  const SupervisorState s = output_.state;
  if (s == SupervisorState::kHold) {
    std::snprintf(line, sizeof line, "shut down by the operator while held (%s)", hold_line_);
  } else if (stopped_by_operator_) {
    std::snprintf(line, sizeof line, "stopped by the operator at trajectory time %.3f s (then "
                  "shut down) before the trajectory's end", stopped_at_trajectory_s_);
  } else if (left_idle_) {
    std::snprintf(line, sizeof line, "shut down by the operator at trajectory time %.3f s (%s) "
                  "before the trajectory's end", output_.trajectory_time_s, ToString(s));
  } else if (trajectory_started_) {
    std::snprintf(line, sizeof line, "shut down by the operator after a reset from HOLD before "
                  "the trajectory ran again to its end");
  } else {
    const std::string motions = MotionList(operator_motions_);
    std::snprintf(line, sizeof line, "shut down by the operator before the trajectory started%s%s%s",
                  motions.empty() ? "" : " (operator motions only: ", motions.c_str(),
                  motions.empty() ? "" : ")");
  }
  log_->warn("{} (state {}; exit {})", line, ToString(s), exit_code::kStoppedByOperator);
  EndSession(exit_code::kStoppedByOperator, line);
}

void SupervisorNode::WriteEndReport() const {
  if (options_.end_report_path.empty() || end_line_[0] == '\0') return;
  const std::string tmp = options_.end_report_path + ".tmp";
  if (FILE* f = std::fopen(tmp.c_str(), "w")) {
    const bool ok = std::fprintf(f, "%s\n", end_line_) > 0;
    if (std::fclose(f) == 0 && ok) std::rename(tmp.c_str(), options_.end_report_path.c_str());
  } else {
    log_->error("cannot write the end report {}", options_.end_report_path);
  }
}

}  // namespace hexa::task_space
