// hexa_session --secure (docs/security.md, "DDS Security"): the whole session with a
// project CA, one identity per process and encrypted topics completes, records everything,
// and equals the in-process lockstep simulation bit for bit (security changes nothing but the
// wire). Its security files are where the session says, one identity per process.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "session_util.hpp"

namespace {

using hexa::testing::RunSession;
using hexa::testing::Slurp;

TEST(SecureSession, CombinedLockstepIsBitIdenticalWithDdsSecurity) {
  const auto run = RunSession("secure_session", 79, {"--secure", "--trajectory", "combined",
                                                     "--periods", "1", "--seed", "3"});
  ASSERT_EQ(run.exit_code, 0) << Slurp(run.dir + "/session.log");
  ASSERT_TRUE(run.has_report);
  const std::string log = Slurp(run.dir + "/session.log");
  EXPECT_NE(log.find("DDS Security on: 9 identities"), std::string::npos) << log;
  const std::string sec = run.dir + "/security/hosts/local/etc/hexa/security";
  for (const char* id : {"plant", "supervisor", "leg1", "leg6", "recorder"})
    EXPECT_TRUE(std::filesystem::exists(sec + "/" + id + "/permissions.p7s")) << id;
  const std::string xml = Slurp(run.dir + "/security/hosts/local/etc/hexa/cyclonedds.xml");
  EXPECT_NE(xml.find("<Security>"), std::string::npos);
  EXPECT_NE(xml.find("<NetworkInterface name=\"lo\""), std::string::npos);
  for (const auto& [topic, missing] : run.report.missing) EXPECT_EQ(missing, 0u) << topic;
  EXPECT_TRUE(run.report.faults.empty());
  hexa::testing::ExpectSameAsInProcess(run.report, hexa::PaperMotion::kCombined, 1, 3);
}

TEST(SecureSession, RefusesAnExplicitDdsConfig) {
  // A configuration of one's own would silently replace the secured one: refused.
  const std::string copy = ::testing::TempDir() + "/own_dds_config.xml";
  std::filesystem::copy_file(HEXA_LOOPBACK_CONFIG, copy, std::filesystem::copy_options::overwrite_existing);
  const auto run = RunSession("secure_session_cfg", 70, {"--secure", "--dds-config", copy});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(Slurp(run.dir + "/launcher.console.log").find("cannot be combined with --dds-config"),
            std::string::npos);
}

}  // namespace
