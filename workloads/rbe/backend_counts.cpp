#include "workloads/rbe/backend_counts.hpp"

#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/rbe/reference.hpp"
#include "workloads/rbe/resident_geometry.hpp"

namespace dtflop::rbe {

std::int64_t edge_taps(std::int64_t I) {
  const std::int64_t c = kernel_centre(I);
  std::int64_t s = 0;
  for (std::int64_t a = 0; a < I; ++a) s += a > c ? a - c : c - a;
  return s;
}

CostCounts cpu_seq_counts(const Shape& s, Convolution prediction) {
  validate(s);
  const std::int64_t ng = s.cells();
  const std::int64_t row_taps = s.Ix * s.nx - edge_taps(s.Ix);  // full 2D: valid (output, tap) pairs, one row
  const std::int64_t col_taps = s.Iy * s.ny - edge_taps(s.Iy);  // ... one column
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.cpu_threads = 1;
  const std::int64_t correction = 3 * ng + 1;  // multiply, sum, A_c x sum, divide
  if (prediction == Convolution::separable) {
    // Zero-padded lines, every output taking every tap, rows in whole groups of
    // reference::kGroup outputs: the x-pass runs n_y rows of n_x, the y-pass n_x of n_y.
    auto whole = [](std::int64_t n) { return (n + reference::kGroup - 1) / reference::kGroup * reference::kGroup; };
    c.N_CD = 2 * (s.ny * whole(s.nx) * s.Ix + s.nx * whole(s.ny) * s.Iy);  // chained taps
    c.N_C = c.N_CD + correction;
    // x-pass r+w, y-pass (transpose, x-pass, transpose back) 3 x r+w, multiply (pred, l -> q),
    // sum (q), divide (q -> p); kernels once.
    c.N_CC = 2 * ng + 6 * ng + 3 * ng + ng + 2 * ng + s.Ix + s.Iy;
    // Working set: the belief p, l, u, the prediction, q and two transpose buffers.
    c.cpu_footprint = 7 * ng * c.P;
  } else {
    c.N_C = 2 * row_taps * col_taps + correction;
    c.N_CC = 2 * ng + 3 * ng + ng + 2 * ng + s.Ix * s.Iy;
    c.cpu_footprint = 5 * ng * c.P;  // p, l, u, the prediction, q
  }
  c.N_CS = ng;  // the correction's sum of q: one chain of n_g dependent additions
  return c;
}

CostCounts cpu_par_counts(const Shape& s, Convolution prediction, int threads) {
  validate(s);
  if (threads < 1) throw InputError(fmt::format("cpu-par needs at least one thread, got {}", threads));
  const std::int64_t ng = s.cells();
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.cpu_threads = threads;
  // Correction: (l x scale) x prediction, 2 multiplications, and the sum, 1 addition, per
  // cell; the scale 1 / (A_c S) of the previous step: 2 operations.
  const std::int64_t correction = 3 * ng + 2;
  // Prediction: read q, write the intermediate (u or the zero-padded copy); read it, write the
  // prediction. Correction: read the prediction and l, write q. Kernels once.
  c.cpu_syncs = threads > 1 ? 3 : 0;
  if (prediction == Convolution::separable) {
    auto round_up = [](std::int64_t n, std::int64_t m) { return (n + m - 1) / m * m; };
    c.N_C = 2 * s.ny * (s.Ix * round_up(s.nx, kCpuParXBlock) + s.Iy * round_up(s.nx, kCpuParYStrip)) + correction;
    // The x-pass slides along its row: one unaligned load per FMA. (The y-pass loads aligned row
    // segments of its strip, each feeding two output rows.)
    c.N_CW = 2 * s.ny * s.Ix * round_up(s.nx, kCpuParXBlock);
    c.N_CA = 2 * s.ny * s.Iy * round_up(s.nx, kCpuParYStrip);  // the y-pass: each row loaded for two FMAs
    c.N_CC = 7 * ng + s.Ix + s.Iy;
    // Working set: q, l, the prediction and u, strip by strip (Y columns), with I_y - 1 zero rows.
    c.cpu_footprint = (3 * ng + (s.ny + s.Iy - 1) * round_up(s.nx, kCpuParYStrip)) * c.P;
  } else {
    c.N_C = 2 * ng * s.Ix * s.Iy + correction;
    c.N_CW = 2 * ng * s.Ix * s.Iy;  // every tap slides along the padded row
    c.N_CC = 7 * ng + s.Ix * s.Iy;
    c.cpu_footprint = (3 * ng + (s.ny + s.Iy - 1) * (s.nx + s.Ix - 1)) * c.P;  // q, l, prediction, padded q
  }
  return c;
}

CostCounts cuda_seed_counts(const Shape& s, HostMemory memory) {
  CostCounts c = seed_gpu_counts(s, memory);
  c.N_C += 1;  // A_c x sum, which the seed counts inside its n_g summations
  c.N_CS = s.cells();  // the host's sum of q: one chain of n_g dependent additions
  // The row kernel's taps: each reads u one row further on (rbe_seed_row_multiply); the column
  // kernel's, the next float of the same row of p (rbe_seed_column).
  c.N_GR = 2 * s.cells() * s.Iy;
  c.N_GW = 2 * s.cells() * s.Ix;
  // The host times each phase up to a synchronize (CudaSeed::advance): two laps of copies to the
  // device (the belief, the kernels and the likelihood; then A_c x sum), two of kernels (the
  // prediction; the division), two of copies back (q; the belief).
  c.laps_CG = 2;
  c.laps_GC = 2;
  c.laps_G = 2;
  // The kernels' working set: the belief, u, the likelihood and q, and the two kernels.
  c.gpu_footprint = c.P * (4 * s.cells() + s.Ix + s.Iy);
  return c;
}

ResidentPlan resident_plan(const Shape& s, const Layout& l, std::size_t max_shared) {
  validate(s);
  auto bad = [&](const std::string& why) {
    return InputError(fmt::format("layout {} is invalid: {}", to_string(l), why));
  };
  if (l.block_x < 8 || l.block_x > 1024 || l.block_x % 8 != 0)
    throw bad("block_x must be a multiple of 8 between 8 and 1024 (each thread of the x-pass "
              "computes 8 neighbouring cells)");
  if (l.block_y < 1) throw bad("block_y must be at least 1");
  const std::int64_t threads = std::int64_t{l.block_x} * l.block_y;
  if (threads > 1024) throw bad(fmt::format("a block of {} threads is more than 1024", threads));
  if (threads % 32 != 0) throw bad(fmt::format("a block of {} threads is not whole warps (a multiple of 32)", threads));
  const int R = l.cells_per_thread;
  if (R != 1 && R != 2 && R != 4 && R != 8 && R != 16)
    throw bad("cells_per_thread must be 1, 2, 4, 8 or 16");

  ResidentPlan p;
  p.threads = static_cast<int>(threads);
  p.tile_w = l.block_x;
  p.tile_h = l.block_y * R;
  p.blocks_y = (s.ny + p.tile_h - 1) / p.tile_h;
  const resident::TileGeometry fused = resident::fused_geometry(s, l);
  if (l.passes == Layout::Passes::fused) {
    if (fused.smem_bytes > max_shared)
      throw bad(fmt::format("the fused tile needs {} bytes of shared memory for a {}x{} kernel, more than "
                            "the {} a block may have; use a smaller tile or :split",
                            fused.smem_bytes, s.Ix, s.Iy, max_shared));
    p.passes = Layout::Passes::fused;
  } else if (l.passes == Layout::Passes::split) {
    p.passes = Layout::Passes::split;
  } else {
    // Fused when a multiprocessor runs two of its blocks at once (each block's shared memory and
    // the 1 KiB its runtime takes) and the x-pass recomputes at most as many halo rows as the
    // tile has rows; else split.
    const bool two = resident::blocks_by_shared(fused.smem_bytes) >= 2 && fused.smem_bytes <= max_shared;
    p.passes = (two && s.Iy - 1 <= p.tile_h) ? Layout::Passes::fused : Layout::Passes::split;
  }
  constexpr std::int64_t kMaxGridY = 65535;
  if (p.blocks_y > kMaxGridY)
    throw bad(fmt::format("{} rows of blocks exceed CUDA's {}; use more rows per block (block_y x "
                          "cells_per_thread)",
                          p.blocks_y, kMaxGridY));
  // Fused tiles of a row start x_shift cells left of a multiple of W (resident_geometry.hpp):
  // the blocks cover x_shift + n_x columns. Split y-pass tiles start at multiples of W.
  if (p.passes == Layout::Passes::fused) {
    p.blocks_x = (s.nx + fused.x_shift + p.tile_w - 1) / p.tile_w;
    p.smem_bytes = fused.smem_bytes;
    return p;
  }
  p.blocks_x = (s.nx + p.tile_w - 1) / p.tile_w;
  // A pass whose whole-kernel tile does not fit walks the kernel in chunks of taps.
  p.y_chunk = resident::pass_chunk([&](int c) { return resident::ypass_geometry(s, l, c); }, s.Iy,
                                   resident::ypass_chunk_step(l), max_shared);
  p.x_chunk = resident::pass_chunk([&](int c) { return resident::xpass_geometry(s, l, c); }, s.Ix,
                                   resident::kXpassChunkStep, max_shared);
  const resident::TileGeometry ypass = resident::ypass_geometry(s, l, p.y_chunk);
  if (ypass.smem_bytes > max_shared)
    throw bad(fmt::format("the y-pass tile needs {} bytes of shared memory for a {}-row kernel, more than "
                          "the {} a block may have; use fewer rows per block (block_y x cells_per_thread)",
                          ypass.smem_bytes, s.Iy, max_shared));
  const resident::TileGeometry xpass = resident::xpass_geometry(s, l, p.x_chunk);
  if (xpass.smem_bytes > max_shared)
    throw bad(fmt::format("the x-pass tile needs {} bytes of shared memory for a {}-column kernel, more "
                          "than the {} a block may have; use fewer threads per block",
                          xpass.smem_bytes, s.Ix, max_shared));
  p.y_chunks = ypass.chunks;
  p.x_chunks = xpass.chunks;
  p.smem_bytes = ypass.smem_bytes;
  p.xtile_w = xpass.out_w;
  p.xtile_h = xpass.out_h;
  p.xblocks_x = (s.nx + xpass.x_shift + p.xtile_w - 1) / p.xtile_w;
  p.xblocks_y = (s.ny + p.xtile_h - 1) / p.xtile_h;
  p.xsmem_bytes = xpass.smem_bytes;
  if (p.xblocks_y > kMaxGridY)
    throw bad(fmt::format("the x-pass needs {} rows of blocks, more than CUDA's {}; use more threads per "
                          "block",
                          p.xblocks_y, kMaxGridY));
  return p;
}

CostCounts cuda_resident_counts(const Shape& s, const Layout& l, int sms) {
  if (sms < 1) throw InputError(fmt::format("a GPU of {} multiprocessors cannot run cuda-resident; give at least 1", sms));
  const ResidentPlan p = resident_plan(s, l);
  const std::int64_t ng = s.cells();
  const std::int64_t W = p.tile_w, H = p.tile_h, B = p.blocks();
  // Waves of a kernel of n blocks, and the blocks counted for it: every multiprocessor runs as
  // many rounds as the busiest one (backend_counts.hpp).
  const std::int64_t S = sms;
  auto waves = [S](std::int64_t n) { return ceil_div(n, S); };
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  // Per block of the correcting kernel: y-pass 2 I_y per output; (scale x prediction) x l, 2
  // multiplications per output; the sum: one addition per output (reductions are counted as one
  // addition per value summed, see docs/rbe.md); the scale 1 / (A_c S): 2 operations.
  const std::int64_t correct_block = 2 * s.Iy * W * H + 3 * W * H + 2;
  // Tile fills: rounds of blocks running at once on the busiest multiprocessor (a kernel's
  // q(B) blocks there, occ at a time), each filling its tile (and kernel coefficients) from
  // device memory, counted on every multiprocessor like N_G.
  // A chunked split pass fills its tile and its chunk of coefficients once per chunk.
  auto fills = [&](std::int64_t blocks, int regs, const resident::TileGeometry& g, std::int64_t tile_values) {
    const int occ = resident::blocks_per_sm(p.threads, regs, g.smem_bytes);
    return ceil_div(waves(blocks), occ) * S * g.chunks * (tile_values + g.kx_len + g.ky_len);
  };
  if (p.passes == Layout::Passes::fused) {
    const auto g = resident::fused_geometry(s, l);
    c.launches = 1;
    c.waves = waves(B);
    c.atomics = B;  // each block adds its share of S_k to the one sum
    c.N_G = waves(B) * S * (2 * s.Ix * W * (H + s.Iy - 1) + correct_block);
    c.N_GG = 3 * ng + s.Ix + s.Iy + 2 + 2 * B;
    c.N_GS = fills(B, resident::kFusedRegs, g, std::int64_t{g.in_rows} * g.in_cols);
    c.gpu_footprint = c.P * (3 * ng + s.Ix + s.Iy);  // the belief read and written, the likelihood, the kernels
  } else {
    const auto gx = resident::xpass_geometry(s, l, p.x_chunk), gy = resident::ypass_geometry(s, l, p.y_chunk);
    c.launches = 2;
    c.waves = waves(p.xblocks()) + waves(B);
    c.atomics = B;  // the y-pass blocks add their shares of S_k to the one sum
    c.N_G = waves(p.xblocks()) * S * 2 * s.Ix * p.xtile_w * p.xtile_h + waves(B) * S * correct_block;
    c.N_GG = 5 * ng + s.Ix + s.Iy + 2 + 2 * B;
    c.N_GS = fills(p.xblocks(), resident::kXpassRegs, gx, std::int64_t{gx.in_rows} * gx.in_cols) +
             fills(B, resident::kYpassRegs, gy, std::int64_t{gy.u_rows} * gy.out_w);
    c.gpu_footprint = c.P * (4 * ng + s.Ix + s.Iy);  // and u between the passes
  }
  return c;
}

CostCounts cuda_resident_run_counts(const Shape& s, const Layout& l, int sms, std::int64_t steps,
                                    std::int64_t chunk, bool graph) {
  if (steps < 1) throw InputError(fmt::format("a run needs at least one step, got {}", steps));
  if (chunk < 1) throw InputError(fmt::format("chunk of {} steps must be at least 1", chunk));
  CostCounts c = cuda_resident_counts(s, l, sms).scaled(steps);
  const std::int64_t chunks = ceil_div(steps, chunk);
  // Per chunk: zero its sums (2 values each, written), carry the last sum in and out (two
  // 8-byte device copies, read + write), copy the chunk's sums to the host in one copy.
  c.N_GG += 2 * steps + chunks * 2 * (2 + 2);
  c.N_GC += 2 * steps;
  c.transfers_GC += chunks;
  // Each chunk's sums (a float64 each: 2 values of P bytes) land in pinned host memory.
  c.host_memory = HostMemory::pinned;
  const std::int64_t sum_bytes = 2 * c.P;
  add_copies(c.copies_GC, chunk * sum_bytes, steps / chunk);
  add_copies(c.copies_GC, (steps % chunk) * sum_bytes, steps % chunk > 0 ? 1 : 0);
  c.host_waits += chunks;  // the host launches each chunk's graph and waits for it
  // From graphs, the device starts every kernel; else the host launches them one by one.
  if (graph) c.graph_launches = c.launches;
  return c;
}

}  // namespace dtflop::rbe
