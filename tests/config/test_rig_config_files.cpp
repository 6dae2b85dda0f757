// Rig file loader (config/): the broken copies in broken/ (one defect each, through the API and
// the hexa_check_config CLI), the CLI's refusals, and generic properties of the line mapping
// (every numeric field, made NaN or removed, is reported at its own line / its block's line).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/supervisor.hpp"
#include "rig_config_test_util.hpp"

namespace {

using hexa::config::ConfigIssue;
using hexa::config::ConfigResult;
using hexa::config::SystemConfig;
using namespace rig_config_test;

// ---------------------------------------------------------------- broken copies

struct BrokenCase {
  std::string name;
  std::string field;    // exact field path ("" for syntax errors)
  std::string message;  // substrings expected in the message, value and limit
  std::string value;
  std::string limit;
};

std::ostream& operator<<(std::ostream& out, const BrokenCase& c) { return out << c.name; }

const std::vector<BrokenCase> kBrokenCases = {
    {"syntax_error", "", "Expected \":\"", "", ""},
    {"unknown_field", "cylinder.cap_aera_m2", "did you mean 'cap_area_m2'", "cap_aera_m2", "cap_area_m2"},
    {"missing_field", "cylinder.rod_area_m2", "'rod_area_m2' is missing from block 'cylinder'", "(absent)", "every field"},
    {"missing_block", "valve", "'valve' is missing from the file", "(absent)", "every field"},
    {"negative_mass", "platform.mass_kg", "mass must be positive", "-6", "> 0"},
    {"zero_area", "cylinder.cap_area_m2", "area must be positive", "0", "> 0"},
    {"annulus_ge_cap", "cylinder.annulus_area_m2", "smaller than the cap area", "0.00035",
     "< cylinder.cap_area_m2 (0.00031416)"},
    {"valve_null_outside", "valve.null_voltage_v", "strictly between", "12", "(0, 10)"},
    {"non_finite", "friction.bristle_damping_n_s_m", "finite", "inf", "finite"},
    {"coincident_joints", "geometry.leg[id=2].p_BA_B_m", "coincides with that of leg 1", "0", ">= 0.001 m"},
    {"collinear_base", "geometry", "base joints are collinear", "0", ">= 0.001 m"},
    {"singular_geometry", "geometry", "Jacobian (eq 48) at the home pose is singular", "condition number inf", "<= 100"},
    {"ill_conditioned_geometry", "geometry", "badly conditioned", "condition number 213.4", "<= 100"},
    {"home_outside_stroke", "geometry.home_position_m", "outside the usable stroke", "0.6598",
     "[0.3884, 0.6184] m"},
    {"window_too_small", "leg_controller.differentiator.window", "window", "1", "[2, 32]"},
    {"sigma_zero", "leg_controller.differentiator.sigma", "must be positive", "0", "> 0"},
    {"unknown_profile", "default_profile", "unknown disturbance profile requested", "\"realsitic\"",
     "ideal, realistic"},
    {"duplicate_profile", "disturbance_profile[1].name", "'realistic' is defined twice (first at line",
     "\"realistic\"", "unique"},
    {"duplicate_leg_id", "geometry.leg[5].id", "leg 5 is defined twice", "5", "exactly once"},
    // Physical limits (each of these was accepted and broke the plant or the control).
    {"supply_beyond_ideal_gas", "air.supply_pressure_pa", "ideal gas", "5020000 Pa",
     "<= 3055565.012 Pa"},
    {"platform_too_heavy", "platform.mass_kg", "the legs must hold the platform", "1e+30 kg",
     "<= 34.39010948 kg"},
    {"spool_faster_than_step", "valve.spool_time_constant_s", "spool lag", "1e-09 s",
     ">= 0.0003333333333 s"},
    {"lambda_beyond_valve_chain", "leg_controller.bssmc.lambda_1_s", "lambda tau < pi/2",
     "1e+12 1/s", "<= 224.3994753 1/s"},  // pi / 2 / 7 ms (differentiator lag 1 sample)
    {"end_stop_too_stiff", "cylinder.end_stop_stiffness_n_m", "end-stop contact mode", "0.0005 s",
     "<= 5.129139494e-05 s"},
    {"heat_ratio_above_monatomic", "air.heat_ratio", "heat capacity ratio of a gas", "1.8",
     "(1, 1.6667]"},
    // Feedback rate in phi_dot and its leg observer.
    {"feedback_rate_fraction_above_one", "leg_controller.bssmc.feedback_rate_fraction",
     "fraction of the feedback part's rate in phi_dot is out of range", "1.5", "[0, 1]"},
    {"observer_mass_zero", "leg_controller.bssmc.observer_mass_kg", "observer mass must be positive", "0",
     "> 0"},
    // The BS-SMC's dither needs at least 4 control periods per cycle.
    {"dither_too_fast", "leg_controller.bssmc.dither_frequency_hz", "dither frequency", "400",
     "[0, 250]"},
    // The remote I/O board's calibration (docs/board_protocol.md).
    {"board_gain_zero", "board.leg[id=3].valve_v.gain_si_per_count", "channel gain must not be zero", "0",
     "!= 0"},
    {"board_potentiometer_short", "board.leg[id=1].potentiometer_m.min_si",
     "plausible range must cover the stroke", "0.4", "<= 0.3784"},
    {"board_five_legs", "board.leg", "the board serves exactly six legs", "5 legs", "exactly 6"},
    // The supervisor's soft limits (docs/operate.md "Soft limits").
    {"soft_box_excludes_home", "supervisor.soft_limits.position_max_from_home_m.y",
     "the pose box must contain the home pose", "-0.02", "> 0"},
    {"soft_box_beyond_workspace", "supervisor.soft_limits.rotation_max_rad.pitch",
     "the pose box must lie inside the workspace check", "0.6", "[-0.5236, 0.5236]"},
    {"soft_joint_limit_zero", "supervisor.soft_limits.max_platform_joint_angle_rad",
     "platform joint deflection limit is out of range", "0", "[0.001, 1.5]"},
};

class BrokenFile : public ::testing::TestWithParam<BrokenCase> {};

TEST_P(BrokenFile, ApiReportsFileLineFieldValueLimit) {
  const BrokenCase& c = GetParam();
  const std::string path = kTestDir + "/broken/" + c.name + ".textproto";
  const int line = DefectLine(path);
  const ConfigResult r = hexa::config::LoadSystemConfig(path);
  ASSERT_FALSE(r.ok);
  ASSERT_EQ(r.issues.size(), 1u) << "one defect must give one message:\n" << r.error;
  const ConfigIssue& issue = r.issues[0];
  EXPECT_EQ(issue.file, path);
  EXPECT_EQ(issue.line, line) << r.error;
  EXPECT_EQ(issue.field, c.field) << r.error;
  EXPECT_NE(issue.message.find(c.message), std::string::npos) << r.error;
  EXPECT_NE(issue.value.find(c.value), std::string::npos) << r.error;
  EXPECT_NE(issue.limit.find(c.limit), std::string::npos) << r.error;
  // The text names all of it too.
  EXPECT_EQ(r.error.rfind(path + ":" + std::to_string(line) + ":", 0), 0u) << r.error;
  EXPECT_NE(r.error.find(c.field), std::string::npos) << r.error;
  if (!c.value.empty()) {
    EXPECT_NE(r.error.find("value " + c.value), std::string::npos) << r.error;
  }
  if (!c.limit.empty()) {
    EXPECT_NE(r.error.find(c.limit), std::string::npos) << r.error;
  }
}


TEST_P(BrokenFile, CliExitsNonZeroWithTheMessageOnStderr) {
  const BrokenCase& c = GetParam();
  const std::string path = kTestDir + "/broken/" + c.name + ".textproto";
  const int line = DefectLine(path);
  const RunResult r = RunCheckConfig("'" + path + "'", c.name);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_EQ(r.err.rfind(path + ":" + std::to_string(line) + ":", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(c.limit), std::string::npos) << r.err;
}

INSTANTIATE_TEST_SUITE_P(Config, BrokenFile, ::testing::ValuesIn(kBrokenCases),
                         [](const ::testing::TestParamInfo<BrokenCase>& info) { return info.param.name; });

TEST(RigConfigCli, ReferenceOkAndUnknownProfileOption) {
  const RunResult ok = RunCheckConfig("'" + hexa::config::DefaultRigFile() + "' --profile ideal", "ok");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(ok.out.rfind("OK ", 0), 0u) << ok.out;
  EXPECT_NE(ok.out.find("HexaTaar-R"), std::string::npos) << ok.out;
  const RunResult bad = RunCheckConfig("--profile windy", "badprofile");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("unknown disturbance profile requested"), std::string::npos) << bad.err;
  const RunResult usage = RunCheckConfig("--frobnicate", "usage");
  EXPECT_EQ(usage.exit_code, 2);
}

// A rig file is read whole: a device, a FIFO or a huge file is refused before reading, so that
// `hexa_check_config /dev/zero` answers at once instead of reading for ever.
TEST(RigConfigCli, DevicesFifosAndHugeFilesAreRefusedAtOnce) {
  // `timeout`: a reader without the limit would read /dev/zero until memory runs out (124).
  const RunResult zero = RunCheckConfig("/dev/zero", "devzero", "timeout 20 ");
  EXPECT_EQ(zero.exit_code, 1) << zero.err;
  EXPECT_NE(zero.err.find("/dev/zero"), std::string::npos) << zero.err;
  EXPECT_NE(zero.err.find("rig file is not a regular file"), std::string::npos) << zero.err;

  const std::string fifo = kTmpDir + "/rig_fifo";
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const ConfigResult from_fifo = hexa::config::LoadSystemConfig(fifo);  // no writer: no wait
  std::remove(fifo.c_str());
  EXPECT_FALSE(from_fifo.ok);
  EXPECT_NE(from_fifo.error.find("not a regular file"), std::string::npos) << from_fifo.error;

  // The reference rig file followed by comments up to 2 MiB: valid text, but over the limit.
  const std::string huge = kTmpDir + "/rig_huge.textproto";
  {
    std::ofstream out(huge);
    out << ReadFile(hexa::config::DefaultRigFile());
    const std::string comment = "# " + std::string(97, 'x') + "\n";
    for (int i = 0; i < 2 * 1024 * 1024 / 100; ++i) out << comment;
  }
  const ConfigResult big = hexa::config::LoadSystemConfig(huge);
  const ConfigResult big_overlay = hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile(), {huge});
  std::remove(huge.c_str());
  EXPECT_FALSE(big.ok);
  EXPECT_NE(big.error.find("more than the limit of 1048576 bytes"), std::string::npos) << big.error;
  EXPECT_FALSE(big_overlay.ok);
  EXPECT_NE(big_overlay.error.find("rig overlay is"), std::string::npos) << big_overlay.error;
}

// ---------------------------------------------------------------- every field's line

// Scalar numeric fields of the reference ("  name: 1.5e-3"), 0-based line indices.
std::vector<std::size_t> ScalarNumericLines(const std::vector<std::string>& lines) {
  static const std::regex kScalar(R"(^\s*[a-z_0-9]+: -?[0-9][0-9.e+-]*\s*(#.*)?$)");
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (std::regex_match(lines[i], kScalar)) out.push_back(i);
  }
  return out;
}

std::string FieldName(const std::string& line) {
  const auto start = line.find_first_not_of(' ');
  return line.substr(start, line.find(':') - start);
}

TEST(RigConfigLines, EveryNumericFieldMadeNanIsReportedAtItsLine) {
  const auto lines = SplitLines(ReadFile(hexa::config::DefaultRigFile()));
  const auto numeric = ScalarNumericLines(lines);
  ASSERT_GT(numeric.size(), 80u);  // the reference has ~90 scalar numeric fields
  for (std::size_t i : numeric) {
    auto edited = lines;
    edited[i] = edited[i].substr(0, edited[i].find(':') + 1) + " nan";
    const ConfigResult r = hexa::config::ParseSystemConfig(JoinLines(edited), "nan.textproto");
    ASSERT_FALSE(r.ok) << lines[i];
    ASSERT_EQ(r.issues.size(), 1u) << lines[i] << "\n" << r.error;
    EXPECT_EQ(r.issues[0].line, static_cast<int>(i) + 1) << lines[i] << "\n" << r.error;
    // Integer fields fail in the parser (nan is no integer); doubles in the finiteness check.
    if (r.issues[0].field.empty()) {
      EXPECT_NE(r.issues[0].message.find("syntax error"), std::string::npos) << r.error;
    } else {
      const std::string name = FieldName(lines[i]);
      EXPECT_EQ(r.issues[0].field.substr(r.issues[0].field.size() - name.size()), name) << r.error;
      EXPECT_EQ(r.issues[0].value, "nan") << r.error;
    }
  }
}

// Start line (0-based) of the innermost block enclosing line i, found by brace counting.
std::size_t EnclosingBlockLine(const std::vector<std::string>& lines, std::size_t i) {
  int depth = 0;
  for (std::size_t k = i; k-- > 0;) {
    const std::string code = lines[k].substr(0, lines[k].find('#'));
    for (auto it = code.rbegin(); it != code.rend(); ++it) {
      if (*it == '}') ++depth;
      if (*it == '{') {
        if (depth == 0) return k;
        --depth;
      }
    }
  }
  return 0;
}

TEST(RigConfigLines, EveryNumericFieldRemovedIsReportedAsMissingAtItsBlock) {
  const auto lines = SplitLines(ReadFile(hexa::config::DefaultRigFile()));
  for (std::size_t i : ScalarNumericLines(lines)) {
    auto edited = lines;
    edited.erase(edited.begin() + static_cast<std::ptrdiff_t>(i));
    const ConfigResult r = hexa::config::ParseSystemConfig(JoinLines(edited), "missing.textproto");
    ASSERT_FALSE(r.ok) << lines[i];
    ASSERT_EQ(r.issues.size(), 1u) << lines[i] << "\n" << r.error;
    const std::string name = FieldName(lines[i]);
    const ConfigIssue& issue = r.issues[0];
    EXPECT_EQ(issue.line, static_cast<int>(EnclosingBlockLine(lines, i)) + 1) << lines[i] << "\n" << r.error;
    EXPECT_EQ(issue.field.substr(issue.field.size() - name.size()), name) << r.error;
    EXPECT_NE(issue.message.find("'" + name + "' is missing"), std::string::npos) << r.error;
  }
}

}  // namespace
