#include "tests/support/gpu.hpp"

#include "cuda/device.hpp"

namespace dtflop::test {

std::string gpu_unavailable_reason() { return cuda::unavailable_reason(); }

}  // namespace dtflop::test
