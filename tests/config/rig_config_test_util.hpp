// Helpers of the rig-file tests (test_rig_config.cpp, test_rig_config_files.cpp): reading and
// splitting files, the DEFECT marker of the broken copies, running the hexa_check_config CLI.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace rig_config_test {

inline const std::string kTestDir = HEXA_CONFIG_TEST_DIR;
inline const std::string kTmpDir = HEXA_CONFIG_TEST_TMP_DIR;

inline std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline std::string JoinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

// 1-based line carrying "DEFECT" (found by the test, independently of the loader).
inline int DefectLine(const std::string& path) {
  const auto lines = SplitLines(ReadFile(path));
  int found = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find("DEFECT") != std::string::npos) {
      EXPECT_EQ(found, 0) << path << " has more than one DEFECT marker";
      found = static_cast<int>(i) + 1;
    }
  }
  EXPECT_GT(found, 0) << path << " has no DEFECT marker";
  return found;
}

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline RunResult RunCheckConfig(const std::string& args, const std::string& tag,
                                const std::string& prefix = "") {
  const std::string out_path = kTmpDir + "/cli_" + tag + ".out";
  const std::string err_path = kTmpDir + "/cli_" + tag + ".err";
  const std::string cmd = prefix + "'" + HEXA_CHECK_CONFIG_BIN + "' " + args + " >'" + out_path + "' 2>'" +
                          err_path + "'";
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  r.out = ReadFile(out_path);
  r.err = ReadFile(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  return r;
}

}  // namespace rig_config_test
