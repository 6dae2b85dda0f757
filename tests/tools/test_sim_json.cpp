// hexa_sim --json: the file parses as JSON whatever the paths it names (a rig overlay and the
// output in a directory whose name holds quotes and backslashes), and keeps its fields: seed,
// profile, controller, overlays, and per trajectory completed / rmse_vs_truth /
// rmse_vs_measured / leg_rmse_m.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <vector>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "hexa/services/json.hpp"
#include "scratch_dir.hpp"

namespace {

// Runs argv without a shell (the paths are passed as they are), output to `log`.
int RunProgram(const std::vector<std::string>& args, const std::string& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    FILE* f = std::freopen(log.c_str(), "w", stdout);
    if (f == nullptr) _exit(127);
    dup2(fileno(stdout), STDERR_FILENO);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(SimJson, PathsWithQuotesAndBackslashesGiveValidJson) {
  const std::string dir = hexa::testing::ScratchDir("sim_json") + "/a \"quoted\" dir\\with\\backslashes";
  std::filesystem::create_directories(dir);
  const std::string overlay = dir + "/overlay \"1\".textproto";
  std::ofstream(overlay) << "rig_name: \"HexaTaar-R\"\n"
                            "provenance { method: \"test \\\"quoted\\\"\" date: \"2026-01-01\" }\n"
                            "leg { leg_id: 1 gravity_load_n: 13.2 }\n";
  const std::string out = dir + "/out \\ \"x\".json";
  const std::string log = dir + "/hexa_sim.log";
  const int rc = RunProgram({HEXA_SIM_BIN, "--trajectory", "z", "--periods", "1", "--seed", "1",
                      "--rig-overlay", overlay, "--json", out},
                     log);
  ASSERT_EQ(rc, 0) << ReadAll(log);
  const std::string text = ReadAll(out);
  hexa::json::Value j;
  ASSERT_NO_THROW(j = hexa::json::Value::parse(text)) << text;
  EXPECT_EQ(j["seed"], 1);
  EXPECT_EQ(j["profile"], "realistic");
  EXPECT_EQ(j["controller"], "bssmc");
  ASSERT_EQ(j["overlays"].size(), 1u);
  EXPECT_EQ(j["overlays"][0].get<std::string>(), overlay);
  ASSERT_TRUE(j["trajectories"].contains("z")) << text;
  const auto& z = j["trajectories"]["z"];
  EXPECT_EQ(z["completed"], true);
  ASSERT_EQ(z["rmse_vs_truth"].size(), 6u);
  ASSERT_EQ(z["rmse_vs_measured"].size(), 6u);
  ASSERT_EQ(z["leg_rmse_m"].size(), 6u);
  // The moving axis' RMSE against ground truth: a number, and a plausible one (under 1 cm).
  ASSERT_TRUE(z["rmse_vs_truth"][2].is_number()) << text;
  EXPECT_GT(z["rmse_vs_truth"][2].get<double>(), 0.0);
  EXPECT_LT(z["rmse_vs_truth"][2].get<double>(), 0.01);
}

}  // namespace
