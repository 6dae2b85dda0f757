// DDS Security files made by deploy/make_security.sh for a generated deployment, and the
// start-up errors of bad ones (docs/security.md, "Start-up check"): a missing file, an expired
// certificate, a certificate or permissions signed by another CA, permissions of another
// identity, a configuration without security. Each is a clear error naming the file from
// `hexa_deploy verify-security`, and the services themselves refuse to start (Cyclone fails
// the participant): never a silent insecure fallback.
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "deployment.hpp"
#include "generate.hpp"
#include "process_group.hpp"
#include "security_check.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hexa::deploy;
using namespace std::chrono_literals;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A one-host deployment on loopback (nothing leaves the machine; ctest runs in `unshare -n`).
std::string DeploymentText(int domain) {
  return "name: \"sec-test\"\ndomain_id: " + std::to_string(domain) +
         "\nmode: LOCKSTEP\nsecurity { enabled: true }\n"
         "host { name: \"one\" interface { name: \"lo\" address: \"127.0.0.1/8\" } dds_interface: \"lo\"\n"
         "  process { role: PLANT } process { role: SUPERVISOR }\n"
         "  process { role: LEG leg: 1 } process { role: LEG leg: 2 } process { role: LEG leg: 3 }\n"
         "  process { role: LEG leg: 4 } process { role: LEG leg: 5 } process { role: LEG leg: 6 } }\n";
}

// Generates the deployment in place under `dir` and signs it (with `ca_dir`, or a new CA).
void MakeSecured(const std::string& dir, int domain, const std::string& ca_dir = "",
                 const std::string& extra = "") {
  fs::remove_all(dir);
  const auto l = ParseDeployment(DeploymentText(domain), "test");
  ASSERT_TRUE(l.ok);
  GenerateOptions o;
  o.in_place = true;
  const auto r = Generate(l.deployment, DeploymentText(domain), dir, o);
  ASSERT_TRUE(r.ok) << r.error;
  std::string cmd = std::string(HEXA_MAKE_SECURITY) + " " + dir;
  if (!ca_dir.empty()) cmd += " --ca-dir " + ca_dir;
  cmd += " " + extra + " > " + dir + "/make_security.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << Slurp(dir + "/make_security.log");
}

class SecurityFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    base_ = ::testing::TempDir() + "/secfiles_" + std::to_string(getpid());
    domain_ = 160 + getpid() % 30;
    MakeSecured(base_ + "/good", domain_);
    MakeSecured(base_ + "/other", domain_);  // same deployment, another CA
  }
  static void TearDownTestSuite() { fs::remove_all(base_); }
  static std::string Config(const std::string& tree) {
    return base_ + "/" + tree + "/hosts/one/etc/hexa/cyclonedds.xml";
  }
  static std::string Sec(const std::string& tree) {
    return base_ + "/" + tree + "/hosts/one/etc/hexa/security";
  }
  // A copy of the good tree to spoil.
  static std::string Spoilable(const std::string& name) {
    const std::string dir = base_ + "/" + name;
    fs::remove_all(dir);
    fs::copy(base_ + "/good", dir, fs::copy_options::recursive);
    // Its configuration must point at its own files.
    const std::string path = Config(name);
    std::string xml = Slurp(path);
    xml = std::regex_replace(xml, std::regex(base_ + "/good/"), base_ + "/" + name + "/");
    std::ofstream(path) << xml;
    return name;
  }
  static std::string Errors(const SecurityCheck& c) {
    std::string all;
    for (const auto& e : c.errors) all += e + "\n";
    return all;
  }
  static std::string base_;
  static int domain_;
};
std::string SecurityFiles::base_;
int SecurityFiles::domain_ = 0;

TEST_F(SecurityFiles, EveryIdentityOfAGoodDeploymentVerifies) {
  for (const char* id : {"plant", "supervisor", "leg1", "leg6"}) {
    const auto c = VerifyDdsConfigSecurity(Config("good"), std::string(id), domain_, std::time(nullptr));
    EXPECT_TRUE(c.ok) << id << ":\n" << Errors(c);
    EXPECT_NE(c.summary.find(std::string("CN=") + id), std::string::npos) << c.summary;
  }
  // The CA key stays with whoever made the deployment; a host gets only the CA certificate.
  EXPECT_TRUE(fs::exists(base_ + "/good/ca/ca_key.pem"));
  EXPECT_FALSE(fs::exists(Sec("good") + "/ca_key.pem"));
  EXPECT_EQ(fs::status(Sec("good") + "/leg1/key.pem").permissions() & fs::perms::others_read,
            fs::perms::none);
}

TEST_F(SecurityFiles, WrongDomainIsAnError) {
  const auto c = VerifyDdsConfigSecurity(Config("good"), std::string("leg1"), domain_ + 1, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("has no rule for domain"), std::string::npos) << Errors(c);
}

TEST_F(SecurityFiles, MissingCertificateNamesTheFile) {
  const std::string t = Spoilable("missing");
  fs::remove(Sec(t) + "/leg2/cert.pem");
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg2"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("identity certificate '" + Sec(t) + "/leg2/cert.pem' cannot be read"),
            std::string::npos) << Errors(c);
}

TEST_F(SecurityFiles, ExpiredCertificateSaysExpiredAndWhen) {
  const std::string t = Spoilable("expired");
  // Re-make leg3's identity with a validity that ended in 2021, signed by the same CA.
  const std::string cmd = std::string(HEXA_MAKE_SECURITY) + " " + base_ + "/" + t + " --ca-dir " +
                          base_ + "/good/ca --only leg3 --start 20200101000000Z --end 20210101000000Z"
                          " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg3"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("leg3/cert.pem' EXPIRED on Jan  1 00:00:00 2021 GMT"), std::string::npos)
      << Errors(c);
}

TEST_F(SecurityFiles, PermissionsSignedByAnotherCaAreRefused) {
  const std::string t = Spoilable("foreign_perm");
  fs::copy_file(Sec("other") + "/leg1/permissions.p7s", Sec(t) + "/leg1/permissions.p7s",
                fs::copy_options::overwrite_existing);
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg1"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("permissions '" + Sec(t) + "/leg1/permissions.p7s' is NOT signed by the "
                           "permissions CA"),
            std::string::npos) << Errors(c);
}

TEST_F(SecurityFiles, IdentityFromAnotherCaIsRefused) {
  const std::string t = Spoilable("foreign_id");
  for (const char* f : {"cert.pem", "key.pem"})
    fs::copy_file(Sec("other") + "/leg1/" + f, Sec(t) + "/leg1/" + f, fs::copy_options::overwrite_existing);
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg1"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("is NOT issued by the identity CA"), std::string::npos) << Errors(c);
}

TEST_F(SecurityFiles, PermissionsOfAnotherIdentityAreRefused) {
  const std::string t = Spoilable("swapped");
  fs::copy_file(Sec(t) + "/leg2/permissions.p7s", Sec(t) + "/leg1/permissions.p7s",
                fs::copy_options::overwrite_existing);
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg1"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("grant 'CN=leg2,O=HexaTaar,OU=sec-test', not this identity"), std::string::npos)
      << Errors(c);
}

TEST_F(SecurityFiles, KeyOfAnotherIdentityIsRefused) {
  const std::string t = Spoilable("wrong_key");
  fs::copy_file(Sec(t) + "/leg2/key.pem", Sec(t) + "/leg1/key.pem", fs::copy_options::overwrite_existing);
  const auto c = VerifyDdsConfigSecurity(Config(t), std::string("leg1"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("does not belong to the identity certificate"), std::string::npos) << Errors(c);
}

TEST_F(SecurityFiles, ConfigurationWithoutSecurityIsRefused) {
  const std::string path = base_ + "/plain.xml";
  std::ofstream(path) << Slurp(HEXA_LOOPBACK_CONFIG);
  const auto c = VerifyDdsConfigSecurity(path, std::string("leg1"), domain_, std::time(nullptr));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(Errors(c).find("WITHOUT DDS Security (refusing)"), std::string::npos) << Errors(c);
  const auto unset = VerifyDdsConfigSecurity(Config("good"), std::nullopt, domain_, std::time(nullptr));
  if (std::getenv("HEXA_IDENTITY") == nullptr) {
    EXPECT_NE(Errors(unset).find("HEXA_IDENTITY"), std::string::npos) << Errors(unset);
  }
}

// The services: with a bad file they exit at start-up with Cyclone's reason, never run open.
TEST_F(SecurityFiles, ServicesRefuseToStartWithBadSecurityFiles) {
  // Reuse the trees spoiled above (the tests of this suite run in order in one process).
  struct Case {
    std::string tree, identity, expect;
  };
  const std::string exp = Spoilable("expired_svc");
  ASSERT_EQ(std::system((std::string(HEXA_MAKE_SECURITY) + " " + base_ + "/" + exp + " --ca-dir " + base_ +
                         "/good/ca --only leg3 --start 20200101000000Z --end 20210101000000Z > /dev/null 2>&1")
                            .c_str()),
            0);
  const std::string foreign = Spoilable("foreign_svc");
  fs::copy_file(Sec("other") + "/leg1/permissions.p7s", Sec(foreign) + "/leg1/permissions.p7s",
                fs::copy_options::overwrite_existing);
  const std::vector<Case> cases{{exp, "leg3", "certificate has expired"},
                                {foreign, "leg1", "Failed to parse PKCS7 SMIME document"},
                                {"good", "leg_nobody", "could not be found"}};
  for (const auto& c : cases) {
    ProcessGroup g;
    ChildSpec s;
    s.name = "leg";
    s.argv = {HEXA_LEG_CTRL, "--leg", "1", "--domain", std::to_string(domain_), "--dds-config",
              Config(c.tree), "--startup-timeout", "5"};
    s.env = {{"HEXA_IDENTITY", c.identity}};
    s.log_path = base_ + "/svc_" + c.tree + ".log";
    std::string err;
    ASSERT_GT(g.Start(s, err), 0) << err;
    const auto ev = g.WaitEvent(30s);
    ASSERT_EQ(ev.kind, ProcessGroup::Event::kChildExited) << c.tree << ": still running";
    EXPECT_EQ(ev.exit.exit_code, 1) << c.tree << ": " << ev.exit.Describe();
    const std::string log = Slurp(s.log_path);
    EXPECT_NE(log.find(c.expect), std::string::npos) << c.tree << ":\n" << log;
    EXPECT_NE(log.find("cannot create DDS participant"), std::string::npos) << c.tree << ":\n" << log;
    EXPECT_EQ(log.find("running: leg"), std::string::npos) << c.tree << ": the leg ran:\n" << log;
  }
}

}  // namespace
