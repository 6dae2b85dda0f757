// After the session: every process stopped in order, processes.json, then the recording
// recovered (a recorder that did not close it), the identification's session info attached,
// or the report written; and the session's exit code (docs/exit_codes.md).
#include <sys/statvfs.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <google/protobuf/text_format.h>

#include "child_progress.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/services/exit_code.hpp"
#include "hexa/services/json.hpp"
#include "hexa/services/progress.hpp"
#include "identification.pb.h"
#include "launcher.hpp"

namespace hexa::launcher {
namespace {

namespace fs = std::filesystem;
using deploy::ChildExit;
using deploy::ChildSpec;
using deploy::ProcessGroup;

// CPU time of every process over its whole life (start-up and discovery included), per
// simulated second when the plant's summary says how much was simulated: `processes.json`
// and a table in the log (docs/performance.md).
void WriteProcessTable(const std::string& out_dir, const std::vector<hexa::deploy::ChildExit>& exits,
                       double wall_s, spdlog::logger& log) {
  double sim_s = 0.0;
  {
    std::ifstream summary(out_dir + "/plant.json");
    const auto plant = hexa::json::Value::parse(summary, nullptr, false);  // no summary: 0
    if (plant.is_object() && plant.contains("sim_time_s") && plant["sim_time_s"].is_number())
      sim_s = plant["sim_time_s"].get<double>();
  }
  hexa::json::Value json = {{"wall_time_s", wall_s}, {"sim_time_s", sim_s},
                            {"processes", hexa::json::Value::array()}};
  double user = 0, sys = 0;
  std::string table;
  for (std::size_t k = 0; k < exits.size(); ++k) {
    const auto& e = exits[k];
    user += e.cpu_user_s;
    sys += e.cpu_system_s;
    json["processes"].push_back({{"name", e.name},
                                 {"cpu_user_s", e.cpu_user_s},
                                 {"cpu_system_s", e.cpu_system_s},
                                 {"max_rss_kb", e.max_rss_kb}});
    char line[160];
    std::snprintf(line, sizeof line, "\n  %-16s user %7.3f s  system %7.3f s", e.name.c_str(),
                  e.cpu_user_s, e.cpu_system_s);
    table += line;
    if (sim_s > 0) {
      std::snprintf(line, sizeof line, "  = %.3f s per simulated s",
                    (e.cpu_user_s + e.cpu_system_s) / sim_s);
      table += line;
    }
  }
  json["cpu_user_s"] = user;
  json["cpu_system_s"] = sys;
  std::string error;
  if (!hexa::json::WriteFile(out_dir + "/processes.json", json, 2, error)) log.error("{}", error);
  log.info("CPU time per process (whole life, start-up included):{}\n  {:<16} user {:7.3f} s  "
           "system {:7.3f} s{}",
           table, "all", user, sys,
           sim_s > 0 ? fmt::format("  = {:.3f} s per simulated s ({:.3f} s simulated)",
                                   (user + sys) / sim_s, sim_s)
                     : std::string());
}

// The samples the recording lost, as the report counted them (report.json,
// "recording_lost_samples"); 0 when there is no report.
long long ReadReportLostSamples(const std::string& out_dir) {
  std::ifstream in(out_dir + "/report.json");
  const hexa::json::Value report = hexa::json::Value::parse(in, nullptr, false);
  if (!report.is_object() || !report.contains("recording_lost_samples") ||
      !report["recording_lost_samples"].is_number())
    return 0;
  return report["recording_lost_samples"].get<long long>();
}

// "N MB free of M MB on the file system of DIR", for messages about write errors.
std::string FreeSpaceOf(const std::string& dir) {
  struct statvfs st {};
  if (statvfs(dir.c_str(), &st) != 0) return "free space of " + dir + " unknown";
  const double unit = static_cast<double>(st.f_frsize);
  char text[160];
  std::snprintf(text, sizeof text, "%.1f MB free of %.1f MB on the file system of ",
                static_cast<double>(st.f_bavail) * unit * 1e-6,
                static_cast<double>(st.f_blocks) * unit * 1e-6);
  return text + dir;
}

// Stop order: plant first (the clock), then controllers, recorder last so that it records
// everything the others published. False if a process did not stop cleanly.
bool StopEveryProcess(ProcessGroup& group, const Options& o, SessionEnd& end,
                      spdlog::logger& log) {
  bool clean = true;
  auto report_exit = [&](const ChildExit& e) {
    end.exits.push_back(e);
    const bool ok = e.signal == 0 && e.exit_code == exit_code::kOk;
    if (!ok) clean = false;
    if (e.name == "recorder") end.recorder_clean = ok;
    (ok ? log.info("{}", e.Describe()) : log.error("{}", e.Describe()));
  };
  auto stop = [&](const std::string& name) {
    if (!group.Running(name)) return;
    if (auto e = group.Stop(name, std::chrono::milliseconds(5000))) report_exit(*e);
  };
  if (o.recorder && !group.Running("recorder")) {
    // The recorder died: there is nothing left to record, so the others stop together. One
    // by one took ~10 s: each process needs about a second per DDS writer to delete it while
    // its reliable samples to the dead recorder stay unacknowledged (Cyclone lingers on them).
    log.warn("the recorder is gone: stopping the other processes together");
    for (const auto& e : group.StopTogether(group.RunningNames(), std::chrono::milliseconds(5000)))
      report_exit(e);
  } else {
    stop("plant");
    stop("supervisor");
    for (const auto& name : group.RunningNames())
      if (name != "recorder" && name != "bridge") stop(name);
    stop("recorder");
    stop("bridge");
  }
  return clean;
}

// Runs a short tool (recover, report) to its end; nullopt if it could not start or this
// process was interrupted.
std::optional<ChildExit> RunTool(ProcessGroup& group, const ChildSpec& spec, spdlog::logger& log) {
  std::string err;
  if (group.Start(spec, err) < 0) {
    log.error("cannot start {}: {}", spec.name, err);
    return std::nullopt;
  }
  // Its progress lines (report: reading ..., plot_session: [k/n] ...) on ours.
  progress::Line line(spec.name, stderr, 10.0);
  line.SetLogSink([&](const std::string& text) { log.info("{}", text); });
  while (true) {
    auto ev = group.WaitEvent(std::chrono::milliseconds(1000));
    if (ev.kind == ProcessGroup::Event::kChildExited) return ev.exit;  // "<tool>: done in .."
    if (ev.kind != ProcessGroup::Event::kTimeout) {
      line.Close();
      group.Stop(spec.name, std::chrono::milliseconds(2000));
      return std::nullopt;
    }
    line.Update(-1, deploy::NewestProgress(spec.log_path, {"report: ", "plot_session: "}));
  }
}

ChildSpec Tool(const std::string& name, std::vector<std::string> args, const Options& o,
               const Launch& launch) {
  ChildSpec t;
  t.name = name;
  t.argv = {Executable("/services/recorder/hexa_recorder")};
  t.argv.insert(t.argv.end(), args.begin(), args.end());
  t.env = launch.env;
  t.log_path = o.out_dir + "/" + name + ".console.log";
  return t;
}

// A recording whose recorder did not close it (killed, crashed) lacks its summary: it is
// recovered (hexa_recorder recover) into session.recovered.mcap. Returns the recording to
// report on; `clean` false if recovering failed.
std::string RecoverRecording(ProcessGroup& group, const Options& o, const Launch& launch,
                             bool& clean, spdlog::logger& log) {
  const std::string& mcap = launch.mcap;
  const std::string recovered = o.out_dir + "/session.recovered.mcap";
  const ChildSpec rc = Tool("recover", {"recover", mcap, "--output", recovered}, o, launch);
  const auto e = RunTool(group, rc, log);
  if (e && e->signal == 0 && e->exit_code == exit_code::kOk) {
    log.warn("the recorder did not close {}: recovered into {}:\n{}", mcap, recovered,
             TailOf(rc.log_path, 15));
    return recovered;
  }
  // Say why even when the tool could not write its own console log (a full disk), and
  // leave no partial copy that could pass for a recovered recording.
  std::string why = TailOf(rc.log_path, 15);
  if (why.empty()) why = "    (" + rc.log_path + " is empty)\n";
  why += "    " + FreeSpaceOf(o.out_dir);
  std::error_code ignored;
  if (fs::remove(recovered, ignored)) why += "; the partial " + recovered + " was removed";
  log.error("the recorder did not close {} and recovering it failed: {}:\n{}", mcap,
            e ? e->Describe() : std::string("recover did not run"), why);
  clean = false;
  return mcap;
}

// Identification: the recording gets the session description and, for evaluation only,
// the plant's true parameters as channels of their own; hexa_identify reads it.
void AttachSessionInfo(ProcessGroup& group, const Options& o, const Launch& launch,
                       const std::string& recording, bool& clean, spdlog::logger& log) {
  rec::SessionInfo info;
  const auto rig = config::LoadSystemConfig(o.rig);
  info.set_rig_name(rig.ok ? rig.config.rig_name : "");
  info.set_rig_file(o.rig);
  info.set_experiment(o.experiment);
  if (o.free_fall()) {
    info.set_free_fall_load_kg(o.free_fall_load_kg);
    info.set_free_fall_release_s(kFreeFallReleaseS);
  }
  info.set_profile(o.profile);
  info.set_seed(static_cast<std::uint64_t>(o.seed));
  info.set_command(o.command);
  info.set_excitation_per_leg_s(o.excite_duration_s);
  for (int leg : o.identify() ? o.excite_legs : std::vector<int>{}) {
    info.add_excited_legs(static_cast<std::uint32_t>(leg));
    info.add_excitation_start_s(launch.plan.legs[static_cast<std::size_t>(leg - 1)].start_s);
  }
  std::string text;
  google::protobuf::TextFormat::PrintToString(info, &text);
  const std::string info_path = o.out_dir + "/session_info.textproto";
  std::ofstream(info_path) << text;
  std::vector<std::string> args{"attach", recording, "--session-info", info_path};
  if (fs::exists(launch.truth_path)) args.insert(args.end(), {"--plant-truth", launch.truth_path});
  const ChildSpec a = Tool("attach", args, o, launch);
  const auto attached = RunTool(group, a, log);
  if (!attached || attached->signal != 0 || attached->exit_code != exit_code::kOk) {
    log.error("could not add the session info / plant truth to {}: {}", recording, TailOf(a.log_path, 5));
    clean = false;
  } else {
    log.info("recording {} ready for hexa_identify (session info and plant truth attached)", recording);
    std::printf("\n%s recording: %s\n", o.experiment.c_str(), recording.c_str());
  }
}

// The recording's parts: with a split, every part still on disk, oldest first, then the last.
std::vector<std::string> RecordingParts(const Options& o, const std::string& recording) {
  std::vector<std::string> parts;
  if (o.split_recording) {
    static const std::regex kPart(R"(session-[0-9]{4,}\.mcap)");
    std::error_code ignored;
    for (const auto& e : fs::directory_iterator(o.out_dir, ignored))
      if (std::regex_match(e.path().filename().string(), kPart)) parts.push_back(e.path().string());
    // session-0009 before session-0010, and session-9999 before session-10000.
    std::sort(parts.begin(), parts.end(), [](const std::string& a, const std::string& b) {
      return a.size() != b.size() ? a.size() < b.size() : a < b;
    });
  }
  parts.push_back(recording);
  return parts;
}

// The report's --meta: what ran and how it ended (report.md's header).
std::vector<std::string> ReportMeta(const Options& o, const SessionEnd& end) {
  auto on_off = [](bool on) { return std::string(on ? "on" : "off"); };
  std::vector<std::string> meta{
      "--meta", "trajectory=" + o.trajectory, "--meta", "controller=" + o.controller,
      "--meta", "profile=" + o.profile, "--meta", "mode=" + o.mode,
      "--meta", "seed=" + std::to_string(o.seed),
      "--meta", "outer_loop=" + on_off(o.outer_loop),
      "--meta", "feedforward=" + on_off(o.feedforward),
      "--meta", "dds_security=" + on_off(o.secure),
      "--meta", "command_auth=" + on_off(o.command_auth),
      "--meta", std::string("completed=") +
                    (end.completed ? "yes" : "NO" + (end.ended_because.empty()
                                                         ? std::string()
                                                         : ": " + end.ended_because))};
  // hexa_recorder splits --meta values at commas.
  std::replace(meta.back().begin(), meta.back().end(), ',', ';');
  if (!o.rig_overlays.empty()) {
    std::string list;
    for (const auto& overlay : o.rig_overlays) list += (list.empty() ? "" : " ") + overlay;
    meta.insert(meta.end(), {"--meta", "rig_overlays=" + list});
  }
  if (!o.faults.empty()) {
    std::string list;
    for (const auto& f : o.faults)
      list += (list.empty() ? "" : "; ") +
              (f.leg == 0 ? std::string("supervisor") : "leg " + std::to_string(f.leg)) + " " +
              f.kind + " at " + f.at + " s";
    meta.insert(meta.end(), {"--meta", "fault=" + list});
  }
  return meta;
}

// The report (hexa_recorder report) over the recording, written whenever there is one:
// after a fault it shows what happened. Printed on the console when the session completed.
void WriteReport(ProcessGroup& group, const Options& o, const Launch& launch,
                 const std::string& recording, const SessionEnd& end, bool& clean,
                 spdlog::logger& log) {
  const std::vector<std::string> parts = RecordingParts(o, recording);
  std::vector<std::string> args{"report"};
  args.insert(args.end(), parts.begin(), parts.end());
  args.insert(args.end(), {"--out", o.out_dir});
  const std::vector<std::string> meta = ReportMeta(o, end);
  args.insert(args.end(), meta.begin(), meta.end());
  if (recording != launch.mcap) args.insert(args.end(), {"--meta", "recording=recovered"});
  if (o.split_recording)
    args.insert(args.end(), {"--meta", "recording_parts=" + std::to_string(parts.size()) +
                                           " files still on disk (--record-split-*; older "
                                           "parts deleted by --record-keep-files are not in "
                                           "the figures)"});
  if (!o.plant_faults.empty()) args.insert(args.end(), {"--meta", "plant_fault=" + o.plant_faults});
  const ChildSpec r = Tool("report", args, o, launch);
  const auto e = RunTool(group, r, log);
  if (!e || e->signal != 0 || e->exit_code != exit_code::kOk) {
    log.error("report failed: {}\n{}", e ? e->Describe() : std::string("not run"),
              TailOf(r.log_path, 15));
    clean = false;
  }
  if (e) {
    std::ifstream md(o.out_dir + "/report.md");
    if (!end.completed) md.setstate(std::ios::failbit);  // the log says why; keep the tail short
    if (md) std::printf("\n%s\n", std::string(std::istreambuf_iterator<char>(md), {}).c_str());
  }
}

}  // namespace

std::string TailOf(const std::string& path, int lines) {
  std::ifstream in(path);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  std::ostringstream os;
  for (size_t i = all.size() > size_t(lines) ? all.size() - lines : 0; i < all.size(); ++i)
    os << "    " << all[i] << "\n";
  return os.str();
}

int PostProcess(ProcessGroup& group, const Options& o, const Launch& launch, SessionEnd& end,
                spdlog::logger& log) {
  bool clean = StopEveryProcess(group, o, end, log) && end.completed;
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - end.t0).count();
  log.info("all processes stopped; session wall time {:.1f} s", wall_s);
  WriteProcessTable(o.out_dir, end.exits, wall_s, log);

  std::string recording = launch.mcap;
  if (o.recorder && fs::exists(launch.mcap) && !end.recorder_clean)
    recording = RecoverRecording(group, o, launch, clean, log);
  const bool have_recording = o.recorder && fs::exists(recording);
  if (o.is_experiment() && have_recording)
    AttachSessionInfo(group, o, launch, recording, clean, log);
  // (Not for the identification experiments: they track no trajectory.)
  if (!o.is_experiment() && have_recording)
    WriteReport(group, o, launch, recording, end, clean, log);

  // A recording that lost samples is not a completed session: its figures miss them.
  const long long lost = o.recorder && !o.is_experiment() ? ReadReportLostSamples(o.out_dir) : 0;
  if (end.completed && clean && lost > 0) {
    log.error("session did NOT complete (exit {}): the trajectory ran to its end, but the "
              "recording lost {} samples (report.md, \"Recording\"); logs in {}",
              exit_code::kSessionRecordingLoss, lost, o.out_dir);
    return exit_code::kSessionRecordingLoss;
  }
  if (end.completed && clean) {
    log.info("session completed; outputs in {}", o.out_dir);
    return exit_code::kOk;
  }
  // Completed but a process did not stop cleanly, or the recording / report failed.
  const int outcome = end.completed ? exit_code::kRunError : end.outcome;
  log.error("session did NOT complete (exit {}){}{}; logs in {}", outcome,
            end.ended_because.empty() ? "" : ": ", end.ended_because, o.out_dir);
  return outcome;
}

}  // namespace hexa::launcher
