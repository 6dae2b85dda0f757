#include "hexa/services/cli.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace hexa::cli {

Parser::Parser(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {
  AddFlag("help", "print this help and exit");
}

void Parser::AddOption(const std::string& name, const std::string& value_name,
                       const std::string& help, std::optional<std::string> default_value) {
  order_.push_back(name);
  specs_[name] = Spec{value_name, help, std::move(default_value), {}, false};
}

void Parser::AddChoice(const std::string& name, const std::vector<std::string>& choices,
                       const std::string& help, const std::string& default_value) {
  std::string value_name;
  for (const auto& c : choices) value_name += (value_name.empty() ? "" : "|") + c;
  order_.push_back(name);
  specs_[name] = Spec{value_name, help, default_value, choices, false};
}

void Parser::AddFlag(const std::string& name, const std::string& help) {
  order_.push_back(name);
  specs_[name] = Spec{"", help, std::nullopt, {}, true};
}

void Parser::AddRepeatable(const std::string& name, const std::string& value_name,
                           const std::string& help) {
  order_.push_back(name);
  Spec spec{value_name, help + " (repeatable)", std::nullopt, {}, false};
  spec.repeatable = true;
  specs_[name] = spec;
}

void Parser::AllowPositional(const std::string& usage, std::size_t max_count) {
  positional_usage_ = usage;
  max_positional_ = max_count;
}

bool Parser::Parse(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "-h") arg = "--help";
    if (arg.size() >= 2 && arg[0] == '-' && arg[1] != '-') {
      // "-trajectory x" would otherwise be a positional word and silently ignored.
      std::string name = arg.substr(1);
      name = name.substr(0, name.find('='));
      error_ = "unknown option '" + arg + "'";
      if (specs_.count(name)) error_ += " (options take two dashes: --" + name + ")";
      return false;
    }
    if (arg.rfind("--", 0) != 0 || arg == "--") {
      if (positional_.size() >= max_positional_) {
        error_ = "unexpected argument '" + arg + "'";
        if (max_positional_ == 0) error_ += " (this program takes no positional arguments)";
        else error_ += " (expected " + positional_usage_ + ")";
        return false;
      }
      positional_.push_back(arg);
      continue;
    }
    std::string name = arg.substr(2);
    std::optional<std::string> inline_value;
    if (auto eq = name.find('='); eq != std::string::npos) {
      inline_value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    auto it = specs_.find(name);
    if (it == specs_.end()) {
      error_ = "unknown option --" + name;
      return false;
    }
    if (it->second.is_flag) {
      if (inline_value) {
        error_ = "option --" + name + " takes no value";
        return false;
      }
      values_[name] = "1";
      if (name == "help") help_requested_ = true;
      continue;
    }
    std::string value;
    if (inline_value) {
      value = *inline_value;
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      error_ = "option --" + name + " needs a value (" + it->second.value_name + ")";
      return false;
    }
    const auto& choices = it->second.choices;
    if (!choices.empty() && std::find(choices.begin(), choices.end(), value) == choices.end()) {
      error_ = "option --" + name + ": '" + value + "' is not one of " + it->second.value_name;
      return false;
    }
    values_[name] = value;
    if (it->second.repeatable) all_values_[name].push_back(value);
  }
  return !help_requested_;
}

std::string Parser::Help() const {
  std::ostringstream os;
  os << "Usage: " << program_ << " [options]"
     << (positional_usage_.empty() ? "" : " " + positional_usage_) << "\n"
     << summary_ << "\n\nOptions:\n";
  for (const auto& name : order_) {
    const Spec& s = specs_.at(name);
    std::string left = "  --" + name + (s.is_flag ? "" : " <" + s.value_name + ">");
    os << left;
    if (left.size() < 34) os << std::string(34 - left.size(), ' ');
    else os << "\n" << std::string(34, ' ');
    os << s.help;
    if (s.default_value) os << " (default: " << *s.default_value << ")";
    os << "\n";
  }
  return os.str();
}

bool Parser::Has(const std::string& name) const {
  if (values_.count(name)) return true;
  auto it = specs_.find(name);
  return it != specs_.end() && it->second.default_value.has_value();
}

bool Parser::Flag(const std::string& name) const { return values_.count(name) > 0; }

std::string Parser::Get(const std::string& name) const {
  if (auto it = values_.find(name); it != values_.end()) return it->second;
  auto it = specs_.find(name);
  if (it != specs_.end() && it->second.default_value) return *it->second.default_value;
  return {};
}

bool Parser::Fail(const std::string& message) {
  error_ = message;
  return false;
}

std::vector<std::string> Parser::GetAll(const std::string& name) const {
  if (auto it = all_values_.find(name); it != all_values_.end()) return it->second;
  if (Has(name)) return {Get(name)};
  return {};
}

std::optional<long long> Parser::GetInt(const std::string& name, long long min, long long max) {
  const std::string text = Get(name);
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || errno != 0 || end == nullptr || *end != '\0') {
    error_ = "option --" + name + ": '" + text + "' is not an integer";
    return std::nullopt;
  }
  if (v < min || v > max) {
    error_ = "option --" + name + ": " + text + " is outside [" + std::to_string(min) + ", " +
             std::to_string(max) + "]";
    return std::nullopt;
  }
  return v;
}

std::optional<long long> Parser::GetIntOrWord(const std::string& name, const std::string& word,
                                             long long word_value, long long min, long long max) {
  if (Get(name) == word) return word_value;
  return GetInt(name, min, max);
}

std::optional<double> Parser::GetDouble(const std::string& name, double min, double max) {
  const std::string text = Get(name);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || errno != 0 || end == nullptr || *end != '\0' || !std::isfinite(v)) {
    error_ = "option --" + name + ": '" + text + "' is not a finite number";
    return std::nullopt;
  }
  if (v < min || v > max) {
    std::ostringstream os;
    os << "option --" << name << ": " << text << " is outside [" << min << ", " << max << "]";
    error_ = os.str();
    return std::nullopt;
  }
  return v;
}

int HandleParseResult(const Parser& parser, bool ok) {
  if (parser.help_requested()) {
    std::fputs(parser.Help().c_str(), stdout);
    return 0;
  }
  if (!ok) {
    std::fprintf(stderr, "error: %s\n(see --help)\n", parser.error().c_str());
    return 2;
  }
  return -1;
}

bool ParseLegList(const std::string& text, std::vector<int>& legs) {
  legs.clear();
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) {
    const auto dash = part.find('-');
    char* end = nullptr;
    const long a = std::strtol(part.c_str(), &end, 10);
    long b = a;
    if (dash != std::string::npos && end == part.c_str() + dash) {
      b = std::strtol(part.c_str() + dash + 1, &end, 10);
    }
    if (part.empty() || end == nullptr || *end != '\0' || a < 1 || b > 6 || b < a) {
      legs.clear();
      return false;
    }
    for (long l = a; l <= b; ++l) legs.push_back(static_cast<int>(l));
  }
  std::sort(legs.begin(), legs.end());
  legs.erase(std::unique(legs.begin(), legs.end()), legs.end());
  return !legs.empty();
}

}  // namespace hexa::cli
