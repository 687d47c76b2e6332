// GPU availability for tests: GPU tests call DTFLOP_REQUIRE_GPU() first and skip, with the
// reason, where no CUDA device can be used.
#pragma once

#include <string>

#include <gtest/gtest.h>

namespace dtflop::test {
// Empty when a CUDA device is usable; otherwise why not.
std::string gpu_unavailable_reason();
}  // namespace dtflop::test

#define DTFLOP_REQUIRE_GPU()                                                     \
  do {                                                                           \
    const std::string dtflop_reason_ = ::dtflop::test::gpu_unavailable_reason(); \
    if (!dtflop_reason_.empty()) GTEST_SKIP() << dtflop_reason_;                 \
  } while (0)
