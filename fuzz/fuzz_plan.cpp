// libFuzzer target: a plan file for `sweep --plan FILE`, for each workload.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz/input_file.hpp"
#include "model/errors.hpp"
#include "workloads/workload.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = dtflop::fuzz::input_file(data, size);
  for (const dtflop::workload::Workload* w : dtflop::workload::all()) {
    try {
      const auto plan = w->plan(path, *w->backends().front(), 1);
      for (const auto& c : plan.configs) (void)w->key(*w->backends().front(), c);
    } catch (const dtflop::InputError&) {
    }
  }
  return 0;
}
