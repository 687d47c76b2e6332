// The machine report: what `dtflop probe` (or a fit) says about one machine.
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <fmt/format.h>

#include "model/profile.hpp"
#include "calibrate/sample.hpp"
#include "model/units.hpp"
#include "reports/common.hpp"
#include "reports/reports.hpp"

namespace dtflop::reports {

std::vector<std::pair<double, double>> decode_transfer_points(const std::string& text) {
  std::vector<std::pair<double, double>> out;
  std::istringstream in(text);
  std::string item;
  while (in >> item) {
    const auto colon = item.find(':');
    if (colon == std::string::npos) return {};
    char* end = nullptr;
    const std::string a = item.substr(0, colon), b = item.substr(colon + 1);
    const double bytes = std::strtod(a.c_str(), &end);
    if (end != a.c_str() + a.size()) return {};
    const double s = std::strtod(b.c_str(), &end);
    if (end != b.c_str() + b.size()) return {};
    if (!(bytes > 0) || !(s > 0) || !std::isfinite(bytes) || !std::isfinite(s)) return {};
    out.emplace_back(bytes, s);
  }
  return out;
}

namespace {

// A log axis only where the values span more than a factor of 20.
bool needs_log(const Chart& c) {
  double lo = INFINITY, hi = 0;
  for (const auto& s : c.series)
    for (const auto& p : s.points)
      if (p.y > 0) lo = std::min(lo, p.y), hi = std::max(hi, p.y);
  return hi > 0 && hi / lo > 20;
}

struct TransferSeries {
  const char* key;  // probe series ("h2d_pinned")
  const char* memory;
  Param bandwidth, latency;
};
struct Direction {
  const char* id;
  const char* title;
  TransferSeries kinds[2];
};
const Direction kDirections[] = {
    {"h2d", "host->device", {{"h2d_pinned", "pinned", Param::B_CG_pinned, Param::L_CG_pinned},
                             {"h2d_pageable", "pageable", Param::B_CG_pageable, Param::L_CG_pageable}}},
    {"d2h", "device->host", {{"d2h_pinned", "pinned", Param::B_GC_pinned, Param::L_GC_pinned},
                             {"d2h_pageable", "pageable", Param::B_GC_pageable, Param::L_GC_pageable}}},
};

// FP32 and FP64 lanes per multiprocessor by compute capability: the peak is SMs x lanes x 2 FLOP
// (one FMA) x clock. Only architectures whose figures NVIDIA publishes in the CUDA programming
// guide's throughput table are listed; others get no peak.
std::optional<std::pair<int, int>> gpu_lanes(const std::string& cc) {
  if (cc == "7.0") return std::pair{64, 32};
  if (cc == "8.0") return std::pair{64, 32};
  if (cc == "8.6" || cc == "8.9") return std::pair{128, 2};
  if (cc == "9.0") return std::pair{128, 64};
  return std::nullopt;
}

std::string md(const MachineProfile& p, const std::string& key) {
  auto it = p.metadata.find(key);
  return it == p.metadata.end() ? std::string() : it->second;
}

}  // namespace

Document machine_report(const MachineProfile& p, const Context& ctx) {
  Document doc;
  doc.kind = "machine";
  doc.title = "Machine report: " + dtflop::describe(p.identity);
  doc.stamp = make_stamp(ctx, dtflop::describe(p.identity), p.identity.measured_at);

  // Identity.
  Section id{"Machine", {}};
  Table t{{"", ""}, {}, "ll"};
  const auto& i = p.identity;
  t.rows.push_back({"CPU", fmt::format("{} ({} cores, {} threads{})", i.cpu_model, i.cpu_cores, i.cpu_threads,
                                       i.cpu_clock_ghz ? fmt::format(", {:.3g} GHz nominal", *i.cpu_clock_ghz) : "")});
  if (i.cpu_llc_bytes > 0) t.rows.push_back({"last-level cache", format_bytes(static_cast<double>(i.cpu_llc_bytes))});
  if (const auto isa = md(p, "probe.cpu_isa"); !isa.empty()) t.rows.push_back({"CPU vector ISA used", isa});
  if (!i.gpu_name.empty()) {
    std::string g = i.gpu_name;
    if (i.gpu_sms > 0) g += fmt::format(", {} SMs", i.gpu_sms);
    if (const auto cc = md(p, "probe.gpu_compute_capability"); !cc.empty()) g += ", compute capability " + cc;
    if (const auto clk = md(p, "probe.gpu_sm_clock_ghz"); !clk.empty()) g += ", SM clock " + clk + " GHz";
    t.rows.push_back({"GPU", g});
    t.rows.push_back({"driver, CUDA", fmt::format("{}, CUDA {}", i.gpu_driver, i.cuda_version)});
  } else {
    t.rows.push_back({"GPU", md(p, "probe.gpu").empty() ? "none" : md(p, "probe.gpu")});
  }
  t.rows.push_back({"probed", fmt::format("{} ({} probe{})", i.measured_at, md(p, "probe.effort"),
                                          md(p, "probe.seconds").empty() ? "" : ", " + md(p, "probe.seconds") + " s")});
  if (const auto fitted = md(p, "fitted_at"); !fitted.empty())
    t.rows.push_back({"fitted", fitted + " (" + md(p, "model_variant") + " variant)"});
  id.blocks.emplace_back(t);
  doc.sections.push_back(std::move(id));

  // Transfers.
  Section tr{"Host<->device transfers", {}};
  bool any_transfer = false, any_points = false;
  for (const auto& d : kDirections) {
    Chart c;
    c.id = fmt::format("transfers-{}", d.id);
    c.title = fmt::format("{} copies: bandwidth against size", d.title);
    c.x = {"bytes per copy [B]", true};
    c.y = {"effective bandwidth [B/s]", true};
    Table ft{{"memory", "bandwidth B", "+-95%", "latency L", "+-95%", "measured sizes"}, {}, "lrrrrr"};
    for (int k = 0; k < 2; ++k) {
      const auto& s = d.kinds[k];
      const Parameter* b = p.find(s.bandwidth);
      const Parameter* l = p.find(s.latency);
      const auto pts = decode_transfer_points(md(p, std::string("probe.transfers.") + s.key));
      if (!b && pts.empty()) continue;
      any_transfer = true;
      double lo = 4096, hi = 256.0 * 1024 * 1024;
      if (!pts.empty()) {
        any_points = true;
        lo = pts.front().first;
        hi = pts.back().first;
        for (const auto& [bytes, sec] : pts) lo = std::min(lo, bytes), hi = std::max(hi, bytes);
        Series m{fmt::format("{}: measured (median)", s.memory), SeriesKind::points, k, {}};
        for (const auto& [bytes, sec] : pts) m.points.push_back({bytes, bytes / sec, format_bytes(bytes)});
        c.series.push_back(std::move(m));
      }
      if (b) {
        const double L = l ? l->value : 0;
        Series fit{fmt::format("{}: fit L + bytes/B", s.memory), SeriesKind::line, k, {}};
        for (int j = 0; j <= 48; ++j) {
          const double bytes = lo * std::pow(hi / lo, j / 48.0);
          fit.points.push_back({bytes, bytes / (L + bytes / b->value), ""});
        }
        c.series.push_back(std::move(fit));
        Series asym{fmt::format("{}: B (large copies)", s.memory), SeriesKind::line, k, {}};
        asym.dashed = true;
        asym.points = {{lo, b->value, ""}, {hi, b->value, ""}};
        c.series.push_back(std::move(asym));
      }
      ft.rows.push_back({s.memory, b ? format_bandwidth(b->value) : "-",
                         b && b->uncertainty ? format_bandwidth(*b->uncertainty) : "-", l ? format_duration(l->value) : "-",
                         l && l->uncertainty ? format_duration(*l->uncertainty) : "-",
                         pts.empty() ? "not kept" : fmt::format("{} ({}..{})", pts.size(), format_bytes(lo), format_bytes(hi))});
    }
    if (c.series.empty()) continue;
    c.note = "A copy of n bytes takes L + n/B; its effective bandwidth n/(L + n/B) approaches B for large copies.";
    tr.blocks.emplace_back(std::move(c));
    tr.blocks.emplace_back(std::move(ft));
  }
  if (!any_transfer) {
    tr.blocks.emplace_back(Paragraph{"No host<->device transfer was measured (no GPU was probed)."});
  } else if (!any_points) {
    tr.blocks.emplace_back(Paragraph{
        "This profile keeps only the fitted curves, not the measured sizes: it was probed by a dtflop that did not "
        "store them. Probe again (dtflop probe) to see the points against the fit."});
  }
  doc.sections.push_back(std::move(tr));

  // Rates against peaks.
  Section rates{"Rates and bandwidths", {}};
  {
    Chart c;
    c.id = "flop-rates";
    c.title = "Floating-point rates against the peaks known";
    c.x = {"processor, precision, threads", false};
    c.y = {"rate [FLOP/s]", true};
    Series meas{"measured", SeriesKind::bars, 0, {}};
    Series peak{"peak", SeriesKind::points, 1, {}, true};
    const double threads = i.cpu_threads;
    auto add = [&](Param par, const std::string& label, std::optional<double> pk) {
      const Parameter* v = p.find(par);
      if (!v) return;
      const double x = static_cast<double>(c.categories.size());
      c.categories.push_back(label);
      meas.points.push_back({x, v->value, label});
      if (pk) peak.points.push_back({x, *pk, label});
    };
    auto one = [&](Param par) -> std::optional<double> {
      const Parameter* v = p.find(par);
      if (!v || threads <= 0) return std::nullopt;
      return v->value * threads;
    };
    add(Param::V_C1_fp32, "CPU FP32, 1 thread", std::nullopt);
    add(Param::V_C_fp32, "CPU FP32, all threads", one(Param::V_C1_fp32));
    add(Param::V_C1_fp64, "CPU FP64, 1 thread", std::nullopt);
    add(Param::V_C_fp64, "CPU FP64, all threads", one(Param::V_C1_fp64));
    std::optional<double> g32, g64;
    const auto lanes = gpu_lanes(md(p, "probe.gpu_compute_capability"));
    const double clk = std::atof(md(p, "probe.gpu_sm_clock_ghz").c_str());
    if (lanes && i.gpu_sms > 0 && clk > 0) {
      g32 = i.gpu_sms * lanes->first * 2.0 * clk * 1e9;
      g64 = i.gpu_sms * lanes->second * 2.0 * clk * 1e9;
    }
    add(Param::V_G_fp32, "GPU FP32", g32);
    add(Param::V_G_fp64, "GPU FP64", g64);
    if (!meas.points.empty()) {
      c.series.push_back(std::move(meas));
      if (!peak.points.empty()) c.series.push_back(std::move(peak));
      c.y.log = needs_log(c);
      c.note = "Peaks: for all CPU threads, the one-thread rate times the hardware threads (perfect scaling); for the "
               "GPU, SMs x FP lanes per SM x 2 FLOP x SM clock. None is drawn where it is not known.";
      rates.blocks.emplace_back(std::move(c));
    }
  }
  {
    Chart c;
    c.id = "bandwidths";
    c.title = "Memory bandwidths";
    c.x = {"memory, threads or direction", false};
    c.y = {"bandwidth [B/s]", true};
    Series meas{"measured", SeriesKind::bars, 2, {}};
    Series peak{"all threads if they scaled perfectly", SeriesKind::points, 1, {}, true};
    const double threads = i.cpu_threads;
    auto add = [&](Param par, const std::string& label, std::optional<Param> single) {
      const Parameter* v = p.find(par);
      if (!v) return;
      const double x = static_cast<double>(c.categories.size());
      c.categories.push_back(label);
      meas.points.push_back({x, v->value, label});
      if (single && p.find(*single) && threads > 1) peak.points.push_back({x, p.find(*single)->value * threads, label});
    };
    add(Param::B_host_1, "host, 1 thread", std::nullopt);
    add(Param::B_host, "host, all threads", Param::B_host_1);
    add(Param::B_llc_1, "LLC, 1 thread", std::nullopt);
    add(Param::B_llc, "LLC, all threads", Param::B_llc_1);
    add(Param::B_GG, "device, kernel", std::nullopt);
    add(Param::B_GG_copy, "device, cudaMemcpy", std::nullopt);
    add(Param::B_CG_pinned, "host->device pinned", std::nullopt);
    add(Param::B_GC_pinned, "device->host pinned", std::nullopt);
    add(Param::B_CG_pageable, "host->device pageable", std::nullopt);
    add(Param::B_GC_pageable, "device->host pageable", std::nullopt);
    if (!meas.points.empty()) {
      c.series.push_back(std::move(meas));
      if (!peak.points.empty()) c.series.push_back(std::move(peak));
      c.y.log = needs_log(c);
      c.note = "Memory bandwidths count bytes read and written. Host memory is shared by the threads, so the "
               "'perfect scaling' ring is an upper bound, not a peak the hardware promises.";
      rates.blocks.emplace_back(std::move(c));
    }
  }
  {
    Chart c;
    c.id = "latencies";
    c.title = "Fixed costs (latencies)";
    c.x = {"model parameter", false};
    c.y = {"time [s]", true};
    Series meas{"measured or fitted", SeriesKind::bars, 3, {}};
    for (const auto& pi : all_params()) {
      if (pi.unit != "s") continue;
      const Parameter* v = p.find(pi.id);
      if (!v || !(v->value > 0)) continue;
      const double x = static_cast<double>(c.categories.size());
      c.categories.push_back(std::string(pi.name));
      meas.points.push_back({x, v->value, std::string(pi.name)});
    }
    if (!meas.points.empty()) {
      c.series.push_back(std::move(meas));
      c.y.log = needs_log(c);
      rates.blocks.emplace_back(std::move(c));
    }
  }
  doc.sections.push_back(std::move(rates));

  // Every parameter.
  Section all{"Every parameter", {}};
  all.blocks.emplace_back(parameter_table(p, false));
  doc.sections.push_back(std::move(all));

  for (const auto& d : kDirections)
    for (const auto& s : d.kinds)
      if (const Parameter* b = p.find(s.bandwidth))
        doc.summary.push_back(fmt::format("{} {}: {} after {} per copy", d.title, s.memory, format_bandwidth(b->value),
                                          p.find(s.latency) ? format_duration(p.find(s.latency)->value) : "?"));
  if (const Parameter* v = p.find(Param::V_C_fp32)) doc.summary.push_back("CPU FP32, all threads: " + format_rate(v->value));
  if (const Parameter* v = p.find(Param::B_host)) doc.summary.push_back("host memory, all threads: " + format_bandwidth(v->value));
  if (const Parameter* v = p.find(Param::V_G_fp32)) doc.summary.push_back("GPU FP32: " + format_rate(v->value));
  if (const Parameter* v = p.find(Param::B_GG)) doc.summary.push_back("device memory: " + format_bandwidth(v->value));
  return doc;
}

}  // namespace dtflop::reports
