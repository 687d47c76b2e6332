// libFuzzer target: the machine profile reader (profiles from `probe` and `calibrate`).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "model/errors.hpp"
#include "model/json_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto j = dtflop::parse_json_limited(std::string_view(reinterpret_cast<const char*>(data), size), "input");
    const dtflop::MachineProfile p = dtflop::profile_from_json(j);
    (void)dtflop::profile_from_json(dtflop::to_json(p));  // what it reads, it writes back readable
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
