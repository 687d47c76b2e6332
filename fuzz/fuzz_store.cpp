// libFuzzer target: a whole sample store file (lines, torn tails, foreign files).
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibrate/store.hpp"
#include "fuzz/input_file.hpp"
#include "model/errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = dtflop::fuzz::input_file(data, size);
  try {
    (void)dtflop::calib::read_store(path);
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
