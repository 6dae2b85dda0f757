#include "lab_session.hpp"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "deployment.hpp"
#include "hexa/services/scheduling.hpp"

namespace hexa::deploy {
namespace {

namespace fs = std::filesystem;

std::string Fmt(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string Quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// The binaries, where the deployment says they are (OUT/bin of the lab's work directory).
bool LinkBinaries(const LabSessionOptions& o, std::string& error) {
  const fs::path bin = fs::path(o.work_dir) / "bin";
  fs::create_directories(bin);
  for (const auto& [name, path] : o.binaries) {
    std::error_code ec;
    fs::remove(bin / name, ec);
    fs::create_symlink(path, bin / name, ec);
    if (ec) {
      error = "cannot link " + (bin / name).string() + ": " + ec.message();
      return false;
    }
  }
  return true;
}

// The deployment description's settings, in the lab's paths.
void WriteSettings(std::ostringstream& d, const LabSessionOptions& o) {
  const fs::path bin = fs::path(o.work_dir) / "bin";
  d << "# Written by the lab session (deploy/lab/lab_session.cpp) for its network namespaces.\n"
    << "name: \"lab\"\n"
    << "domain_id: " << o.domain << "\n"
    << "mode: " << (o.realtime ? "REALTIME" : "LOCKSTEP") << "\n"
    << "security { enabled: " << (o.secure ? "true" : "false")
    << (o.audit ? " audit_dir: " + Quoted((fs::path(o.work_dir) / "audit").string()) : std::string())
    << (o.metadata_protection.empty() ? std::string() : " metadata_protection: " + o.metadata_protection)
    << (o.loop_metadata_protection.empty() ? std::string()
                                           : " loop_metadata_protection: " + o.loop_metadata_protection)
    << " }\n"
    << "bin_dir: " << Quoted(bin.string()) << "\n"
    << "rig_file: " << Quoted(o.rig_file) << "\n"
    << "record_dir: " << Quoted((fs::path(o.work_dir) / "rec").string()) << "\n"
    << "timing {";
  if (o.watchdog_s > 0) d << " watchdog_s: " << Fmt(o.watchdog_s);
  if (o.lockstep_timeout_s > 0) d << " lockstep_timeout_s: " << Fmt(o.lockstep_timeout_s);
  if (o.stale_ticks > 0) d << " stale_ticks: " << o.stale_ticks;
  d << " startup_timeout_s: " << Fmt(o.startup_timeout_s) << " }\n";
}

// The hosts and their processes, in the lab's names and addresses: the built-in layout, or
// a deployment file's hosts. `start_order`: the hosts, the recorder's first.
void WriteHosts(std::ostringstream& d, const LabSessionOptions& o, const NetnsLab& lab,
                const std::optional<deployment::Deployment>& layout,
                std::vector<std::string>& start_order) {
  auto host_block = [&](const std::string& name, const std::string& processes) {
    const LabHost& h = lab.host(name);
    d << "host {\n  name: \"" << name << "\"\n  interface { name: \"" << h.veth
      << "\" address: \"" << h.address << "\" }\n  dds_interface: \"" << h.veth << "\"\n"
      << processes << "}\n";
  };
  auto args = [](const std::vector<std::string>& a) {
    std::string out;
    for (const auto& x : a) out += " arg: " + Quoted(x);
    return out;
  };
  // The one-machine session's placement (hexa_session's "auto" CPU options).
  const std::vector<int> allowed = sched::AllowedCpus();
  const bool place = o.cpu_placement && allowed.size() >= 2;
  const std::string control = place ? " cpu: " + std::to_string(allowed.back()) : "";
  const std::string other = place ? " cpu: " + std::to_string(allowed.front()) : "";
  auto legs = [&](int first, const std::string& extra, const std::string& cpu) {
    std::string out;
    for (int leg = first; leg < first + 3; ++leg)
      out += "  process { role: LEG leg: " + std::to_string(leg) + extra + cpu + " }\n";
    return out;
  };
  std::vector<std::string> recorder_hosts, other_hosts;  // start order: recorder first
  if (layout) {
    for (const auto& h : layout->host()) {
      std::string processes;
      bool has_recorder = false;
      for (const auto& p : h.process()) {
        const bool is_control = p.role() == deployment::PLANT ||
                                (p.role() == deployment::LEG && !p.standby() && !(o.split_legs_b && h.name() == "legs-b"));
        std::string line = std::string("  process { role: ") + ToString(p.role());
        if (p.role() == deployment::LEG) {
          line += " leg: " + std::to_string(p.leg());
          if (p.standby()) line += " standby: true";
        }
        if (p.role() != deployment::OPERATOR) line += is_control ? control : other;
        std::vector<std::string> extra(p.arg().begin(), p.arg().end());
        if (p.role() == deployment::PLANT) extra.insert(extra.end(), o.plant_args.begin(), o.plant_args.end());
        if (p.role() == deployment::SUPERVISOR)
          extra.insert(extra.end(), o.supervisor_args.begin(), o.supervisor_args.end());
        processes += line + args(extra) + " }\n";
        has_recorder = has_recorder || p.role() == deployment::RECORDER;
      }
      host_block(h.name(), processes);
      (has_recorder ? recorder_hosts : other_hosts).push_back(h.name());
    }
  } else {
    host_block("io-sup", "  process { role: PLANT" + control + args(o.plant_args) +
                             " }\n  process { role: SUPERVISOR" + other + args(o.supervisor_args) +
                             " }\n  process { role: OPERATOR }\n");
    host_block("legs-a", legs(1, "", control));
    host_block("legs-b", legs(4, "", o.split_legs_b ? other : control));
    if (o.standbys) host_block("standby-b", legs(4, " standby: true", other));
    host_block("recorder", "  process { role: RECORDER" + other + " }\n");
    recorder_hosts = {"recorder"};
    other_hosts = {"legs-a", "legs-b"};
    if (o.standbys) other_hosts.push_back("standby-b");
    other_hosts.push_back("io-sup");
  }
  start_order = recorder_hosts;
  start_order.insert(start_order.end(), other_hosts.begin(), other_hosts.end());
}

}  // namespace

int RunToCompletion(ProcessGroup& group, const std::string& name,
                    const std::vector<std::string>& argv, const std::string& log,
                    std::chrono::seconds timeout, const std::map<std::string, std::string>& env) {
  ChildSpec s;
  s.name = name;
  s.argv = argv;
  s.env = env;
  s.log_path = log;
  std::string err;
  if (group.Start(s, err) < 0) return -1;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    const auto ev = group.WaitEvent(std::chrono::milliseconds(500));
    if (ev.kind == ProcessGroup::Event::kChildExited && ev.exit.name == name)
      return ev.exit.signal != 0 ? 128 + ev.exit.signal : ev.exit.exit_code;
    if (ev.kind == ProcessGroup::Event::kInterrupted) break;
  }
  group.Stop(name, std::chrono::milliseconds(2000));
  return -1;
}

std::unique_ptr<LabSession> LabSession::Create(const LabSessionOptions& o, std::string& error) {
  std::unique_ptr<LabSession> s(new LabSession());
  s->options_ = o;
  fs::create_directories(o.work_dir);
  // The layout: the built-in one, or a deployment file's hosts and processes.
  std::optional<deployment::Deployment> layout;
  if (!o.layout_file.empty()) {
    LoadedDeployment loaded = LoadDeployment(o.layout_file);
    if (!loaded.ok) {
      error = "layout " + o.layout_file + ":";
      for (const auto& e : loaded.errors) error += " " + e;
      return nullptr;
    }
    layout = std::move(loaded.deployment);
  }
  std::vector<std::string> hosts;
  if (layout) {
    for (const auto& h : layout->host()) hosts.push_back(h.name());
  } else {
    hosts = {"io-sup", "legs-a", "legs-b"};
    if (o.standbys) hosts.push_back("standby-b");
    hosts.push_back("recorder");
  }
  std::vector<std::string> all_hosts = hosts;
  all_hosts.insert(all_hosts.end(), o.extra_hosts.begin(), o.extra_hosts.end());
  s->lab_ = NetnsLab::Create(o.tag, all_hosts, o.subnet, error);
  if (!s->lab_) return nullptr;

  if (!LinkBinaries(o, error)) return nullptr;
  fs::create_directories(fs::path(o.work_dir) / "rec");
  if (o.audit) fs::create_directories(fs::path(o.work_dir) / "audit");

  // The deployment description, in the lab's names and addresses.
  std::ostringstream d;
  WriteSettings(d, o);
  WriteHosts(d, o, *s->lab_, layout, s->hosts_);
  s->deployment_text_ = d.str();
  const std::string file = (fs::path(o.work_dir) / "deployment.textproto").string();
  std::ofstream(file) << s->deployment_text_;

  s->generated_ = (fs::path(o.work_dir) / "gen").string();
  fs::remove_all(s->generated_);
  const auto deploy_bin = o.binaries.find("hexa_deploy");
  if (deploy_bin == o.binaries.end()) {
    error = "no hexa_deploy among the binaries";
    return nullptr;
  }
  const std::string work = o.work_dir;
  if (int rc = RunToCompletion(s->group_, "generate",
                               {deploy_bin->second, "generate", file, "--out", s->generated_, "--in-place"},
                               work + "/generate.log", std::chrono::seconds(60));
      rc != 0) {
    error = "hexa_deploy generate failed (exit " + std::to_string(rc) + "), see " + work + "/generate.log";
    return nullptr;
  }
  if (o.secure) {
    if (int rc = RunToCompletion(s->group_, "make_security", {o.make_security, s->generated_},
                                 work + "/make_security.log", std::chrono::seconds(120));
        rc != 0) {
      error = "make_security.sh failed (exit " + std::to_string(rc) + "), see " + work + "/make_security.log";
      return nullptr;
    }
  }
  s->launcher_ = std::make_unique<UnitLauncher>(s->group_, *s->lab_, s->generated_, work + "/run");
  return s;
}

LabSession::~LabSession() {
  group_.StopAll(std::chrono::milliseconds(3000));
  launcher_.reset();
  lab_.reset();  // deletes the namespaces after every process in them has stopped
}

std::vector<std::pair<std::string, std::vector<std::string>>> LabSession::Plan() const {
  std::vector<std::pair<std::string, std::vector<std::string>>> plan;
  for (const auto& h : hosts_) plan.emplace_back(h, launcher_->UnitsOf(h));
  return plan;
}

bool LabSession::StartAll(std::string& error) {
  // Recorder first and plant last: each process waits for its peers anyway, but this order
  // starts the clock master when everyone else is already there.
  std::string plant_host;
  for (const auto& [host, units] : Plan()) {
    for (const auto& unit : units) {
      if (unit == "hexa-plant.service") {
        plant_host = host;
        continue;
      }
      if (!launcher_->Start(host, unit, error)) return false;
    }
  }
  if (options_.plant_start_delay_s > 0) {
    // The others discover (and, secured, authenticate) each other before the clock starts.
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::duration<double>(options_.plant_start_delay_s);
    while (std::chrono::steady_clock::now() < end) {
      const auto ev = group_.WaitEvent(std::chrono::milliseconds(100));
      launcher_->Poll();
      if (ev.kind == ProcessGroup::Event::kChildExited) {
        error = ev.exit.Describe() + " before the plant was started";
        return false;
      }
    }
  }
  return plant_host.empty() || launcher_->Start(plant_host, "hexa-plant.service", error);
}

std::string LabSession::Recording() const {
  std::string newest;
  fs::file_time_type newest_time{};
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(options_.work_dir) / "rec", ec)) {
    if (e.path().extension() != ".mcap") continue;
    if (newest.empty() || e.last_write_time() > newest_time) {
      newest = e.path().string();
      newest_time = e.last_write_time();
    }
  }
  return newest;
}

std::string LabSession::DdsConfigOf(const std::string& host) const {
  return (fs::path(generated_) / "hosts" / host / "etc/hexa/cyclonedds.xml").string();
}

}  // namespace hexa::deploy
