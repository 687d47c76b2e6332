#include "calibrate/sweep.hpp"

#include <chrono>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/store.hpp"
#include "model/errors.hpp"
#include "model/units.hpp"

namespace dtflop::calib {

std::string format_eta(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const long t = std::lround(s);
  if (t >= 3600) return fmt::format("{}h{:02}m", t / 3600, (t % 3600) / 60);
  if (t >= 60) return fmt::format("{}m{:02}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

SweepReport run_sweep(const Plan& plan, const std::filesystem::path& store, const MachineIdentity& here,
                      const MeasureFn& measure, std::FILE* progress) {
  SweepReport rep;
  rep.planned = static_cast<int>(plan.items.size());
  // Opening the writer first locks the store and repairs a torn tail; then read what it holds.
  StoreWriter writer(store, rep.warnings);
  const StoreContents have = read_store(store);
  for (const auto& w : have.warnings) rep.warnings.push_back(w);
  for (const auto& s : have.samples) {
    std::string why;
    if (!same_machine(s.machine, here, &why))
      throw InputError(fmt::format(
          "sample store '{}' holds samples measured on another machine ({}: {}); a store holds "
          "one machine's samples, so use another --store here",
          store.string(), describe(s.machine), why));
  }
  std::set<std::string> done = have.keys();

  std::vector<const PlanItem*> todo;
  std::set<std::string> planned;
  for (const auto& item : plan.items) {
    if (!planned.insert(item.key).second) continue;  // a plan file may repeat a configuration
    if (done.count(item.key)) ++rep.already;
    else todo.push_back(&item);
  }
  if (progress) {
    for (const auto& w : rep.warnings) fmt::print(progress, "dtflop: warning: {}\n", w);
    fmt::print(progress, "sweep {}: {} configurations, {} already in {}, {} to measure\n", plan.name,
               planned.size(), rep.already, store.string(), todo.size());
    std::fflush(progress);
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < todo.size(); ++i) {
    Sample s = measure(*todo[i]);
    writer.append(s);
    ++rep.measured;
    if (progress) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double eta = elapsed / static_cast<double>(i + 1) * static_cast<double>(todo.size() - i - 1);
      const Stats* total = s.find(Component::total);
      fmt::print(progress, "[{}/{}] {}: {} per step, ETA {}\n", rep.already + static_cast<int>(i) + 1,
                 planned.size(), todo[i]->label,
                 total ? format_duration(total->median / static_cast<double>(s.steps)) : "?", format_eta(eta));
      std::fflush(progress);
    }
  }
  return rep;
}

}  // namespace dtflop::calib
