#include "workloads/rbe/band_counts.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "cuda/device.hpp"
#include "model/errors.hpp"
#include "workloads/rbe/motion.hpp"
#include "workloads/rbe/resident_geometry.hpp"

namespace dtflop::rbe {

BandPlan band_plan(const Shape& s, int partitions) {
  validate(s);
  if (partitions < 1 || partitions > kMaxPartitions)
    throw InputError(fmt::format("cuda-bands: {} partitions; give 1 to {}", partitions, kMaxPartitions));
  BandPlan p;
  p.halo_before = s.Iy - 1 - kernel_centre(s.Iy);
  p.halo_after = kernel_centre(s.Iy);
  p.ld = resident::row_pitch(s.nx);
  const std::int64_t G = partitions;
  const std::int64_t base = s.ny / G, taller = s.ny % G;
  const std::int64_t halo = std::max(p.halo_before, p.halo_after);
  if (G > 1 && base < std::max<std::int64_t>(halo, 1)) {
    const std::int64_t most = s.ny / std::max<std::int64_t>(halo, 1);
    throw InputError(fmt::format(
        "cuda-bands: {} partitions of a grid {} rows high make bands of {} rows, lower than the {} rows the {}-row "
        "kernel reaches past a cell (each halo must come from the next band alone); use at most {} partitions",
        partitions, s.ny, base, std::max<std::int64_t>(halo, 1), s.Iy, most));
  }
  std::int64_t first = 0;
  for (std::int64_t b = 0; b < G; ++b) {
    const std::int64_t rows = base + (b < taller ? 1 : 0);
    p.bands.push_back({first, rows});
    first += rows;
  }
  return p;
}

BandLaunches band_launches(const BandPlan& p, std::size_t b) {
  const std::int64_t rows = p.bands.at(b).rows;
  const bool above = b > 0, below = b + 1 < p.bands.size();
  // The edge rows: those that read a halo, and those sent to a neighbour (cuda-bands sends them
  // as soon as the edge launch has written them), so max(h_b, h_a) on each side with a neighbour.
  const std::int64_t reach = std::max(p.halo_before, p.halo_after);
  const std::int64_t lo = above ? reach : 0;
  const std::int64_t hi = below ? rows - reach : rows;
  BandLaunches l;
  if (lo >= hi) {  // too low for rows that need no halo
    l.edges.push_back({0, rows});
    return l;
  }
  l.inner.push_back({lo, hi});
  if (lo > 0) l.edges.push_back({0, lo});
  if (hi < rows) l.edges.push_back({hi, rows});
  return l;
}

HaloSends halo_sends(const BandPlan& p, std::size_t b) {
  HaloSends h;
  if (b > 0 && p.halo_after > 0) ++h.messages, h.values += p.halo_after * p.ld;
  if (b + 1 < p.bands.size() && p.halo_before > 0) ++h.messages, h.values += p.halo_before * p.ld;
  return h;
}

BandPlacement band_placement(int partitions, int gpus) {
  if (gpus < 1 || gpus > kMaxPartitions)
    throw InputError(fmt::format("cuda-bands: {} GPUs; give 1 to {}", gpus, kMaxPartitions));
  if (partitions < 1 || partitions > kMaxPartitions)
    throw InputError(fmt::format("cuda-bands: {} partitions; give 1 to {}", partitions, kMaxPartitions));
  if (gpus > 1 && partitions != gpus)
    throw InputError(fmt::format(
        "cuda-bands: {} partitions over {} GPUs; give one partition per GPU (--partitions {}) or put every "
        "partition on one GPU (--gpus 1)",
        partitions, gpus, gpus));
  return {partitions, gpus, gpus > 1 ? PeerPath::link : PeerPath::device};
}

BandPlacement band_placement(const BackendOptions& o) {
  if (o.gpus < 0 || o.partitions < 0)
    throw InputError(fmt::format("cuda-bands: --gpus {} --partitions {}; give counts >= 0 (0: every GPU, one "
                                 "partition per GPU)",
                                 o.gpus, o.partitions));
  const int gpus = o.gpus > 0 ? o.gpus : std::max(1, cuda::device_count());
  return band_placement(o.partitions > 0 ? o.partitions : gpus, gpus);
}

CostCounts fused_rows_counts(const Shape& s, const Layout& l, int sms, std::int64_t rows) {
  if (sms < 1) throw InputError(fmt::format("a GPU of {} multiprocessors cannot run cuda-bands; give at least 1", sms));
  const ResidentPlan p = resident_plan(s, l);
  if (p.passes != Layout::Passes::fused)
    throw InputError(fmt::format("cuda-bands runs cuda-resident's fused kernel only, and layout {} with a {}x{} kernel "
                                 "needs the split passes; use a layout whose fused tile fits (more rows per block, "
                                 "':fused'), or cuda-resident",
                                 to_string(l), s.Ix, s.Iy));
  const auto g = resident::fused_geometry(s, l);
  const std::int64_t W = p.tile_w, H = p.tile_h, S = sms;
  const std::int64_t B = p.blocks_x * ceil_div(rows, H);
  const std::int64_t q = ceil_div(B, S);
  const int occ = resident::blocks_per_sm(p.threads, resident::kFusedRegs, g.smem_bytes);
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.launches = 1;
  c.waves = q;
  c.atomics = B;
  c.N_G = q * S * (2 * s.Ix * W * (H + s.Iy - 1) + 2 * s.Iy * W * H + 3 * W * H + 2);
  c.N_GG = 3 * rows * s.nx + s.Ix + s.Iy + 2 + 2 * B;
  c.N_GS = ceil_div(q, occ) * S * (std::int64_t{g.in_rows} * g.in_cols + g.kx_len + g.ky_len);
  return c;
}

namespace {

// The counts of one device: the bands it holds, their messages and their share of the all-reduce.
CostCounts device_step_counts(const Shape& s, const Layout& l, int sms, const BandPlan& plan,
                              const std::vector<std::size_t>& bands, PeerPath path) {
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.peer_path = path;
  for (std::size_t b : bands) {
    const BandLaunches launches = band_launches(plan, b);
    for (const auto* ranges : {&launches.inner, &launches.edges})
      for (const RowRange& r : *ranges) c += fused_rows_counts(s, l, sms, r.rows());
    const HaloSends h = halo_sends(plan, b);
    c.peer_messages += h.messages;
    c.N_peer += h.values;
  }
  // The device's working set, as cuda-resident's: its bands read and written, their likelihood,
  // the kernels (the halo rows, a few rows a band, left out).
  std::int64_t rows = 0;
  for (std::size_t b : bands) rows += plan.bands[b].rows;
  c.gpu_footprint = c.P * (3 * rows * s.nx + s.Ix + s.Iy);
  const std::int64_t G = plan.partitions();
  if (G > 1) {
    // Each band's scale kernel (the lagged normalization): one launch, reading T_k, E_k, T_{k-1},
    // E_{k+1} and writing rho_k, E_{k+2}, six float64 values.
    const auto n = static_cast<std::int64_t>(bands.size());
    c.launches += n;
    c.N_GG += n * 6 * 2;
    if (path == PeerPath::link) {
      c.collectives = 1;
      c.collective_bytes = 8;
    } else {
      c.collectives = G;
      c.collective_bytes = 8 * G * (G + 1);
    }
  }
  c.peer_path = path;
  return c;
}

// Each count the largest over the devices; the sizes of device->host copies from the device
// that makes them (device 0, the first in `devices`).
CostCounts busiest(const std::vector<CostCounts>& devices) {
  CostCounts out = devices.front();
  for (const CostCounts& d : devices)
    for (const CountField& f : count_fields()) out.*f.member = std::max(out.*f.member, d.*f.member);
  return out;
}

std::vector<std::vector<std::size_t>> bands_by_device(const BandPlan& plan, const BandPlacement& placement) {
  std::vector<std::vector<std::size_t>> out;
  if (placement.path == PeerPath::device) {
    out.emplace_back();
    for (std::size_t b = 0; b < plan.bands.size(); ++b) out.back().push_back(b);
  } else {
    for (std::size_t b = 0; b < plan.bands.size(); ++b) out.push_back({b});
  }
  return out;
}

}  // namespace

CostCounts cuda_bands_counts(const Shape& s, const Layout& l, int sms, const BandPlacement& placement) {
  const BandPlan plan = band_plan(s, placement.partitions);
  std::vector<CostCounts> devices;
  for (const auto& bands : bands_by_device(plan, placement))
    devices.push_back(device_step_counts(s, l, sms, plan, bands, placement.path));
  return busiest(devices);
}

CostCounts cuda_bands_run_counts(const Shape& s, const Layout& l, int sms, const BandPlacement& placement,
                                 std::int64_t steps, std::int64_t segment) {
  if (steps < 1) throw InputError(fmt::format("a run needs at least one step, got {}", steps));
  if (segment < 1) throw InputError(fmt::format("a segment of {} steps must be at least 1", segment));
  const BandPlan plan = band_plan(s, placement.partitions);
  const std::int64_t segments = ceil_div(steps, segment);
  std::vector<CostCounts> devices;
  bool first = true;
  for (const auto& bands : bands_by_device(plan, placement)) {
    CostCounts c = device_step_counts(s, l, sms, plan, bands, placement.path).scaled(steps);
    const auto n = static_cast<std::int64_t>(bands.size());
    // Per band: zero each step's partial sum (2 values written), carry the total in and out.
    c.N_GG += n * (2 * steps + segments * 2 * (2 + 2));
    if (plan.partitions() > 1) {
      // Per band and segment of m steps: E_1 = T_0 carried in (one more copy), and the scale
      // kernel launched m + 1 times, moving 6m - 1 float64 values (m >= 2: at k = 0 no rho_0,
      // at k = m - 1 and m no E ahead) or 4 (m = 1), against the step counts' m launches and 6m.
      const std::int64_t whole = steps / segment, rest = steps % segment;
      auto fewer = [](std::int64_t m) { return m >= 2 ? 1 : 2; };  // float64 values short of 6m
      const std::int64_t short_by = whole * fewer(segment) + (rest > 0 ? fewer(rest) : 0);
      c.launches += n * segments;
      c.N_GG += n * (segments * 2 * 2 - 2 * short_by);
    }
    if (first) {  // device 0: band 0's totals to the host, one pinned copy per segment
      c.N_GC += 2 * steps;
      c.transfers_GC += segments;
      c.host_memory = HostMemory::pinned;
      const std::int64_t sum_bytes = 2 * c.P;
      add_copies(c.copies_GC, segment * sum_bytes, steps / segment);
      add_copies(c.copies_GC, (steps % segment) * sum_bytes, steps % segment > 0 ? 1 : 0);
    }
    c.host_waits += segments;  // the host waits for every device at the end of a segment
    first = false;
    devices.push_back(c);
  }
  return busiest(devices);
}

}  // namespace dtflop::rbe
