// libFuzzer target: a run configuration for `live dct --config FILE`, and each line of it as
// a source name (`--source SPEC`).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"
#include "sources/live.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)dtflop::live::parse_live_config(text, "fuzz.yaml");
  } catch (const dtflop::InputError&) {
  }
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    try {
      (void)dtflop::sources::parse_source_spec(line);
    } catch (const dtflop::InputError&) {
    }
  }
  return 0;
}
