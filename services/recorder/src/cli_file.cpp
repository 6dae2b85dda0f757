// File subcommands of hexa_recorder: info, export, recover, diff (no DDS involved).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "cli.hpp"
#include "hexa/recording/recording.hpp"

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

namespace {
bool PrintHelp(const Args& a, const char* text) {
  if (a.help) std::fputs(text, stdout);
  return a.help;
}
void NeedPositionals(const Args& a, size_t n, const char* what) {
  if (a.positional.size() != n) throw UsageError(std::string("expected ") + what);
}
}  // namespace

int RunInfo(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {}, {"tolerant", "no-crc"});
  if (PrintHelp(a,
                "usage: hexa_recorder info FILE.mcap [--tolerant] [--no-crc]\n"
                "Prints duration, channels (topic, type, QoS metadata), message counts, rates, the\n"
                "largest log-time gap, and loss per topic and instance from tick numbers (periodic\n"
                "topics: a tick difference of k expected steps = k-1 missing samples).\n"
                "  --tolerant  read a truncated file up to its last intact chunk instead of failing\n"
                "  --no-crc    skip CRC verification\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one recording file");
  McapScanOptions o;
  o.tolerant = a.Has("tolerant");
  o.verify_crcs = !a.Has("no-crc");
  const RecordingInfo info = Inspect(a.positional[0], o);
  std::fputs(FormatInfo(info).c_str(), stdout);
  return kExitOk;
}

int RunExport(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"out-dir", "topics", "exclude"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder export FILE.mcap --out-dir DIR [--topics GLOB,..] "
                "[--exclude GLOB,..]\n"
                "Writes DIR/<topic>.csv per topic: log_time_ns, publish_time_ns, sequence, then\n"
                "every message field (nested as a.b, repeated as name[i], enums by name, doubles\n"
                "with 17 significant digits).\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one recording file");
  if (!a.Has("out-dir")) throw UsageError("--out-dir DIR is required");
  TopicFilter f{a.GetAll("topics"), a.GetAll("exclude")};
  const ExportResult r = ExportCsv(a.positional[0], a.Get("out-dir", ""), f);
  for (const auto& w : r.warnings) std::fprintf(stderr, "hexa_recorder export: warning: %s\n", w.c_str());
  for (const auto& [path, rows] : r.files)
    std::printf("%s: %llu rows\n", path.c_str(), static_cast<unsigned long long>(rows));
  if (r.files.empty()) std::printf("no messages matched; no file written\n");
  return kExitOk;
}

int RunRecover(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"output", "o", "compression"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder recover DAMAGED.mcap --output FIXED.mcap "
                "[--compression none|zstd]\n"
                "Reads every intact chunk of a recording that lacks its summary and footer (e.g.\n"
                "the recorder was killed) or has corrupt chunks, and writes a complete MCAP file\n"
                "with summary, indexes and footer. Sequence numbers and times are kept. String\n"
                "fields that are not valid UTF-8 are repaired (U+FFFD). Exit status 2, and no\n"
                "output, when no intact message was found.\n"
                "Chunks of the output are zstd-compressed unless --compression none.\n"))
    return kExitOk;
  NeedPositionals(a, 1, "exactly one input file");
  const std::string out = a.Get("output", a.Get("o", ""));
  if (out.empty()) throw UsageError("--output FILE is required");
  if (out == a.positional[0]) throw UsageError("--output must differ from the input file");
  McapWriterConfig config;
  config.compression = ParseCompressionOption(a);
  const RecoverResult r = Recover(a.positional[0], out, config);
  for (const auto& p : r.problems) std::printf("problem: %s\n", p.c_str());
  const char* status = r.input_readable ? "was complete"
                       : r.input_complete ? "was complete in structure but not readable as it was"
                                          : "was incomplete";
  if (r.messages == 0) {
    // Nothing to keep: an output without messages would only look like a recovery.
    std::remove(out.c_str());
    std::fprintf(stderr,
                 "hexa_recorder recover: nothing recovered: no intact message in '%s' (input %s, "
                 "%llu chunks read, %llu corrupt chunks, %llu bytes dropped at the end); no "
                 "output written\n",
                 a.positional[0].c_str(), status, static_cast<unsigned long long>(r.chunks_read),
                 static_cast<unsigned long long>(r.bad_chunks),
                 static_cast<unsigned long long>(r.bytes_dropped));
    return kExitError;
  }
  std::printf("input %s; recovered %llu messages from %llu chunks (%llu corrupt chunks skipped, "
              "%llu bytes dropped at the end, %llu messages repaired, %llu undecodable) into %s\n",
              status, static_cast<unsigned long long>(r.messages),
              static_cast<unsigned long long>(r.chunks_read),
              static_cast<unsigned long long>(r.bad_chunks),
              static_cast<unsigned long long>(r.bytes_dropped),
              static_cast<unsigned long long>(r.repaired_messages),
              static_cast<unsigned long long>(r.undecodable_messages), out.c_str());
  return kExitOk;
}

int RunDiff(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"tolerance-v"}, {});
  if (PrintHelp(a,
                "usage: hexa_recorder diff A.mcap B.mcap [--tolerance-v V]\n"
                "Compares valve_v of the ValveCommand streams per leg, matched by tick: ticks in\n"
                "both, ticks in only one, max and RMS |A-B| in volts, first tick that differs\n"
                "(|A-B| > tolerance, default 0, or present in one file only).\n"
                "exit status: 0 identical, 1 different, 2 error\n"))
    return kExitOk;
  NeedPositionals(a, 2, "two recording files");
  const double tol = a.GetDouble("tolerance-v", 0.0);
  if (!(tol >= 0.0)) throw UsageError("--tolerance-v must be >= 0");
  const DiffReport r = DiffValveCommands(a.positional[0], a.positional[1], tol);
  std::fputs(FormatDiff(r).c_str(), stdout);
  return r.identical ? kExitOk : kExitDifferent;
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
