#include "model/predict.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop {

std::string_view to_string(Variant v) {
  switch (v) {
    case Variant::seed: return "seed";
    case Variant::latency: return "latency";
    case Variant::memory: return "memory";
    case Variant::extended: return "extended";
  }
  return "?";
}

const std::vector<Variant>& all_variants() {
  static const std::vector<Variant> v = {Variant::seed, Variant::latency, Variant::memory, Variant::extended};
  return v;
}

std::string variant_names(std::string_view last_separator) {
  std::string out;
  const auto& v = all_variants();
  for (std::size_t i = 0; i < v.size(); ++i)
    out += fmt::format("{}{}", i == 0 ? "" : i + 1 == v.size() ? last_separator : std::string_view(", "), to_string(v[i]));
  return out;
}

std::optional<Variant> variant_from_string(std::string_view s) {
  for (auto v : all_variants())
    if (to_string(v) == s) return v;
  return std::nullopt;
}

namespace {

bool pinned(const CostCounts& c) { return c.host_memory == HostMemory::pinned; }
Param b_cg(const CostCounts& c) { return pinned(c) ? Param::B_CG_pinned : Param::B_CG_pageable; }
Param b_gc(const CostCounts& c) { return pinned(c) ? Param::B_GC_pinned : Param::B_GC_pageable; }
Param l_cg(const CostCounts& c) { return pinned(c) ? Param::L_CG_pinned : Param::L_CG_pageable; }
Param l_gc(const CostCounts& c) { return pinned(c) ? Param::L_GC_pinned : Param::L_GC_pageable; }
bool fp64(Precision p) { return p == Precision::fp64; }
Param v_c1(Precision p) { return fp64(p) ? Param::V_C1_fp64 : Param::V_C1_fp32; }
Param v_c(Precision p) { return fp64(p) ? Param::V_C_fp64 : Param::V_C_fp32; }
Param v_g(Precision p) { return fp64(p) ? Param::V_G_fp64 : Param::V_G_fp32; }

// Picks the single-thread or all-thread figure: one thread uses the first, as many
// threads as the machine has use the second, and in between threads x first, capped.
double scaled_rate(const MachineProfile& m, Param one, Param all, int threads) {
  if (threads <= 1) return m.get(one).value;
  const int hw = std::max(1, m.identity.cpu_threads);
  if (threads >= hw || !m.has(one)) return m.get(all).value;
  return std::min(threads * m.get(one).value, m.get(all).value);
}

std::vector<Param> cpu_params(Param one, Param all, int threads) {
  if (threads <= 1) return {one};
  return {one, all};
}

}  // namespace

double cpu_rate(const MachineProfile& m, Precision precision, int threads) {
  return scaled_rate(m, v_c1(precision), v_c(precision), threads);
}

double host_bandwidth(const MachineProfile& m, int threads) {
  return scaled_rate(m, Param::B_host_1, Param::B_host, threads);
}

double llc_share_missed(const MachineProfile& m, const CostCounts& c) {
  if (c.cpu_footprint <= 0 || m.identity.cpu_llc_bytes <= 0) return 1.0;
  return std::min(1.0, static_cast<double>(c.cpu_footprint) / static_cast<double>(m.identity.cpu_llc_bytes));
}

double host_seconds_per_byte(const MachineProfile& m, const CostCounts& c) {
  const double w = llc_share_missed(m, c);
  double s = w / host_bandwidth(m, c.cpu_threads);
  if (w < 1.0) s += (1.0 - w) / scaled_rate(m, Param::B_llc_1, Param::B_llc, c.cpu_threads);
  return s;
}

bool has_staging(const MachineProfile& m) {
  return m.has(Param::B_GC_staged) && m.has(Param::S_GC_staged) && m.has(Param::S_GC_flat);
}

double staged_copy_seconds(const MachineProfile& m, std::int64_t bytes) {
  const double b = static_cast<double>(bytes);
  const double staged = m.get(Param::S_GC_staged).value, flat = m.get(Param::S_GC_flat).value;
  return std::min(b, staged) / m.get(Param::B_GC_staged).value +
         std::max(b - staged - flat, 0.0) / m.get(Param::B_GC_pageable).value;
}

namespace {
// Parameters no probe measures: only `dtflop calibrate` finds them (docs/model.md, section 3).
bool fitted_only(Param p) {
  switch (p) {
    case Param::B_GS:
    case Param::L_atomic:
    case Param::B_GC_staged:
    case Param::S_GC_staged:
    case Param::S_GC_flat:
    case Param::K_CW:
    case Param::K_GR: return true;
    default: return false;
  }
}
// The variants that model the host's memory: its traffic, and load-bound CPU loops (N_CW).
bool models_host_memory(Variant v) { return v == Variant::memory || v == Variant::extended; }
// FLOPs of which `part` cost `k` times the others, in FLOPs at the plain rate.
double priced_flops(std::int64_t all, std::int64_t part, double k) {
  return static_cast<double>(all) + (k - 1) * static_cast<double>(part);
}
// The staging figures apply: latency variants, pageable device->host copies with their sizes.
bool uses_staging(const CostCounts& c, Variant variant, bool staged) {
  return staged && variant != Variant::seed && c.host_memory == HostMemory::pageable && !c.copies_GC.empty();
}
}  // namespace

std::vector<Param> required_params(const CostCounts& c, Variant variant, std::int64_t profile_llc, bool staged) {
  std::vector<Param> out;
  auto add = [&out](Param p) {
    if (std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
  };
  const bool lat = variant != Variant::seed;
  if (c.N_CG > 0) add(b_cg(c));
  if (c.N_GC > 0) add(b_gc(c));
  if (uses_staging(c, variant, staged))
    for (auto p : {Param::B_GC_staged, Param::S_GC_staged, Param::S_GC_flat}) add(p);
  if (c.N_GG > 0) add(Param::B_GG);
  if (c.N_C > 0)
    for (auto p : cpu_params(v_c1(c.precision), v_c(c.precision), c.cpu_threads)) add(p);
  if (c.N_G > 0) add(v_g(c.precision));
  if (lat && c.transfers_CG > 0) add(l_cg(c));
  if (lat && c.transfers_GC > 0) add(l_gc(c));
  if (lat && c.launches > 0) add(Param::L_launch);
  if (lat && c.waves > 0) add(Param::L_wave);
  if (lat && c.atomics > 0) add(Param::L_atomic);
  if (lat && c.host_waits > 0) add(Param::L_wait);
  if (lat && c.cpu_syncs > 0) add(Param::L_sync);
  if (lat && c.N_GS > 0) add(Param::B_GS);
  if (lat && c.N_GR > 0 && c.N_G > 0) add(Param::K_GR);
  if (models_host_memory(variant) && c.N_CW > 0 && c.N_C > 0) add(Param::K_CW);
  if (models_host_memory(variant) && c.N_CC > 0) {
    for (auto p : cpu_params(Param::B_host_1, Param::B_host, c.cpu_threads)) add(p);
    if (c.cpu_footprint > 0 && c.cpu_footprint < profile_llc)
      for (auto p : cpu_params(Param::B_llc_1, Param::B_llc, c.cpu_threads)) add(p);
  }
  return out;
}

Prediction predict(const MachineProfile& m, const CostCounts& c, Variant variant) {
  if (c.P <= 0) throw InputError(fmt::format("bytes per value P must be positive, got {}", c.P));
  // Report every missing parameter at once.
  std::string missing;
  if (!c.copies_GC.empty()) {
    std::int64_t bytes = 0, copies = 0;
    for (const CopySize& s : c.copies_GC) bytes += s.bytes * s.count, copies += s.count;
    if (bytes != c.P * c.N_GC || copies != c.transfers_GC)
      throw InputError(fmt::format(
          "the counts list device->host copies of {} bytes in {} copies, but P N_GC is {} bytes in "
          "transfers_GC = {} copies; the workload's counts are inconsistent",
          bytes, copies, c.P * c.N_GC, c.transfers_GC));
  }
  // A count of FLOPs of one kind is a part of all FLOPs.
  auto check_part = [](const char* part, std::int64_t n, const char* all, std::int64_t total, const char* kind) {
    if (n < 0 || n > total)
      throw InputError(fmt::format("the counts give {} = {} {} FLOPs of {} = {}; they are some of those FLOPs, so "
                                   "0 <= {} <= {}: the workload's counts are inconsistent",
                                   part, n, kind, all, total, part, all));
  };
  check_part("N_GR", c.N_GR, "N_G", c.N_G, "across-row");
  check_part("N_CW", c.N_CW, "N_C", c.N_C, "sliding-window");
  const bool staged = uses_staging(c, variant, has_staging(m));
  std::string unprobed;  // missing ones that only a fit finds
  for (auto p : required_params(c, variant, m.identity.cpu_llc_bytes, staged))
    if (!m.has(p)) {
      missing += fmt::format("{}{} ({})", missing.empty() ? "" : ", ", info(p).name, info(p).what);
      if (fitted_only(p)) unprobed += fmt::format("{}{}", unprobed.empty() ? "" : ", ", info(p).name);
    }
  if (!missing.empty())
    throw MissingParameter(fmt::format(
        "the machine profile lacks {} needed to predict this computation with the {} variant; {}", missing,
        to_string(variant),
        unprobed.empty()
            ? "probe a machine that has it (`dtflop probe`), or use one of the profiles in docs/examples/"
            : fmt::format("no probe measures {}: fit it to measured runs of this machine (`dtflop sweep`, then "
                          "`dtflop calibrate`, docs/calibration.md), or predict with a simpler --variant",
                          unprobed)));

  const double P = c.P;
  Prediction r;
  r.variant = variant;
  // Eqs. 3.5-3.9. A count of zero needs no parameter and costs nothing.
  if (c.N_CG > 0) r.dt_CG = P * static_cast<double>(c.N_CG) / m.get(b_cg(c)).value;
  if (c.N_GC > 0) r.dt_GC = P * static_cast<double>(c.N_GC) / m.get(b_gc(c)).value;
  if (c.N_GG > 0) r.dt_GG = P * static_cast<double>(c.N_GG) / m.get(Param::B_GG).value;
  // memory and extended: the sliding-window FLOPs cost K_CW times the others (their loads, one
  // per FMA and most of them unaligned, hold the arithmetic back: docs/model.md 2.4).
  if (c.N_C > 0)
    r.dt_C = priced_flops(c.N_C, c.N_CW, models_host_memory(variant) && c.N_CW > 0 ? m.get(Param::K_CW).value : 1.0) /
             cpu_rate(m, c.precision, c.cpu_threads);
  // latency+: the across-row FLOPs cost K_GR times the others (each tap fetches a new line
  // through the caches: docs/model.md 2.2).
  if (c.N_G > 0)
    r.dt_G = priced_flops(c.N_G, c.N_GR, variant != Variant::seed && c.N_GR > 0 ? m.get(Param::K_GR).value : 1.0) /
             m.get(v_g(c.precision)).value;

  if (variant == Variant::seed) {
    r.total = r.dt_CG + r.dt_GC + r.dt_GG + r.dt_C + r.dt_G;  // eqs. 3.2, 3.4
    return r;
  }
  // A pageable device->host copy is staged through pinned memory: priced per copy by its size.
  if (staged) {
    r.dt_GC = 0;
    for (const CopySize& s : c.copies_GC) r.dt_GC += static_cast<double>(s.count) * staged_copy_seconds(m, s.bytes);
  }
  if (c.transfers_CG > 0) r.lat_CG = static_cast<double>(c.transfers_CG) * m.get(l_cg(c)).value;
  if (c.transfers_GC > 0) r.lat_GC = static_cast<double>(c.transfers_GC) * m.get(l_gc(c)).value;
  if (c.launches > 0) r.lat_launch = static_cast<double>(c.launches) * m.get(Param::L_launch).value;
  if (c.cpu_syncs > 0) r.lat_sync = static_cast<double>(c.cpu_syncs) * m.get(Param::L_sync).value;
  if (c.waves > 0) r.lat_wave = static_cast<double>(c.waves) * m.get(Param::L_wave).value;
  // Atomic updates of one address queue at the memory that holds it: the last block of a kernel
  // finishes after all of them.
  if (c.atomics > 0) r.lat_atomic = static_cast<double>(c.atomics) * m.get(Param::L_atomic).value;
  if (c.host_waits > 0) r.lat_wait = static_cast<double>(c.host_waits) * m.get(Param::L_wait).value;
  // A block fills its tile before it computes on it: the fills add to the kernels' time.
  if (c.N_GS > 0) r.dt_GS = P * static_cast<double>(c.N_GS) / m.get(Param::B_GS).value;
  const double latencies = r.lat_CG + r.lat_GC + r.lat_wait + r.device_overheads();
  const double host_traffic =
      models_host_memory(variant) && c.N_CC > 0 ? P * static_cast<double>(c.N_CC) * host_seconds_per_byte(m, c) : 0;
  if (variant == Variant::latency || variant == Variant::memory) {
    // memory: the CPU work's memory traffic adds to its arithmetic, as device traffic does.
    r.dt_C += host_traffic + r.lat_sync;
    r.total = r.dt_CG + r.dt_GC + r.dt_GG + r.dt_C + r.dt_G + latencies;
    return r;
  }
  // extended: a kernel streams memory while it computes, so device time is the larger of
  // the two (roofline); CPU work likewise overlaps its memory traffic with arithmetic.
  r.dt_C = std::max(r.dt_C, host_traffic) + r.lat_sync;
  r.total = r.dt_CG + r.dt_GC + std::max(r.dt_GG, r.dt_G) + r.dt_C + latencies;
  return r;
}

}  // namespace dtflop
