// libFuzzer target: a whole sample store file (lines, torn tails, foreign files).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "calibrate/store.hpp"
#include "model/errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("dtflop_fuzz_store_" + std::to_string(::getpid()) + ".jsonl");
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data),
                                                                 static_cast<std::streamsize>(size));
  try {
    (void)dtflop::calib::read_store(path);
  } catch (const dtflop::InputError&) {
  }
  return 0;
}
