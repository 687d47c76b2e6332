// Shared GoogleTest main: runs every test; the folders a test made with fresh_test_dir are
// removed when it passes and kept, with their paths printed, when it fails.
#include <cstdio>
#include <filesystem>
#include <system_error>

#include <gtest/gtest.h>

#include "tests/support/gpu.hpp"
#include "tests/support/temp_dir.hpp"

namespace {

class RemoveTestDirs final : public testing::EmptyTestEventListener {
  void OnTestEnd(const testing::TestInfo& info) override {
    auto& dirs = dtflop::test::running_test_dirs();
    for (const auto& d : dirs) {
      if (info.result()->Failed()) {
        std::fprintf(stderr, "%s.%s failed: its files are kept in %s\n", info.test_suite_name(), info.name(), d.c_str());
      } else {
        std::error_code ec;
        std::filesystem::remove_all(d, ec);
      }
    }
    dirs.clear();
  }
};

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  testing::UnitTest::GetInstance()->listeners().Append(new RemoveTestDirs);  // gtest owns it
  return RUN_ALL_TESTS();
}
