#include "cli/model_tables.hpp"

#include <string>

#include <fmt/format.h>

#include "cli/table.hpp"
#include "model/terms.hpp"
#include "model/units.hpp"

namespace dtflop::cli {

void print_counts(const CostCounts& c) {
  Table t({"count", "value", "meaning"}, "lrl");
  t.row({"P", fmt::format("{}", c.P), fmt::format("bytes per value ({})", to_string(c.precision))});
  for (const CountField& f : count_fields()) {
    const std::int64_t v = c.*f.member;
    if (f.part_of && v == 0) continue;  // a part of another count: shown where there is one
    t.row({std::string(f.name), fmt::format("{}", v), fmt::format("{} {}", f.unit, f.meaning)});
  }
  if (!c.copies_GC.empty()) {
    std::string sizes;
    for (const CopySize& s : c.copies_GC)
      sizes += fmt::format("{}{} x {}", sizes.empty() ? "" : ", ", s.count, format_bytes(static_cast<double>(s.bytes)));
    t.row({"copies_GC", sizes, "device->host copies by size (pageable ones are staged, docs/model.md 2.1)"});
  }
  t.row({"cpu_threads", fmt::format("{}", c.cpu_threads),
         fmt::format("the CPU work runs on {} thread{}", c.cpu_threads, c.cpu_threads == 1 ? "" : "s")});
  t.row({"host_memory", std::string(to_string(c.host_memory)), "host memory of the copies"});
  if (c.peer_messages > 0 || c.N_peer > 0 || c.collectives > 0)
    t.row({"peer_path", std::string(to_string(c.peer_path)),
           c.peer_path == PeerPath::link ? "partitions on several GPUs (NCCL)" : "partitions on one GPU (copies)"});
  fmt::print("{}", t.str());
}

void print_prediction(const Prediction& p) {
  Table t({"term", "what", "time", "share"}, "llrr");
  auto share = [&p](double v) { return p.total > 0 ? fmt::format("{:.1f}%", 100 * v / p.total) : "-"; };
  std::string overlaps;  // extended: "max(dt_GG, dt_G), max(dt_C_arith, dt_CC)"
  int zero = 0;
  for (Phase phase : all_phases()) {
    std::string group;
    int rows = 0;
    for (const Term& term : terms()) {
      if (term.phase != phase || !term.applies(p.variant)) continue;
      const double v = p.*term.field;
      if (term.combine == Combine::overlap) group += fmt::format("{}{}", group.empty() ? "" : ", ", term.name);
      if (v == 0) {
        ++zero;
        continue;
      }
      t.row({std::string(term.name), std::string(term.label), format_duration(v), share(v)});
      ++rows;
    }
    // A phase of several terms: its time, what a measurement of it compares with.
    if (rows > 1) {
      const double v = phase_seconds(p, phase);
      t.row({fmt::format("= {}", to_string(phase)), std::string(describe(phase)), format_duration(v), share(v)});
    }
    if (p.variant == kOverlapVariant && group.find(',') != std::string::npos)
      overlaps += fmt::format("{}max({})", overlaps.empty() ? "" : " and ", group);
  }
  t.row({"total", "", format_duration(p.total), ""});
  fmt::print("{}", t.str());
  if (zero > 0) fmt::print("({} more term{} of the {} variant cost nothing here)\n", zero, zero == 1 ? "" : "s",
                           to_string(p.variant));
  if (!overlaps.empty())
    fmt::print("({} variant: overlapping terms take {}, so the shares may add up to more than 100%)\n",
               to_string(p.variant), overlaps);
}

}  // namespace dtflop::cli
