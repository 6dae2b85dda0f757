#include "hexa/services/logging.hpp"

#include <vector>

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include "hexa/services/text.hpp"

namespace hexa::logging {
namespace {

constexpr const char* kPattern = "%Y-%m-%d %H:%M:%S.%e [%n] %^%l%$ %v";

// Every message passes through text::Sanitize before the pattern is applied: valid UTF-8,
// no control characters but tab and line feed, at most kMaxLogLineBytes (docs/robustness.md).
// Whatever a caller formats into a message (a CSV field, a path, a DDS string from another
// process), the log line stays readable and bounded. Clean messages take the fast path.
class SanitizingFormatter final : public spdlog::formatter {
 public:
  SanitizingFormatter() : inner_(std::make_unique<spdlog::pattern_formatter>(kPattern)) {}
  explicit SanitizingFormatter(std::unique_ptr<spdlog::formatter> inner)
      : inner_(std::move(inner)) {}

  void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override {
    const std::string_view payload(msg.payload.data(), msg.payload.size());
    if (text::IsClean(payload, text::kMaxLogLineBytes, text::Newlines::kKeep)) {
      inner_->format(msg, dest);
      return;
    }
    const std::string clean =
        text::Sanitize(payload, text::kMaxLogLineBytes, text::Newlines::kKeep);
    spdlog::details::log_msg copy = msg;
    copy.payload = spdlog::string_view_t(clean.data(), clean.size());
    inner_->format(copy, dest);
  }
  std::unique_ptr<spdlog::formatter> clone() const override {
    return std::make_unique<SanitizingFormatter>(inner_->clone());
  }

 private:
  std::unique_ptr<spdlog::formatter> inner_;
};

}  // namespace

std::shared_ptr<spdlog::logger> Init(const std::string& process_name,
                                     const std::string& log_file, const std::string& level) {
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!log_file.empty()) {
    sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(log_file, true));
  }
  auto logger = std::make_shared<spdlog::logger>(process_name, sinks.begin(), sinks.end());
  logger->set_formatter(std::make_unique<SanitizingFormatter>());
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
  return logger;
}

}  // namespace hexa::logging
