// libFuzzer target: the specimen spec parser (`dtflop specimen KIND:key=value,...`). Only the spec
// is parsed and the dots placed; nothing is rendered.
#include <cstddef>
#include <cstdint>
#include <string>

#include "model/errors.hpp"
#include "workloads/dct/specimen.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 4096) return 0;
  try {
    (void)dtflop::dct::parse_specimen(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
