// libFuzzer target: image decoding as `dtflop fields --reference/--frames` reads files.
#include <cstddef>
#include <cstdint>
#include <string>

#include "model/errors.hpp"
#include "workloads/dct/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)dtflop::dct::decode_grey(std::string(reinterpret_cast<const char*>(data), size), "input");
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
