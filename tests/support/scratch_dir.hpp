// Scratch directories of system tests (sessions, generated units, namespaces): a test makes one
// with ScratchDir(); it is removed when the test passes and kept, with its path printed, when the
// test fails (its logs are what a reader needs then). Before this, every run of the suite left
// about 30 session directories (a few MB each) in /tmp.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <gtest/gtest.h>

namespace hexa::testing {

inline std::vector<std::string>& ScratchDirsOfThisTest() {
  static std::vector<std::string> dirs;
  return dirs;
}

class ScratchDirCleaner : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    for (const auto& dir : ScratchDirsOfThisTest()) {
      if (info.result()->Failed()) {
        std::printf("test failed: its scratch directory is kept for inspection: %s\n",
                    dir.c_str());
      } else {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
      }
    }
    ScratchDirsOfThisTest().clear();
  }
};

// Installed once per test binary, before main() runs the tests (the listener list owns it).
inline const bool kScratchDirCleanerInstalled = [] {
  ::testing::UnitTest::GetInstance()->listeners().Append(new ScratchDirCleaner);
  return true;
}();

// A fresh directory TempDir()/NAME_PID (emptied if it exists), removed at the end of the current
// test unless the test failed.
inline std::string ScratchDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/" + name + "_" + std::to_string(getpid());
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir);
  ScratchDirsOfThisTest().push_back(dir);
  return dir;
}

}  // namespace hexa::testing
