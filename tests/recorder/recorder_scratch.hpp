// The scratch directory of a recorder file test (tests/support/scratch_dir.hpp): named after
// the test, removed when the test passes, kept when it fails.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "scratch_dir.hpp"

namespace hexa::recorder {

inline std::filesystem::path TempDir() {
  return hexa::testing::ScratchDir(
      std::string("hexa_rec_test_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

}  // namespace hexa::recorder
