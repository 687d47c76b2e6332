#include "model/terms.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace dtflop {

std::string_view to_string(Phase p) {
  switch (p) {
    case Phase::CG: return "CG";
    case Phase::GC: return "GC";
    case Phase::G: return "G";
    case Phase::C: return "C";
    case Phase::wait: return "wait";
    case Phase::net: return "net";
  }
  return "?";
}

std::string_view describe(Phase p) {
  switch (p) {
    case Phase::CG: return "host->device copies";
    case Phase::GC: return "device->host copies";
    case Phase::G: return "kernels";
    case Phase::C: return "CPU work (dt_C)";
    case Phase::wait: return "host waits for the device";
    case Phase::net: return "messages between processes";
  }
  return "?";
}

const std::vector<Phase>& all_phases() {
  static const std::vector<Phase> all = {Phase::CG, Phase::GC, Phase::G, Phase::C, Phase::wait, Phase::net};
  return all;
}

std::string Variants::str() const {
  bool every = true;
  std::string out;
  for (Variant v : all_variants()) {
    if (!contains(v)) {
      every = false;
      continue;
    }
    out += fmt::format("{}{}", out.empty() ? "" : ", ", to_string(v));
  }
  return every ? std::string("every variant") : out;
}

Pricing Pricing::of(const MachineProfile& m) {
  return {model_llc_bytes(m.identity), has_staging(m), m.has(Param::K_CW_all) || m.has(Param::K_CA_all),
          m.has(Param::V_CS), m.has(Param::B_L2) ? m.identity.gpu_l2_bytes : 0, m.has(Param::L_graph),
          m.has(Param::L_pixel_all), m.has(Param::V_CM), m.has(Param::V_CM_all),
          m.has(Param::V_GM), m.has(Param::L_GP), 
          m.has(Param::L_label) && m.has(Param::L_hist) && m.has(Param::L_scan),
          m.has(Param::L_label_all) && m.has(Param::L_hist_all) && m.has(Param::L_scan_all),
          m.has(Param::L_pass_all), m.has(Param::K_GW), m.has(Param::L_match), m.has(Param::L_GF),
          m.has(Param::L_record)};
}

namespace {

// ---- Which parameter prices a term, for given counts ----------------------------------------

bool pinned(const CostCounts& c) { return c.host_memory == HostMemory::pinned; }
Param b_cg(const CostCounts& c) { return pinned(c) ? Param::B_CG_pinned : Param::B_CG_pageable; }
Param b_gc(const CostCounts& c) { return pinned(c) ? Param::B_GC_pinned : Param::B_GC_pageable; }
Param l_cg(const CostCounts& c) { return pinned(c) ? Param::L_CG_pinned : Param::L_CG_pageable; }
Param l_gc(const CostCounts& c) { return pinned(c) ? Param::L_GC_pinned : Param::L_GC_pageable; }
bool fp64(const CostCounts& c) { return c.precision == Precision::fp64; }
Param v_c1(const CostCounts& c) { return fp64(c) ? Param::V_C1_fp64 : Param::V_C1_fp32; }
Param v_c(const CostCounts& c) { return fp64(c) ? Param::V_C_fp64 : Param::V_C_fp32; }
Param v_g(const CostCounts& c) { return fp64(c) ? Param::V_G_fp64 : Param::V_G_fp32; }
template <Param P>
Param only(const CostCounts&) {
  return P;
}
// A CPU figure on cpu_threads threads: the one-thread figure, and for more threads the
// all-thread one too (cpu_rate() picks between them).
std::vector<Param> cpu_params(Param one, Param all, int threads) {
  if (threads <= 1) return {one};
  return {one, all};
}

// ---- The shapes of the simple terms ----------------------------------------------------------

using Pick = Param (*)(const CostCounts&);

template <std::int64_t CostCounts::*N>
bool positive(const CostCounts& c) {
  return c.*N > 0;
}
template <Pick pick>
std::vector<Param> needs_one(const CostCounts& c, Variant, const Pricing&) {
  return {pick(c)};
}
// P N / B: values moved over a bandwidth.
template <std::int64_t CostCounts::*N, Pick B>
double bytes_over_bandwidth(const MachineProfile& m, const CostCounts& c, Variant, const Pricing&) {
  const double P = c.P;
  return P * static_cast<double>(c.*N) / m.get(B(c)).value;
}
// n L: events that each cost a fixed time.
template <std::int64_t CostCounts::*N, Pick L>
double events_times_latency(const MachineProfile& m, const CostCounts& c, Variant, const Pricing&) {
  return static_cast<double>(c.*N) * m.get(L(c)).value;
}

// ---- The terms with rules of their own --------------------------------------------------------

// FLOPs of which `part` cost `k` times the others, in FLOPs at the plain rate.
double priced_flops(std::int64_t all, std::int64_t part, double k) {
  return static_cast<double>(all) + (k - 1) * static_cast<double>(part);
}

// dt_GC. A pageable device->host copy is staged through pinned memory: with the copies' sizes
// counted and the staging figures known, latency+ prices it per copy by its size
// (docs/model.md 2.1); otherwise P N_GC / B_GC as the seed's eq. 3.6.
bool staged(const CostCounts& c, Variant v, const Pricing& x) {
  return x.staging && kLatencyVariants.contains(v) && c.host_memory == HostMemory::pageable && !c.copies_GC.empty();
}
std::vector<Param> gc_needs(const CostCounts& c, Variant v, const Pricing& x) {
  if (staged(c, v, x)) return {b_gc(c), Param::B_GC_staged, Param::S_GC_staged, Param::S_GC_flat};
  return {b_gc(c)};
}
double gc_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  if (!staged(c, v, x)) return bytes_over_bandwidth<&CostCounts::N_GC, b_gc>(m, c, v, x);
  double s = 0;
  for (const CopySize& copy : c.copies_GC) s += static_cast<double>(copy.count) * staged_copy_seconds(m, copy.bytes);
  return s;
}

// dt_GG. latency+: the share of the kernels' traffic the GPU's L2 cache serves (0 < gpu_footprint <
// L2, where the profile has B_L2) at B_L2, the rest at B_GG, as the CPU's last-level cache is
// priced (docs/model.md 2.2): w = gpu_footprint / L2 of it at B_GG; the whole-frame passes' values
// (N_GG_frame) left out where lat_GF prices those passes. Seed: P N_GG / B_GG (eq. 3.4).
bool frame_passes(const CostCounts& c, Variant v, const Pricing& x) {
  return x.gpu_frame && kLatencyVariants.contains(v) && c.gpu_frame_pixels > 0;
}
std::int64_t gg_values(const CostCounts& c, Variant v, const Pricing& x) {
  return c.N_GG - (frame_passes(c, v, x) ? c.N_GG_frame : 0);
}
bool l2_served(const CostCounts& c, Variant v, const Pricing& x) {
  return kLatencyVariants.contains(v) && c.gpu_footprint > 0 && c.gpu_footprint < x.gpu_l2_bytes;
}
std::vector<Param> gg_needs(const CostCounts& c, Variant v, const Pricing& x) {
  if (gg_values(c, v, x) <= 0) return {};
  if (l2_served(c, v, x)) return {Param::B_GG, Param::B_L2};
  return {Param::B_GG};
}
double gg_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  const std::int64_t values = gg_values(c, v, x);
  if (values <= 0) return 0;
  const double bytes = static_cast<double>(c.P) * static_cast<double>(values);
  if (!l2_served(c, v, x)) return bytes / m.get(Param::B_GG).value;
  const double w = static_cast<double>(c.gpu_footprint) / static_cast<double>(x.gpu_l2_bytes);
  return bytes * (w / m.get(Param::B_GG).value + (1 - w) / m.get(Param::B_L2).value);
}

// lat_launch and lat_graph (latency+). The kernels of a CUDA graph (graph_launches) are started by
// the device, one after another: L_graph each where the profile has it; every other launch, and
// all of them on a profile without L_graph, L_launch (docs/model.md 2.2).
std::int64_t host_launches(const CostCounts& c, const Pricing& x) {
  return c.launches - (x.graph ? c.graph_launches : 0);
}
std::vector<Param> launch_needs(const CostCounts& c, Variant, const Pricing& x) {
  if (host_launches(c, x) > 0) return {Param::L_launch};
  return {};
}
double launch_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing& x) {
  const std::int64_t n = host_launches(c, x);
  return n > 0 ? static_cast<double>(n) * m.get(Param::L_launch).value : 0.0;
}
std::vector<Param> graph_needs(const CostCounts& c, Variant, const Pricing& x) {
  if (x.graph && c.graph_launches > 0) return {Param::L_graph};
  return {};
}
double graph_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing& x) {
  if (!x.graph || c.graph_launches <= 0) return 0;
  return static_cast<double>(c.graph_launches) * m.get(Param::L_graph).value;
}

// dt_G. latency+: the FLOPs whose taps read across rows (N_GR) cost K_GR times the others (each
// tap fetches a new line through the caches), those whose taps read along a row (N_GW) K_GW times
// where the profile has K_GW (a load and its bounds test beside every FMA): docs/model.md 2.2.
bool across_rows(const CostCounts& c, Variant v) { return kLatencyVariants.contains(v) && c.N_GR > 0; }
bool along_row(const CostCounts& c, Variant v, const Pricing& x) {
  return x.along_row && kLatencyVariants.contains(v) && c.N_GW > 0;
}
std::vector<Param> g_needs(const CostCounts& c, Variant v, const Pricing& x) {
  std::vector<Param> out = {v_g(c)};
  if (across_rows(c, v)) out.push_back(Param::K_GR);
  if (along_row(c, v, x)) out.push_back(Param::K_GW);
  return out;
}
double g_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  double flops = priced_flops(c.N_G, c.N_GR, across_rows(c, v) ? m.get(Param::K_GR).value : 1.0);
  if (along_row(c, v, x)) flops += (m.get(Param::K_GW).value - 1) * static_cast<double>(c.N_GW);
  return flops / m.get(v_g(c)).value;
}

// dt_C_arith. Over the CPU rate of cpu_threads threads (docs/model.md 2.3); memory and extended:
// the sliding-window FLOPs (N_CW) cost K_CW times the others (their loads, one per FMA and most
// of them unaligned, hold the arithmetic back), the chained ones (N_CD) K_CD times (each tap's
// addition waits for the one before: docs/model.md 2.4).
bool sliding_window(const CostCounts& c, Variant v) { return kHostMemoryVariants.contains(v) && c.N_CW > 0; }
bool chained_window(const CostCounts& c, Variant v) { return kHostMemoryVariants.contains(v) && c.N_CD > 0; }
bool aligned_window(const CostCounts& c, Variant v) { return kHostMemoryVariants.contains(v) && c.N_CA > 0; }
// latency+: a serial chain (N_CS) runs at its own rate V_CS, on one thread whatever cpu_threads is,
// where the profile has V_CS (or a fit is to find it); a profile made before the probe measured it
// prices the chain at the CPU rate, as it was fitted to (like the staging figures, docs/model.md 2.4).
bool serial_chain(const CostCounts& c, Variant v, const Pricing& x) {
  return x.serial && kLatencyVariants.contains(v) && c.N_CS > 0;
}
// latency+: the FLOPs of moving-least-squares fields (N_CM) run at their own rate, V_CM on one
// thread and V_CM_all on several where the profile has it (docs/model.md 2.6); a profile without
// the rate they would run at prices them at the CPU rate, as the fits made before the probe were.
// (On several threads V_CM_all alone will do: a cpu-par calibration carries it without V_CM.)
bool mls_fields(const CostCounts& c, Variant v, const Pricing& x) {
  return (x.mls || (x.mls_all && c.cpu_threads > 1)) && kLatencyVariants.contains(v) && c.N_CM > 0;
}
Param v_cm(const CostCounts& c, const Pricing& x) {
  return x.mls_all && c.cpu_threads > 1 ? Param::V_CM_all : Param::V_CM;
}
// The FLOPs of N_C priced at their own rates (N_CS, N_CM), the rest at the CPU rate.
std::int64_t apart_flops(const CostCounts& c, Variant v, const Pricing& x) {
  return (serial_chain(c, v, x) ? c.N_CS : 0) + (mls_fields(c, v, x) ? c.N_CM : 0);
}
std::vector<Param> c_needs(const CostCounts& c, Variant v, const Pricing& x) {
  const bool serial = serial_chain(c, v, x);
  std::vector<Param> out;
  if (c.N_C > apart_flops(c, v, x)) out = cpu_params(v_c1(c), v_c(c), c.cpu_threads);
  const bool all = x.all_threads && c.cpu_threads > 1;
  if (sliding_window(c, v)) out.push_back(all ? Param::K_CW_all : Param::K_CW);
  if (chained_window(c, v)) out.push_back(Param::K_CD);
  if (aligned_window(c, v)) out.push_back(all ? Param::K_CA_all : Param::K_CA);
  if (serial) out.push_back(Param::V_CS);
  if (mls_fields(c, v, x)) out.push_back(v_cm(c, x));
  return out;
}
double c_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  const bool serial = serial_chain(c, v, x);
  const bool all = x.all_threads && c.cpu_threads > 1;  // the windows' ratios with every thread at work
  const double flops = priced_flops(c.N_C - apart_flops(c, v, x), c.N_CW,
                                    sliding_window(c, v) ? m.get(all ? Param::K_CW_all : Param::K_CW).value : 1.0) +
                       (chained_window(c, v) ? m.get(Param::K_CD).value - 1 : 0.0) * static_cast<double>(c.N_CD) +
                       (aligned_window(c, v) ? m.get(all ? Param::K_CA_all : Param::K_CA).value - 1 : 0.0) *
                           static_cast<double>(c.N_CA);
  const double rest = flops > 0 ? flops / cpu_rate(m, c.precision, c.cpu_threads) : 0.0;
  return rest + (serial ? static_cast<double>(c.N_CS) / m.get(Param::V_CS).value : 0.0) +
         (mls_fields(c, v, x) ? static_cast<double>(c.N_CM) / m.get(v_cm(c, x)).value : 0.0);
}

// dt_net: bytes (not values of P bytes) over B_net.
double net_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing&) {
  return static_cast<double>(c.net_bytes) / m.get(Param::B_net).value;
}

// dt_peer and dt_allreduce: the messages between the partitions of one grid (docs/model.md 2.9),
// priced by where they travel. Between GPUs (PeerPath::link): L_peer per message and P N_peer over
// B_peer; L_allreduce per all-reduce and its bytes over B_allreduce. Inside one device
// (PeerPath::device): a halo message is a device-to-device copy, a launch's fixed cost and its
// values read and written at the copy bandwidth B_GG_copy (read + write counted); an all-reduce
// is a reduction kernel, a launch and its bytes (reads + writes) at B_GG.
bool peers_on_device(const CostCounts& c) { return c.peer_path == PeerPath::device; }
bool peer_counted(const CostCounts& c) { return c.peer_messages > 0 || c.N_peer > 0; }
std::vector<Param> peer_needs(const CostCounts& c, Variant, const Pricing&) {
  std::vector<Param> out;
  if (c.peer_messages > 0) out.push_back(peers_on_device(c) ? Param::L_launch : Param::L_peer);
  if (c.N_peer > 0) out.push_back(peers_on_device(c) ? Param::B_GG_copy : Param::B_peer);
  return out;
}
double peer_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing&) {
  const double P = c.P;
  double s = 0;
  if (c.peer_messages > 0)
    s += static_cast<double>(c.peer_messages) * m.get(peers_on_device(c) ? Param::L_launch : Param::L_peer).value;
  if (c.N_peer > 0)
    s += peers_on_device(c) ? 2 * P * static_cast<double>(c.N_peer) / m.get(Param::B_GG_copy).value
                      : P * static_cast<double>(c.N_peer) / m.get(Param::B_peer).value;
  return s;
}
bool allreduce_counted(const CostCounts& c) { return c.collectives > 0 || c.collective_bytes > 0; }
std::vector<Param> allreduce_needs(const CostCounts& c, Variant, const Pricing&) {
  std::vector<Param> out;
  if (c.collectives > 0) out.push_back(peers_on_device(c) ? Param::L_launch : Param::L_allreduce);
  if (c.collective_bytes > 0) out.push_back(peers_on_device(c) ? Param::B_GG : Param::B_allreduce);
  return out;
}
double allreduce_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing&) {
  double s = 0;
  if (c.collectives > 0)
    s += static_cast<double>(c.collectives) * m.get(peers_on_device(c) ? Param::L_launch : Param::L_allreduce).value;
  if (c.collective_bytes > 0)
    s += static_cast<double>(c.collective_bytes) / m.get(peers_on_device(c) ? Param::B_GG : Param::B_allreduce).value;
  return s;
}

// lat_pixel. A step of pixel work costs L_pixel on one thread; on several, the wall time of a step
// the threads share, L_pixel_all, where the profile has it (docs/model.md 2.6). Where the profile
// has the figures of each kind of step (the cpu-pixel probe times them apart), a labelled pixel
// (label_steps) costs L_label, a histogram's count (hist_steps) L_hist and every other step L_scan
// (L_label_all, L_hist_all, L_scan_all on several threads): a labelling costs several times a
// count or a label read, and frames differ in how much of their pixel work each kind is. The
// richest figures the profile has price the steps.
struct PixelPrices {
  Param label, hist, scan;  // by kind; all three the same figure where the kinds are not apart
  bool by_kind;
};
bool kinds_counted(const CostCounts& c) { return c.label_steps > 0 || c.hist_steps > 0; }
PixelPrices pixel_prices(const CostCounts& c, const Pricing& x) {
  const bool many = c.cpu_threads > 1;
  if (kinds_counted(c) && many && x.pixel_kinds_all)
    return {Param::L_label_all, Param::L_hist_all, Param::L_scan_all, true};
  if (many && x.pixel_all) return {Param::L_pixel_all, Param::L_pixel_all, Param::L_pixel_all, false};
  if (kinds_counted(c) && x.pixel_kinds) return {Param::L_label, Param::L_hist, Param::L_scan, true};
  return {Param::L_pixel, Param::L_pixel, Param::L_pixel, false};
}
std::int64_t scan_steps(const CostCounts& c) { return c.pixel_steps - c.label_steps - c.hist_steps; }
// On several threads, priced by kind, a frame's passes also cost a fixed L_pass_all each where the
// profile has it: the probe finds the kinds' figures as the slopes of its passes over two frame
// sizes and this as what is left at none (threads woken, stripes merged, the parallel labelling's
// set-up), which a per-step figure measured on one frame size spreads over its steps.
bool passes_priced(const CostCounts& c, const Pricing& x, const PixelPrices& p) {
  return p.by_kind && p.label == Param::L_label_all && x.pixel_pass_all && c.pixel_passes > 0;
}
std::vector<Param> pixel_needs(const CostCounts& c, Variant, const Pricing& x) {
  const PixelPrices p = pixel_prices(c, x);
  if (!p.by_kind) return {p.label};
  std::vector<Param> out;
  if (c.label_steps > 0) out.push_back(p.label);
  if (c.hist_steps > 0) out.push_back(p.hist);
  if (scan_steps(c) > 0) out.push_back(p.scan);
  if (passes_priced(c, x, p)) out.push_back(Param::L_pass_all);
  return out;
}
double pixel_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing& x) {
  const PixelPrices p = pixel_prices(c, x);
  if (!p.by_kind) return static_cast<double>(c.pixel_steps) * m.get(p.label).value;
  double s = 0;
  if (c.label_steps > 0) s += static_cast<double>(c.label_steps) * m.get(p.label).value;
  if (c.hist_steps > 0) s += static_cast<double>(c.hist_steps) * m.get(p.hist).value;
  if (scan_steps(c) > 0) s += static_cast<double>(scan_steps(c)) * m.get(p.scan).value;
  if (passes_priced(c, x, p)) s += static_cast<double>(c.pixel_passes) * m.get(Param::L_pass_all).value;
  return s;
}

// dt_CC. The CPU work's host memory traffic, over the bandwidth of cpu_threads threads; the
// share the last-level cache serves (cpu_footprint < LLC) at the cache's (docs/model.md 2.4).
// Where the pixel steps are priced by kind, the values of their passes (N_CC_pixel) are not: the
// kinds' figures were timed on such passes, their memory traffic in them (docs/model.md 2.6).
std::int64_t cc_values(const CostCounts& c, const Pricing& x) {
  return c.N_CC - (c.pixel_steps > 0 && pixel_prices(c, x).by_kind ? c.N_CC_pixel : 0);
}
std::vector<Param> cc_needs(const CostCounts& c, Variant, const Pricing& x) {
  if (cc_values(c, x) <= 0) return {};
  auto out = cpu_params(Param::B_host_1, Param::B_host, c.cpu_threads);
  if (c.cpu_footprint > 0 && c.cpu_footprint < x.llc_bytes)
    for (Param p : cpu_params(Param::B_llc_1, Param::B_llc, c.cpu_threads)) out.push_back(p);
  return out;
}
double cc_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing& x) {
  const std::int64_t values = cc_values(c, x);
  if (values <= 0) return 0;
  return static_cast<double>(c.P) * static_cast<double>(values) * host_seconds_per_byte(m, c);
}

// The two simple shapes: P N / B, values moved over a bandwidth, and n L, events at a fixed cost.
// lat_GM. latency+: the field kernel gives each point a thread, and the points' threads run side by
// side (one round of them for any plan's points), so a field takes one point's chain of dependent
// rotations, square roots and divisions: N_GM at V_GM (docs/model.md 2.6). A profile without V_GM
// leaves the fields in N_G at the GPU's rate, as the fits made before the probe were.
std::vector<Param> gpu_mls_needs(const CostCounts&, Variant v, const Pricing& x) {
  if (x.gpu_mls && kLatencyVariants.contains(v)) return {Param::V_GM};
  return {};
}
double gpu_mls_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  if (!x.gpu_mls || !kLatencyVariants.contains(v)) return 0;
  return static_cast<double>(c.N_GM) / m.get(Param::V_GM).value;
}

// lat_GP. latency+: the DCT cuda backend's centroid kernel gives each dot a block that classifies
// its window's pixels from their neighbourhoods' labels, twice, between barriers: work that grows
// with the window pixels (gpu_pixel_steps) and that the blocks' branches and barriers bound, not
// the bytes N_GG counts for it (docs/model.md 2.6). The gpu-centroid probe measures L_GP; a profile
// without it leaves that work in N_GG at the device's bandwidth, as the fits made before it were.
std::vector<Param> gpu_pixel_needs(const CostCounts&, Variant v, const Pricing& x) {
  if (x.gpu_pixel && kLatencyVariants.contains(v)) return {Param::L_GP};
  return {};
}
// lat_match: the grid matching's steps at L_match; on a profile made before the cpu-match probe, at
// L_tree (the matching was a k-d tree's then, and a step of either is a few loads: 8.8 and 10.2 ns
// on the 2-vCPU VM, docs/model.md 2.6).
Param match_price(const Pricing& x) { return x.grid_match ? Param::L_match : Param::L_tree; }
std::vector<Param> match_needs(const CostCounts&, Variant, const Pricing& x) { return {match_price(x)}; }
double match_seconds(const MachineProfile& m, const CostCounts& c, Variant, const Pricing& x) {
  return static_cast<double>(c.match_steps) * m.get(match_price(x)).value;
}
// lat_record: the host's pass over component records at L_record; not priced on a profile made
// before the cpu-records probe (those fits took the pass into the matching's steps).
std::vector<Param> record_needs(const CostCounts&, Variant v, const Pricing& x) {
  if (x.records && kLatencyVariants.contains(v)) return {Param::L_record};
  return {};
}
double record_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  if (!x.records || !kLatencyVariants.contains(v)) return 0;
  return static_cast<double>(c.record_steps) * m.get(Param::L_record).value;
}
// lat_GF. latency+: the device's whole-frame passes, a thread a pixel (a threshold, a labelling's
// unions and relabellings, a histogram's counts), at L_GF a pixel of a pass: light threads whose
// issue bounds them, not the bytes they move (on a lent H200 1.8-3.9 ps a pixel where those bytes
// at B_GG come to 1-1.5; docs/model.md 2.6). The gpu-frame-pass probe times such passes, traffic
// included, so their values (N_GG_frame) leave dt_GG. A profile without L_GF prices the passes by
// their bytes, as the fits made before the probe were.
std::vector<Param> gpu_frame_needs(const CostCounts& c, Variant v, const Pricing& x) {
  if (frame_passes(c, v, x)) return {Param::L_GF};
  return {};
}
double gpu_frame_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  if (!frame_passes(c, v, x)) return 0;
  return static_cast<double>(c.gpu_frame_pixels) * m.get(Param::L_GF).value;
}
double gpu_pixel_seconds(const MachineProfile& m, const CostCounts& c, Variant v, const Pricing& x) {
  if (!x.gpu_pixel || !kLatencyVariants.contains(v)) return 0;
  return static_cast<double>(c.gpu_pixel_steps) * m.get(Param::L_GP).value;
}

template <std::int64_t CostCounts::*N, Pick B>
constexpr Price per_byte() {
  return {positive<N>, needs_one<B>, bytes_over_bandwidth<N, B>};
}
template <std::int64_t CostCounts::*N, Pick L>
constexpr Price per_event() {
  return {positive<N>, needs_one<L>, events_times_latency<N, L>};
}

}  // namespace

const std::vector<Term>& terms() {
  using P = Prediction;
  using C = CostCounts;
  constexpr auto sum = Combine::sum, overlap = Combine::overlap;
  static const std::vector<Term> table = {
      // name, field, phase, variants, combine, count, parameters, label, price
      {"dt_CG", &P::dt_CG, Phase::CG, kEveryVariant, sum, "P N_CG", "B_CG_pinned or B_CG_pageable (host_memory)",
       "host->device copies: bandwidth", per_byte<&C::N_CG, b_cg>()},
      {"lat_CG", &P::lat_CG, Phase::CG, kLatencyVariants, sum, "transfers_CG",
       "L_CG_pinned or L_CG_pageable (host_memory)", "host->device copies: latency",
       per_event<&C::transfers_CG, l_cg>()},
      {"dt_GC", &P::dt_GC, Phase::GC, kEveryVariant, sum,
       "P N_GC; latency+, pageable, sizes in copies_GC: each copy by its size (2.1)",
       "B_GC_pinned or B_GC_pageable (host_memory); staged: B_GC_staged, S_GC_staged, S_GC_flat",
       "device->host copies: bandwidth", {positive<&C::N_GC>, gc_needs, gc_seconds}},
      {"lat_GC", &P::lat_GC, Phase::GC, kLatencyVariants, sum, "transfers_GC",
       "L_GC_pinned or L_GC_pageable (host_memory)", "device->host copies: latency",
       per_event<&C::transfers_GC, l_gc>()},
      {"dt_GG", &P::dt_GG, Phase::G, kEveryVariant, overlap,
       "P N_GG, less N_GG_frame where lat_GF prices the frame passes; latency+, 0 < gpu_footprint < L2: w = "
       "gpu_footprint / L2 of it at B_GG, the rest at B_L2 (2.2)",
       "B_GG; B_L2 (latency+, 0 < gpu_footprint < L2, where the profile has it)", "device memory traffic",
       {positive<&C::N_GG>, gg_needs, gg_seconds}},
      {"dt_G", &P::dt_G, Phase::G, kEveryVariant, overlap,
       "N_G + (K_GR - 1) N_GR + (K_GW - 1) N_GW (where the profile has K_GW); seed: N_G",
       "V_G_fp32 or V_G_fp64 (precision); K_GR (latency+, N_GR > 0); K_GW (latency+, N_GW > 0, where the profile "
       "has it)", "GPU arithmetic",
       {positive<&C::N_G>, g_needs, g_seconds}},
      {"lat_launch", &P::lat_launch, Phase::G, kLatencyVariants, sum,
       "launches - graph_launches (all of them where the profile has no L_graph)", "L_launch", "kernel launches",
       {positive<&C::launches>, launch_needs, launch_seconds}},
      {"lat_graph", &P::lat_graph, Phase::G, kLatencyVariants, sum, "graph_launches", "L_graph (where the profile has it)",
       "kernels of CUDA graphs", {positive<&C::graph_launches>, graph_needs, graph_seconds}},
      {"lat_wave", &P::lat_wave, Phase::G, kLatencyVariants, sum, "waves", "L_wave", "rounds of thread blocks",
       per_event<&C::waves, only<Param::L_wave>>()},
      {"lat_atomic", &P::lat_atomic, Phase::G, kLatencyVariants, sum, "atomics", "L_atomic",
       "serialized atomic updates", per_event<&C::atomics, only<Param::L_atomic>>()},
      {"lat_GM", &P::lat_GM, Phase::G, kLatencyVariants, sum, "N_GM (where the profile has V_GM)", "V_GM",
       "one GPU thread's MLS chain", {positive<&C::N_GM>, gpu_mls_needs, gpu_mls_seconds}},
      {"lat_GP", &P::lat_GP, Phase::G, kLatencyVariants, sum, "gpu_pixel_steps (where the profile has L_GP)", "L_GP",
       "per-dot pixel classification on the device", {positive<&C::gpu_pixel_steps>, gpu_pixel_needs, gpu_pixel_seconds}},
      {"lat_GF", &P::lat_GF, Phase::G, kLatencyVariants, sum, "gpu_frame_pixels (where the profile has L_GF)",
       "L_GF", "the device's whole-frame passes, a thread a pixel",
       {positive<&C::gpu_frame_pixels>, gpu_frame_needs, gpu_frame_seconds}},
      {"dt_GS", &P::dt_GS, Phase::G, kLatencyVariants, sum, "P N_GS", "B_GS", "shared-memory tile fills",
       per_byte<&C::N_GS, only<Param::B_GS>>()},
      {"dt_C_arith", &P::dt_C_arith, Phase::C, kEveryVariant, overlap,
       "N_C + (K_CW - 1) N_CW + (K_CD - 1) N_CD + (K_CA - 1) N_CA, N_CS and N_CM apart (latency+); seed: N_C",
       "V_C1_fp32 or V_C1_fp64 (precision), and V_C_fp32 or V_C_fp64 for cpu_threads > 1 (2.3); K_CW (memory, "
       "extended, N_CW > 0); K_CD, K_CA (memory, extended, N_CD, N_CA > 0); K_CW_all, K_CA_all in place of K_CW, "
       "K_CA for cpu_threads > 1 where the profile has them; V_CS (latency+, N_CS > 0); V_CM, or V_CM_all for "
       "cpu_threads > 1 where the profile has it (latency+, N_CM > 0)",
       "CPU arithmetic", {positive<&C::N_C>, c_needs, c_seconds}},
      {"dt_CC", &P::dt_CC, Phase::C, kHostMemoryVariants, overlap,
       "P N_CC; less N_CC_pixel where the pixel steps are priced by kind (2.6)",
       "B_host_1, and B_host for cpu_threads > 1; B_llc_1 (and B_llc) when 0 < cpu_footprint < LLC (2.4)",
       "host memory traffic", {positive<&C::N_CC>, cc_needs, cc_seconds}},
      {"lat_sync", &P::lat_sync, Phase::C, kLatencyVariants, sum, "cpu_syncs", "L_sync", "CPU thread syncs",
       per_event<&C::cpu_syncs, only<Param::L_sync>>()},
      {"lat_tree", &P::lat_tree, Phase::C, kLatencyVariants, sum, "tree_steps", "L_tree", "host k-d tree steps",
       per_event<&C::tree_steps, only<Param::L_tree>>()},
      {"lat_match", &P::lat_match, Phase::C, kLatencyVariants, sum, "match_steps",
       "L_match; L_tree where the profile lacks it (made before the cpu-match probe)", "host grid matching steps",
       {positive<&C::match_steps>, match_needs, match_seconds}},
      {"lat_record", &P::lat_record, Phase::C, kLatencyVariants, sum, "record_steps",
       "L_record; nothing where the profile lacks it (made before the cpu-records probe)",
       "host pass over component records", {positive<&C::record_steps>, record_needs, record_seconds}},
      {"lat_pixel", &P::lat_pixel, Phase::C, kLatencyVariants, sum,
       "pixel_steps; where the profile has L_label, L_hist and L_scan: label_steps, hist_steps and the rest apart, "
       "and for cpu_threads > 1 pixel_passes",
       "L_pixel; L_pixel_all for cpu_threads > 1 where the profile has it; L_label, L_hist and L_scan (their _all "
       "for cpu_threads > 1) where it has them and label_steps or hist_steps > 0; L_pass_all (so priced on "
       "cpu_threads > 1, where the profile has it)", "host scalar pixel steps",
       {positive<&C::pixel_steps>, pixel_needs, pixel_seconds}},
      {"lat_wait", &P::lat_wait, Phase::wait, kLatencyVariants, sum, "host_waits", "L_wait",
       "host waits for the device", per_event<&C::host_waits, only<Param::L_wait>>()},
      {"lat_lap_CG", &P::lat_lap_CG, Phase::CG, kLatencyVariants, sum, "laps_CG", "L_wait",
       "host-timed laps of host->device copies", per_event<&C::laps_CG, only<Param::L_wait>>()},
      {"lat_lap_GC", &P::lat_lap_GC, Phase::GC, kLatencyVariants, sum, "laps_GC", "L_wait",
       "host-timed laps of device->host copies", per_event<&C::laps_GC, only<Param::L_wait>>()},
      {"lat_lap_G", &P::lat_lap_G, Phase::G, kLatencyVariants, sum, "laps_G", "L_wait",
       "host-timed laps of kernels", per_event<&C::laps_G, only<Param::L_wait>>()},
      {"lat_net", &P::lat_net, Phase::net, kLatencyVariants, sum, "net_messages", "L_net",
       "messages between processes: latency", per_event<&C::net_messages, only<Param::L_net>>()},
      {"dt_net", &P::dt_net, Phase::net, kEveryVariant, sum, "net_bytes (bytes)", "B_net",
       "messages between processes: bandwidth", {positive<&C::net_bytes>, needs_one<only<Param::B_net>>, net_seconds}},
      {"dt_peer", &P::dt_peer, Phase::G, kLatencyVariants, overlap,
       "peer_messages, P N_peer (peer_path)",
       "L_peer, B_peer (link); L_launch, B_GG_copy with 2 P N_peer (device)",
       "halo messages between partitions", {peer_counted, peer_needs, peer_seconds}},
      {"dt_allreduce", &P::dt_allreduce, Phase::G, kLatencyVariants, sum,
       "collectives, collective_bytes (bytes) (peer_path)",
       "L_allreduce, B_allreduce (link); L_launch, B_GG (device)", "all-reduces across partitions",
       {allreduce_counted, allreduce_needs, allreduce_seconds}},
  };
  return table;
}

double phase_seconds(const Prediction& p, Phase phase) {
  const bool max = p.variant == kOverlapVariant;
  double overlapping = 0, added = 0;
  for (const Term& t : terms()) {
    if (t.phase != phase) continue;
    const double s = p.*t.field;
    if (t.combine == Combine::sum) added += s;
    else overlapping = max ? std::max(overlapping, s) : overlapping + s;
  }
  return overlapping + added;
}

bool counts_phase(const CostCounts& c, Phase phase) {
  return std::any_of(terms().begin(), terms().end(),
                     [&](const Term& t) { return t.phase == phase && t.price.counted(c); });
}

double Prediction::device_overheads() const {
  double s = 0;
  for (const Term& t : terms())
    if (t.phase == Phase::G && t.combine == Combine::sum) s += this->*t.field;
  return s;
}

std::string terms_markdown() {
  std::string out =
      "| term | phase | variants | combines | counts | parameters | what |\n"
      "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const Term& t : terms())
    out += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", t.name, to_string(t.phase), t.variants.str(),
                       t.combine == Combine::sum ? "sum" : "overlap", t.count, t.params, t.label);
  return out;
}

std::string counts_markdown() {
  std::string out =
      "| count | unit | meaning | steps and sums |\n"
      "| --- | --- | --- | --- |\n";
  for (const CountField& f : count_fields())
    out += fmt::format("| {} | {} | {} | {} |\n", f.name, f.unit, f.meaning,
                       f.accumulate == CountField::Accumulate::sum ? "added" : "the larger");
  return out;
}

}  // namespace dtflop
