// A fresh, empty folder for the running test, so that tests running in parallel (ctest -j)
// never share files: <temp>/<prefix>_<pid>_<test name>, removed first if it is there. The shared
// test main (support/main.cpp) removes it when the test passes and keeps it, saying where, when
// the test fails.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace dtflop::test {

// The folders fresh_test_dir made for the running test (emptied when it ends).
inline std::vector<std::filesystem::path>& running_test_dirs() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}

inline std::filesystem::path fresh_test_dir(const std::string& prefix) {
  // A parameterized test's name holds a '/': one folder, not a folder in a folder.
  std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  std::replace(name.begin(), name.end(), '/', '_');
  const auto dir = std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  running_test_dirs().push_back(dir);
  return dir;
}

}  // namespace dtflop::test
