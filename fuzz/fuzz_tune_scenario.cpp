// libFuzzer target: a tuning scenario (`tune --scenario FILE`, YAML) and its accuracy block.
#include <cstddef>
#include <cstdint>
#include <string>

#include "model/errors.hpp"
#include "tune/accuracy.hpp"
#include "tune/scenario.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto s = dtflop::tune::parse_scenario(std::string(reinterpret_cast<const char*>(data), size), "", "fuzz");
    if (s.workload == "rbe" || s.workload == "dct") (void)dtflop::tune::make_accuracy_model(s.workload, s.accuracy);
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
