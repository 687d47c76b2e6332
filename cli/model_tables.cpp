#include "cli/model_tables.hpp"

#include <string>

#include <fmt/format.h>

#include "cli/table.hpp"
#include "model/units.hpp"

namespace dtflop::cli {
namespace {

std::string count_str(std::int64_t v) { return fmt::format("{}", v); }

}  // namespace

void print_counts(const CostCounts& c) {
  Table t({"count", "value", "meaning"}, "lrl");
  t.row({"P", count_str(c.P), fmt::format("bytes per value ({})", to_string(c.precision))});
  t.row({"N_CG", count_str(c.N_CG), fmt::format("values host->device in {} copies", c.transfers_CG)});
  t.row({"N_GC", count_str(c.N_GC), fmt::format("values device->host in {} copies", c.transfers_GC)});
  if (!c.copies_GC.empty()) {
    std::string sizes;
    for (const CopySize& s : c.copies_GC)
      sizes += fmt::format("{}{} x {}", sizes.empty() ? "" : ", ", s.count, format_bytes(static_cast<double>(s.bytes)));
    t.row({"copies_GC", sizes, "device->host copies by size (pageable ones are staged, docs/model.md 2.1)"});
  }
  t.row({"N_GG", count_str(c.N_GG), "values through device memory"});
  t.row({"N_C", count_str(c.N_C), fmt::format("FLOPs on the CPU, on {} thread{}", c.cpu_threads,
                                              c.cpu_threads == 1 ? "" : "s")});
  if (c.N_CW > 0) t.row({"N_CW", count_str(c.N_CW), "of N_C, FLOPs of sliding-window loops (one unaligned load per FMA)"});
  t.row({"N_CC", count_str(c.N_CC), "values through host memory (extended model)"});
  t.row({"N_G", count_str(c.N_G), "FLOPs on the GPU"});
  if (c.N_GR > 0) t.row({"N_GR", count_str(c.N_GR), "of N_G, FLOPs whose taps each read another row of device memory"});
  t.row({"N_GS", count_str(c.N_GS), "values kernels copy into shared-memory tiles (per busiest-SM round x SMs)"});
  t.row({"launches", count_str(c.launches), "kernel launches"});
  t.row({"waves", count_str(c.waves), "rounds of thread blocks on the busiest GPU multiprocessor"});
  t.row({"atomics", count_str(c.atomics), "atomic updates of one device address (serialized)"});
  t.row({"host_waits", count_str(c.host_waits), "host submits device work and waits for it"});
  t.row({"cpu_syncs", count_str(c.cpu_syncs), "CPU thread forks/joins and barriers"});
  t.row({"host memory", std::string(to_string(c.host_memory)), ""});
  fmt::print("{}", t.str());
}

void print_prediction(const Prediction& p) {
  Table t({"component", "time", "share"});
  auto share = [&p](double v) { return p.total > 0 ? fmt::format("{:.1f}%", 100 * v / p.total) : "-"; };
  auto add = [&](const char* name, double v) { t.row({name, format_duration(v), share(v)}); };
  add("dt_CG  host->device", p.dt_CG);
  add("dt_GC  device->host", p.dt_GC);
  add("dt_GG  device memory", p.dt_GG);
  add("dt_C   CPU", p.dt_C);
  add("dt_G   GPU arithmetic", p.dt_G);
  if (p.variant != Variant::seed) {
    add("latency host->device", p.lat_CG);
    add("latency device->host", p.lat_GC);
    add("kernel launches", p.lat_launch);
    add("waves of thread blocks", p.lat_wave);
    add("serialized atomic updates", p.lat_atomic);
    add("shared-memory tile fills", p.dt_GS);
    add("host waits for the device", p.lat_wait);
    t.row({"  of which CPU thread syncs", format_duration(p.lat_sync), "(in dt_C)"});
  }
  t.row({"total", format_duration(p.total), ""});
  fmt::print("{}", t.str());
  if (p.variant == Variant::extended)
    fmt::print("(extended variant: device time is max(dt_GG, dt_G), so shares of the total may "
               "add up to more than 100%)\n");
}

}  // namespace dtflop::cli
