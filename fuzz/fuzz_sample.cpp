// libFuzzer target: one line of a sample store (the store reader's per-line path).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "calibrate/sample.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto j = dtflop::parse_json_limited(std::string_view(reinterpret_cast<const char*>(data), size), "input");
    const dtflop::calib::Sample s = dtflop::calib::sample_from_json(j);
    (void)dtflop::calib::sample_from_json(dtflop::calib::to_json(s));
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
