#include "calibrate/sweep.hpp"

#include <chrono>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/rounds.hpp"
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
                      const MeasureFn& measure, std::FILE* progress, int rounds) {
  if (rounds < 1 || rounds > 1000)
    throw InputError(fmt::format("--rounds must be between 1 and 1000 (each round measures every configuration "
                                 "of the plan once), got {}",
                                 rounds));
  SweepReport rep;
  rep.rounds = rounds;
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
  const std::set<std::string> done = have.keys();

  // The plan's distinct configurations, in plan order.
  std::vector<const PlanItem*> items;
  std::set<std::string> planned;
  for (const auto& item : plan.items)
    if (planned.insert(item.key).second) items.push_back(&item);  // a plan file may repeat a configuration
  rep.configurations = static_cast<int>(items.size());
  rep.planned = rep.configurations * rounds;

  // (configuration, round) pairs to measure: round 1 of every configuration, then round 2, ...
  struct Todo {
    const PlanItem* item;
    int round;
  };
  std::vector<Todo> todo;
  std::vector<int> round_done(static_cast<std::size_t>(rounds) + 1, 0);  // samples of each round in the store
  for (int r = 1; r <= rounds; ++r)
    for (const PlanItem* item : items) {
      if (done.count(round_key(item->key, r))) {
        ++rep.already;
        ++round_done[static_cast<std::size_t>(r)];
      } else {
        todo.push_back({item, r});
      }
    }
  if (progress) {
    for (const auto& w : rep.warnings) fmt::print(progress, "dtflop: warning: {}\n", w);
    if (rounds == 1)
      fmt::print(progress, "sweep {}: {} configurations, {} already in {}, {} to measure\n", plan.name,
                 rep.configurations, rep.already, store.string(), todo.size());
    else
      fmt::print(progress, "sweep {}: {} configurations x {} rounds = {} samples, {} already in {}, {} to measure\n",
                 plan.name, rep.configurations, rounds, rep.planned, rep.already, store.string(), todo.size());
    std::fflush(progress);
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < todo.size(); ++i) {
    const Todo& t = todo[i];
    PlanItem item = *t.item;
    item.key = round_key(t.item->key, t.round);
    Sample s = measure(item);
    s.key = item.key;
    s.round = t.round;
    writer.append(s);
    ++rep.measured;
    const int in_round = ++round_done[static_cast<std::size_t>(t.round)];
    if (progress) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double eta = elapsed / static_cast<double>(i + 1) * static_cast<double>(todo.size() - i - 1);
      const Stats* total = s.find(Component::total);
      const std::string per_step =
          total ? format_duration(total->median / static_cast<double>(s.steps)) : std::string("?");
      if (rounds == 1)
        fmt::print(progress, "[{}/{}] {}: {} per step, ETA {}\n", in_round, rep.configurations, t.item->label,
                   per_step, format_eta(eta));
      else
        fmt::print(progress, "round {}/{} [{}/{}] {}: {} per step, ETA {}\n", t.round, rounds, in_round,
                   rep.configurations, t.item->label, per_step, format_eta(eta));
      std::fflush(progress);
    }
  }
  return rep;
}

}  // namespace dtflop::calib
