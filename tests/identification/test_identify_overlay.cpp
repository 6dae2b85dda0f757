// hexa_identify's overlay writer (report.hpp): an overlay is checked as a service loading it
// next to the rig file would, and values outside the rig file's limits are refused, never
// written.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "hexa/config/rig_config.hpp"
#include "report.hpp"

namespace fs = std::filesystem;

namespace hexa {
namespace {

TEST(IdentifyOverlay, ValuesOutsideTheRigFilesLimitsAreRefusedNeverWritten) {
  const config::ConfigResult rig = config::LoadSystemConfig(config::DefaultRigFile());
  ASSERT_TRUE(rig.ok) << rig.error;
  const std::string path = ::testing::TempDir() + "/identify_refused_" + std::to_string(getpid()) + ".textproto";
  config::RigOverlay o;
  o.rig_name = rig.config.rig_name;
  o.provenance.method = "test";
  o.provenance.date = "-";
  o.provenance.tool = "test";
  o.leg[2].friction_extend.coulomb_n = 50.0;
  o.leg[2].polytropic_extend.volume = 1.3;
  // Within the limits: written, and it loads back.
  EXPECT_EQ(identify::WriteValidatedOverlay(o, rig.config, path, "test"), "");
  ASSERT_TRUE(fs::exists(path));
  EXPECT_TRUE(config::LoadSystemConfig(config::DefaultRigFile(), {path}).ok);
  // gamma_k beyond [1, 2]: refused with the field and value named; the earlier file is gone.
  o.leg[2].polytropic_extend.volume = 2.5;
  std::string error = identify::WriteValidatedOverlay(o, rig.config, path, "test");
  EXPECT_NE(error.find("leg[leg_id=3].polytropic.extend.volume"), std::string::npos) << error;
  EXPECT_NE(error.find("2.5"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(path));
  // F_s below F_c (eq 3's rule): refused.
  o.leg[2].polytropic_extend.volume = 1.3;
  o.leg[2].friction_extend.static_n = 40.0;
  error = identify::WriteValidatedOverlay(o, rig.config, path, "test");
  EXPECT_NE(error.find("static_n"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace hexa
