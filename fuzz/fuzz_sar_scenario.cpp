// libFuzzer target: a search-and-rescue scenario file for `dtflop sar --scenario FILE`.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz/input_file.hpp"
#include "model/errors.hpp"
#include "sar/scenario.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = dtflop::fuzz::input_file(data, size);
  try {
    const dtflop::sar::Scenario s = dtflop::sar::load_scenario(path);
    (void)dtflop::sar::team_digest(s);
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
