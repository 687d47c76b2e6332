// libFuzzer target: a plan file for `sweep --plan FILE`, for each workload.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "model/errors.hpp"
#include "workloads/workload.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("dtflop_fuzz_plan_" + std::to_string(::getpid()) + ".json");
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data),
                                                                 static_cast<std::streamsize>(size));
  for (const dtflop::workload::Workload* w : dtflop::workload::all()) {
    try {
      const auto plan = w->plan(path.string(), *w->backends().front(), 1);
      for (const auto& c : plan.configs) (void)w->key(*w->backends().front(), c);
    } catch (const dtflop::InputError&) {
    }
  }
  return 0;
}
