// The option parser shared by every hexa_recorder verb (cli.hpp), and record / play's
// stand-ins in a build without DDS.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "cli.hpp"

namespace hexa::recorder::cli {

std::string Args::Get(const std::string& name, const std::string& fallback) const {
  auto it = options.find(name);
  return it == options.end() || it->second.empty() ? fallback : it->second.back();
}

std::vector<std::string> Args::GetAll(const std::string& name) const {
  std::vector<std::string> out;
  auto it = options.find(name);
  if (it == options.end()) return out;
  for (const auto& v : it->second) {
    std::stringstream ss(v);
    std::string item;
    while (std::getline(ss, item, ','))
      if (!item.empty()) out.push_back(item);
  }
  return out;
}

double Args::GetDouble(const std::string& name, double fallback, bool allow_infinity) const {
  if (!Has(name)) return fallback;
  const std::string v = Get(name, "");
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  const bool value_ok = std::isfinite(d) || (allow_infinity && std::isinf(d) && d > 0.0);
  if (v.empty() || end == nullptr || *end != '\0' || !value_ok)
    throw UsageError("--" + name + (allow_infinity ? " expects a number or inf, got '"
                                                    : " expects a finite number, got '") +
                     v + "'");
  return d;
}

long long GetIntImpl(const Args& a, const std::string& name, long long fallback) {
  if (!a.Has(name)) return fallback;
  const std::string v = a.Get(name, "");
  char* end = nullptr;
  const long long d = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || end == nullptr || *end != '\0')
    throw UsageError("--" + name + " expects an integer, got '" + v + "'");
  return d;
}

long long Args::GetInt(const std::string& name, long long fallback) const {
  return GetIntImpl(*this, name, fallback);
}

McapCompression ParseCompressionOption(const Args& a) {
  const std::string v = a.Get("compression", "zstd");
  if (v != "none" && v != "zstd") throw UsageError("--compression must be none or zstd, got '" + v + "'");
  return ParseMcapCompression(v);
}

int ParseZstdLevelOption(const Args& a) {
  const long long level = a.GetInt("zstd-level", McapWriterConfig{}.zstd_level);
  if (level < 1 || level > 19) throw UsageError("--zstd-level must be in [1, 19]");
  return static_cast<int>(level);
}

Args ParseArgs(const std::vector<std::string>& argv, const std::set<std::string>& value_options,
               const std::set<std::string>& flag_options) {
  Args a;
  for (size_t i = 0; i < argv.size(); ++i) {
    const std::string& s = argv[i];
    if (s == "--help" || s == "-h") {
      a.help = true;
      continue;
    }
    if (s.size() >= 2 && s[0] == '-' && s[1] != '-') {
      // A single-dash option would otherwise be taken for a file name.
      const std::string name = s.substr(1, s.find('=') == std::string::npos ? std::string::npos
                                                                             : s.find('=') - 1);
      const bool known = value_options.count(name) > 0 || flag_options.count(name) > 0;
      throw UsageError("unknown option '" + s + "'" +
                       (known ? " (options take two dashes: --" + name + ")" : std::string()));
    }
    if (s.rfind("--", 0) != 0 || s == "--") {
      a.positional.push_back(s);
      continue;
    }
    std::string name = s.substr(2), value;
    const auto eq = name.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    if (flag_options.count(name)) {
      if (inline_value) throw UsageError("option --" + name + " takes no value");
      a.options[name].push_back("");
    } else if (value_options.count(name)) {
      if (!inline_value) {
        if (i + 1 >= argv.size()) throw UsageError("option --" + name + " needs a value");
        value = argv[++i];
      }
      a.options[name].push_back(value);
    } else {
      throw UsageError("unknown option '" + s + "'");
    }
  }
  return a;
}

bool PrintHelp(const Args& a, const char* text) {
  if (a.help) std::fputs(text, stdout);
  return a.help;
}
void NeedPositionals(const Args& a, size_t n, const char* what) {
  if (a.positional.size() != n) throw UsageError(std::string("expected ") + what);
}

#ifndef HEXA_RECORDER_HAVE_DDS
int RunRecord(const std::vector<std::string>&) {
  throw std::runtime_error("this build has no DDS support (comm layer hexa_comm missing)");
}
int RunPlay(const std::vector<std::string>&) {
  throw std::runtime_error("this build has no DDS support (comm layer hexa_comm missing)");
}
#endif

}  // namespace hexa::recorder::cli
