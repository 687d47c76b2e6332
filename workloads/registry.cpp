// The registry of workloads: one line per workload. Adding a workload is adding its folder
// (its parameter space, backends and plans behind the contract of workload.hpp) and one line here.
#include <fmt/format.h>

#include "model/errors.hpp"
#include "sar/workload.hpp"
#include "workloads/dct/workload.hpp"
#include "workloads/rbe/workload.hpp"
#include "workloads/workload.hpp"

namespace dtflop::workload {

const std::vector<const Workload*>& all() {
  static const std::vector<const Workload*> list = {
      &rbe::workload(),
      &dct::workload(),
      &sar::net_workload(),
  };
  return list;
}

const Workload& find(std::string_view name) {
  for (const Workload* w : all())
    if (w->name() == name) return *w;
  throw InputError(fmt::format("no workload is named '{}'; use one of {}", name, names()));
}

std::string names(std::string_view separator) {
  std::string out;
  for (const Workload* w : all()) out += (out.empty() ? "" : std::string(separator)) + std::string(w->name());
  return out;
}

}  // namespace dtflop::workload
