#include "lab_session.hpp"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "deployment.hpp"
#include "generate.hpp"
#include "session_layout.hpp"
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

// The built-in five hosts: where each process of the session's layout runs.
std::string BuiltInHostOf(const session::ProcessSpec& p) {
  switch (p.role) {
    case session::Role::kRecorder: return "recorder";
    case session::Role::kPlant:
    case session::Role::kSupervisor: return "io-sup";
    case session::Role::kLeg: return p.standby ? "standby-b" : p.leg <= 3 ? "legs-a" : "legs-b";
    case session::Role::kBridge: break;
  }
  return "";
}

deployment::Role DeploymentRoleOf(session::Role role) {
  switch (role) {
    case session::Role::kPlant: return deployment::PLANT;
    case session::Role::kSupervisor: return deployment::SUPERVISOR;
    case session::Role::kLeg: return deployment::LEG;
    case session::Role::kRecorder: return deployment::RECORDER;
    case session::Role::kBridge: return deployment::BRIDGE;
  }
  return deployment::ROLE_UNSPECIFIED;
}

// The built-in layout as a deployment's hosts and processes: the session's layout
// (deploy/session: the processes hexa_session runs, with a recorder, and standbys of legs
// 4-6 when asked for) on the five hosts, and the operator's identity beside the supervisor.
deployment::Deployment BuiltInLayout(const LabSessionOptions& o) {
  session::SessionOptions options;
  options.realtime = o.realtime;
  if (o.standbys) options.standby = {false, false, false, true, true, true};
  deployment::Deployment d;
  auto host = [&d](const std::string& name) {
    for (auto& h : *d.mutable_host())
      if (h.name() == name) return &h;
    deployment::Host* h = d.add_host();
    h->set_name(name);
    return h;
  };
  for (const auto& spec : session::BuildSessionLayout(options).processes) {
    deployment::Host* h = host(BuiltInHostOf(spec));
    deployment::Process* p = h->add_process();
    p->set_role(DeploymentRoleOf(spec.role));
    if (spec.role == session::Role::kLeg) {
      p->set_leg(static_cast<unsigned>(spec.leg));
      p->set_standby(spec.standby);
    }
    if (spec.role == session::Role::kSupervisor) h->add_process()->set_role(deployment::OPERATOR);
  }
  return d;
}

// The hosts and their processes of `layout` (built-in or a deployment file's), in the lab's
// names and addresses, each process with the CPU the one-machine session gives it
// (hexa_session's "auto" CPU options: the plant and the primary legs on this machine's last
// allowed CPU, the rest on its first). `start_order`: the hosts, the recorder's first.
void WriteHosts(std::ostringstream& d, const LabSessionOptions& o, const NetnsLab& lab,
                const deployment::Deployment& layout, std::vector<std::string>& start_order) {
  const std::vector<int> allowed = sched::AllowedCpus();
  const bool place = o.cpu_placement && allowed.size() >= 2;
  session::SessionOptions placement = SessionOptionsOf(layout);
  if (place) {
    placement.cpus_control = std::to_string(allowed.back());
    placement.cpus_standby = placement.cpus_supervisor = placement.cpus_recorder =
        std::to_string(allowed.front());
  }
  const session::SessionLayout placed = session::BuildSessionLayout(placement);
  std::vector<std::string> recorder_hosts, other_hosts;
  for (const auto& h : layout.host()) {
    const LabHost& lab_host = lab.host(h.name());
    d << "host {\n  name: \"" << h.name() << "\"\n  interface { name: \"" << lab_host.veth
      << "\" address: \"" << lab_host.address << "\" }\n  dds_interface: \"" << lab_host.veth
      << "\"\n";
    bool has_recorder = false;
    for (const auto& p : h.process()) {
      d << "  process { role: " << ToString(p.role());
      if (p.role() == deployment::LEG) d << " leg: " << p.leg() << (p.standby() ? " standby: true" : "");
      const session::ProcessSpec* spec = placed.Find(NodeName(p));
      std::string cpu = spec != nullptr ? spec->cpus : "";
      if (place && o.split_legs_b && h.name() == "legs-b" && p.role() == deployment::LEG)
        cpu = std::to_string(allowed.front());
      if (!cpu.empty()) d << " cpu: " << cpu;
      std::vector<std::string> args(p.arg().begin(), p.arg().end());
      if (p.role() == deployment::PLANT) args.insert(args.end(), o.plant_args.begin(), o.plant_args.end());
      if (p.role() == deployment::SUPERVISOR)
        args.insert(args.end(), o.supervisor_args.begin(), o.supervisor_args.end());
      for (const auto& a : args) d << " arg: " << Quoted(a);
      d << " }\n";
      has_recorder = has_recorder || p.role() == deployment::RECORDER;
    }
    d << "}\n";
    (has_recorder ? recorder_hosts : other_hosts).push_back(h.name());
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
  deployment::Deployment layout;
  if (o.layout_file.empty()) {
    layout = BuiltInLayout(o);
  } else {
    LoadedDeployment loaded = LoadDeployment(o.layout_file);
    if (!loaded.ok) {
      error = "layout " + o.layout_file + ":";
      for (const auto& e : loaded.errors) error += " " + e;
      return nullptr;
    }
    layout = std::move(loaded.deployment);
  }
  std::vector<std::string> hosts;
  for (const auto& h : layout.host()) hosts.push_back(h.name());
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
