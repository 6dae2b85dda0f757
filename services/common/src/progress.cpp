#include "hexa/services/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace hexa::progress {

Line::Line(std::string what, std::FILE* out, double log_period_s)
    : Line(std::move(what), out, log_period_s, ::isatty(::fileno(out)) == 1) {}

Line::Line(std::string what, std::FILE* out, double log_period_s, bool is_terminal)
    : what_(std::move(what)),
      out_(out),
      log_period_s_(log_period_s),
      terminal_(is_terminal),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

Line::~Line() { Done(); }

void Line::Update(double fraction, const std::string& detail) {
  if (done_) return;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_print_).count();
  if (since < (terminal_ ? 0.25 : log_period_s_)) return;
  last_print_ = now;
  Print(fraction, detail, false);
}

void Line::Done(const std::string& summary) {
  if (done_) return;
  done_ = true;
  // A step that finished before its first progress line needs no "done" line on a log.
  if (!terminal_ && !printed_ && summary.empty()) return;
  Print(1.0, summary, true);
}

void Line::Clear() {
  if (!terminal_ || !drawn_) return;
  std::fprintf(out_, "\r\033[K");
  std::fflush(out_);
  drawn_ = false;
}

void Line::Print(double fraction, const std::string& detail, bool final_line) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  char head[96];
  if (final_line) {
    std::snprintf(head, sizeof head, "done in %.1f s", elapsed);
  } else if (fraction >= 0) {
    const double f = std::clamp(fraction, 0.0, 1.0);
    // Remaining time from the mean rate so far, once there is something to go on.
    if (f > 0.02 && elapsed > 1.0)
      std::snprintf(head, sizeof head, "%3.0f %% after %.0f s, about %.0f s left", 100 * f, elapsed,
                    elapsed * (1 - f) / f);
    else
      std::snprintf(head, sizeof head, "%3.0f %% after %.0f s", 100 * f, elapsed);
  } else {
    std::snprintf(head, sizeof head, "%.0f s", elapsed);
  }
  std::string line = what_ + ": " + head + (detail.empty() ? "" : ", " + detail);
  if (terminal_) {
    std::fprintf(out_, "\r\033[K%s%s", line.c_str(), final_line ? "\n" : "");
    drawn_ = !final_line;
  } else if (log_sink_) {
    log_sink_(line);
    printed_ = true;
    return;
  } else {
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
  printed_ = true;
}

}  // namespace hexa::progress
