// hexa_deploy: deployment descriptions (proto/deployment.proto) -> per-host configuration.
//   hexa_deploy check FILE                  validate, print the plan
//   hexa_deploy generate FILE --out DIR     Cyclone XML, systemd units, security inputs per host
//   hexa_deploy verify-security --dds-config FILE [--identity NAME] [--domain D]
//                                           check a process's DDS Security files at start-up
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "deployment.hpp"
#include "generate.hpp"
#include "hexa/services/cli.hpp"
#include "hexa/services/exit_code.hpp"
#include "security_check.hpp"

namespace {

using namespace hexa::deploy;

constexpr char kUsage[] =
    "usage: hexa_deploy COMMAND [options]\n"
    "  check FILE                 validate a deployment description and print its plan\n"
    "  generate FILE --out DIR    write per host: Cyclone DDS config, systemd units, and the\n"
    "                             security inputs of deploy/make_security.sh\n"
    "  verify-security --dds-config FILE [--identity NAME] [--domain D]\n"
    "                             check the DDS Security files a process will use\n"
    "Each command has --help. docs/deployment.md describes the file and the outputs.\n";

int PrintErrors(const LoadedDeployment& l) {
  for (const auto& e : l.errors) std::fprintf(stderr, "%s\n", e.c_str());
  std::fprintf(stderr, "hexa_deploy: %zu error%s: deployment rejected\n", l.errors.size(),
               l.errors.size() == 1 ? "" : "s");
  return hexa::exit_code::kRunError;
}

void PrintPlan(const hexa::deployment::Deployment& d) {
  std::printf("deployment '%s': domain %u, %s, security %s, %d host%s\n", d.name().c_str(),
              d.domain_id(), ToString(d.mode()), d.security().enabled() ? "ON" : "off",
              d.host_size(), d.host_size() == 1 ? "" : "s");
  std::map<std::string, std::string> per_host;
  for (const auto& p : PlanProcesses(d)) per_host[p.host] += " " + p.node;
  for (const auto& h : d.host()) {
    const auto& i = DdsInterface(h);
    std::printf("  %-14s %-8s %-18s%s\n", h.name().c_str(), i.name().c_str(),
                i.address().c_str(), per_host[h.name()].c_str());
  }
}

int Check(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_deploy check", "Validates a deployment description: hexa_deploy check FILE");
  cli.AllowPositional("FILE", 1);
  if (int rc = hexa::cli::HandleParseResult(cli, cli.Parse(argc, argv)); rc >= 0) return rc;
  if (cli.positional().size() != 1) {
    std::fprintf(stderr, "error: expected exactly one deployment file\n(see --help)\n");
    return hexa::exit_code::kUsage;
  }
  const auto l = LoadDeployment(cli.positional()[0]);
  if (!l.ok) return PrintErrors(l);
  std::printf("OK ");
  PrintPlan(l.deployment);
  return hexa::exit_code::kOk;
}

int GenerateCommand(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_deploy generate",
                        "Writes per host the Cyclone DDS configuration, the systemd units and "
                        "the inputs of deploy/make_security.sh: hexa_deploy generate FILE --out DIR");
  cli.AddOption("out", "dir", "output directory (hosts/<host>/..., security-src/)");
  cli.AddFlag("in-place", "paths inside the files point into DIR/hosts/<host>/ (tests, trials in "
                          "network namespaces) instead of the on-host config_dir");
  cli.AllowPositional("FILE", 1);
  if (int rc = hexa::cli::HandleParseResult(cli, cli.Parse(argc, argv)); rc >= 0) return rc;
  if (cli.positional().size() != 1 || !cli.Has("out")) {
    std::fprintf(stderr, "error: expected a deployment file and --out DIR\n(see --help)\n");
    return hexa::exit_code::kUsage;
  }
  const std::string path = cli.positional()[0];
  const auto l = LoadDeployment(path);
  if (!l.ok) return PrintErrors(l);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  GenerateOptions options;
  options.in_place = cli.Flag("in-place");
  const auto r = Generate(l.deployment, text.str(), cli.Get("out"), options);
  if (!r.ok) {
    std::fprintf(stderr, "hexa_deploy: error: %s\n", r.error.c_str());
    return hexa::exit_code::kRunError;
  }
  PrintPlan(l.deployment);
  std::printf("wrote %zu files under %s\n", r.files.size(), cli.Get("out").c_str());
  if (l.deployment.security().enabled())
    std::printf("next: deploy/make_security.sh %s   (CA, identities, signed governance and "
                "permissions)\n", cli.Get("out").c_str());
  return hexa::exit_code::kOk;
}

int VerifySecurity(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_deploy verify-security",
                        "Checks the DDS Security files named by a Cyclone DDS configuration: "
                        "present, signed by the project CA, valid now, matching identity; exit 0 "
                        "only if all hold");
  cli.AddOption("dds-config", "file", "the Cyclone DDS configuration the process will use");
  cli.AddOption("identity", "name", "the process's identity (default: $HEXA_IDENTITY)");
  cli.AddOption("domain", "id", "the DDS domain the process joins (checked against the documents)");
  if (int rc = hexa::cli::HandleParseResult(cli, cli.Parse(argc, argv)); rc >= 0) return rc;
  if (!cli.Has("dds-config")) {
    std::fprintf(stderr, "error: --dds-config is required\n(see --help)\n");
    return hexa::exit_code::kUsage;
  }
  std::optional<std::string> identity;
  if (cli.Has("identity")) identity = cli.Get("identity");
  std::optional<int> domain;
  if (cli.Has("domain")) {
    const auto d = cli.GetInt("domain", 0, kMaxDomainId);
    if (!d) {
      std::fprintf(stderr, "error: %s\n", cli.error().c_str());
      return hexa::exit_code::kUsage;
    }
    domain = static_cast<int>(*d);
  }
  const auto r = VerifyDdsConfigSecurity(cli.Get("dds-config"), identity, domain, std::time(nullptr));
  if (!r.ok) {
    for (const auto& e : r.errors) std::fprintf(stderr, "hexa_deploy: security error: %s\n", e.c_str());
    return hexa::exit_code::kRunError;
  }
  std::printf("OK %s\n", r.summary.c_str());
  return hexa::exit_code::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  if (command == "check") return Check(argc - 1, argv + 1);
  if (command == "generate") return GenerateCommand(argc - 1, argv + 1);
  if (command == "verify-security") return VerifySecurity(argc - 1, argv + 1);
  std::fprintf(stderr, "error: unknown command '%s'\n%s", command.c_str(), kUsage);
  return hexa::exit_code::kUsage;
}
