// Progress of a long step (reading a recording, a fit, a session) for the person waiting: on a
// terminal one line rewritten in place (at most 4 times a second), in a log file or a pipe a
// plain line every `log_period_s`. Written to stderr by default, so that a tool's results on
// stdout stay clean. Not for the control loop: it reads the clock and writes to a stream.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

namespace hexa::progress {

class Line {
 public:
  // `what`: the step ("report: reading session.mcap"). `is_terminal`: default from isatty.
  explicit Line(std::string what, std::FILE* out = stderr, double log_period_s = 10.0);
  Line(std::string what, std::FILE* out, double log_period_s, bool is_terminal);
  ~Line();
  Line(const Line&) = delete;
  Line& operator=(const Line&) = delete;

  // fraction in [0, 1] (< 0: unknown, only the detail and the elapsed time are shown).
  void Update(double fraction, const std::string& detail = "");
  // Ends the line: "<what>: done in 12.3 s[, summary]". Called by the destructor if not before.
  void Done(const std::string& summary = "");
  // Erases the line on a terminal (before other output); the next Update draws it again.
  void Clear();
  // Ends without a final line (the caller reports the outcome itself).
  void Close() {
    Clear();
    done_ = true;
  }
  // Where the periodic lines go when the output is not a terminal (default: the stream), e.g.
  // a logger.
  void SetLogSink(std::function<void(const std::string&)> sink) { log_sink_ = std::move(sink); }

 private:
  void Print(double fraction, const std::string& detail, bool final_line);

  std::string what_;
  std::FILE* out_;
  double log_period_s_;
  bool terminal_;
  bool done_ = false;
  std::chrono::steady_clock::time_point start_, last_print_;
  bool printed_ = false;
  bool drawn_ = false;  // the terminal line shows a progress line now
  std::function<void(const std::string&)> log_sink_;
};

}  // namespace hexa::progress
