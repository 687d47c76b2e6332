// Each backend's declared counts against formulas written out here by hand, and cpu-seq's
// against the operations its code really performs (an operation-counting scalar).
#include <gtest/gtest.h>

#include "cuda/device.hpp"

#include "model/errors.hpp"
#include "tests/workloads/rbe/support.hpp"
#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/reference.hpp"
#include "workloads/rbe/resident_geometry.hpp"

namespace dtflop::rbe {
namespace {

// A double that counts the floating-point operations done on it.
struct Ops {
  static inline std::int64_t add = 0, mul = 0, div = 0;
  static void reset() { add = mul = div = 0; }
  static std::int64_t total() { return add + mul + div; }
};
struct Counted {
  double v = 0;
  Counted() = default;
  explicit Counted(double x) : v(x) {}
  friend Counted operator+(Counted a, Counted b) { ++Ops::add; return Counted(a.v + b.v); }
  friend Counted operator*(Counted a, Counted b) { ++Ops::mul; return Counted(a.v * b.v); }
  friend Counted operator/(Counted a, Counted b) { ++Ops::div; return Counted(a.v / b.v); }
};

// One cpu-seq step through the reference algorithms with counted scalars.
std::int64_t counted_step(const Shape& s, Convolution prediction) {
  const std::int64_t n = s.cells();
  const auto N = static_cast<std::size_t>(n);
  std::vector<Counted> kx(static_cast<std::size_t>(s.Ix), Counted(0.1));
  std::vector<Counted> ky(static_cast<std::size_t>(s.Iy), Counted(0.2));
  std::vector<Counted> k2(static_cast<std::size_t>(s.Ix * s.Iy), Counted(0.1));
  std::vector<Counted> p(N, Counted(1)), l(N, Counted(0.5)), u(N), pred(N), q(N), work(2 * N);
  Ops::reset();
  if (prediction == Convolution::separable) {
    reference::pass_x(s.nx, s.ny, kx.data(), s.Ix, p.data(), u.data());
    reference::pass_y(s.nx, s.ny, ky.data(), s.Iy, u.data(), pred.data(), work.data());
  } else {
    reference::convolve_full(s.nx, s.ny, k2.data(), s.Ix, s.Iy, p.data(), pred.data());
  }
  reference::multiply(n, l.data(), pred.data(), q.data());
  const Counted sum = reference::sum(n, q.data());
  reference::normalize(n, q.data(), Counted(0.25), sum, p.data());
  return Ops::total();
}

TEST(RbeBackendCounts, CpuSeqCountsAreTheOperationsItsCodeDoes) {
  for (const Shape s : {Shape{1, 1, 1, 1}, Shape{17, 12, 5, 3}, Shape{16, 9, 4, 6}, Shape{30, 30, 30, 1}}) {
    for (const auto pr : {Convolution::separable, Convolution::full}) {
      SCOPED_TRACE(fmt::format("{}x{} kernel {}x{} {}", s.nx, s.ny, s.Ix, s.Iy, int(pr)));
      EXPECT_EQ(cpu_seq_counts(s, pr).N_C, counted_step(s, pr));
    }
  }
}

TEST(RbeBackendCounts, CpuSeqByHand) {
  // Grid 10 x 8, kernel 3 x 4: c_x = 1, c_y = 1. S(3) = |0-1| + 0 + |2-1| = 2;
  // S(4) = 1 + 0 + 1 + 2 = 4. Valid taps: along x per row 3*10 - 2 = 28, along y per column
  // 4*8 - 4 = 28.
  EXPECT_EQ(edge_taps(3), 2);
  EXPECT_EQ(edge_taps(4), 4);
  const Shape s{10, 8, 3, 4};
  const auto c = cpu_seq_counts(s, Convolution::separable);
  // Zero-padded lines in whole groups of 8 outputs: 8 rows of 16 (10 rounded up) with 3 taps,
  // 10 columns of 8 with 4 taps.
  EXPECT_EQ(c.N_C, 2 * (8 * 16 * 3 + 10 * 8 * 4) + 3 * 80 + 1);
  EXPECT_EQ(c.N_CC, 14 * 80 + 3 + 4);  // the y-pass through two transposes
  EXPECT_EQ(c.N_CW, 0);  // chains of dependent additions: bound by their latency, not the loads
  EXPECT_EQ(c.N_CD, 2 * (8 * 16 * 3 + 10 * 8 * 4));  // every tap of both passes is such a chain
  EXPECT_EQ(cpu_seq_counts(s, Convolution::full).N_CD, 0);  // one chain per output: not this shape
  EXPECT_EQ(c.N_CS, 80);  // the correction's sum: one chain of n_g additions, in both modes
  EXPECT_EQ(cpu_seq_counts(s, Convolution::full).N_CS, 80);
  EXPECT_EQ(c.cpu_syncs, 0);
  EXPECT_EQ(c.P, 8);
  EXPECT_EQ(c.cpu_threads, 1);
  EXPECT_EQ(cpu_seq_counts(s, Convolution::full).N_C, 2 * 28 * 28 + 3 * 80 + 1);
  // Working set: 7 arrays of 80 doubles (p, l, u, prediction, q, two transpose buffers); 5 full.
  EXPECT_EQ(c.cpu_footprint, 7 * 80 * 8);
  EXPECT_EQ(cpu_seq_counts(s, Convolution::full).cpu_footprint, 5 * 80 * 8);
}

TEST(RbeBackendCounts, CpuParByHand) {
  const Shape s{1000, 1000, 33, 33};
  const auto c = cpu_par_counts(s, Convolution::separable, 2);
  // 5.5 plus the correction, over rows rounded up to whole x-pass blocks (1024 = 16 x 64) and
  // whole y-pass strips (1024 = 32 x 32).
  EXPECT_EQ(c.N_C, 2LL * 1000 * (33 * 1024 + 33 * 1024) + 3LL * 1000000 + 2);
  EXPECT_EQ(c.N_CC, 7LL * 1000000 + 66);
  EXPECT_EQ(c.N_CW, 2LL * 1000 * 33 * 1024);  // the x-pass's FLOPs: it slides along its rows
  EXPECT_EQ(c.N_CA, 2LL * 1000 * 33 * 1024);  // the y-pass's: each row segment loaded feeds two FMAs
  EXPECT_EQ(cpu_par_counts({100, 10, 3, 5}, Convolution::separable, 2).N_CA, 2LL * 10 * 5 * 128);
  EXPECT_EQ(cpu_par_counts({100, 50, 5, 7}, Convolution::full, 1).N_CA, 0);
  EXPECT_EQ(c.cpu_syncs, 3);
  // Working set: q, l, prediction (10^6 floats each) and u: 32 strips of 32 columns, 1032 rows.
  EXPECT_EQ(c.cpu_footprint, 4LL * (3 * 1000000 + 1032 * 1024));
  // 100 columns: 128 in x-pass blocks, 128 in y-pass strips; 96 columns: 128 and 96.
  EXPECT_EQ(cpu_par_counts({100, 10, 3, 5}, Convolution::separable, 2).N_C, 2LL * 10 * (3 * 128 + 5 * 128) + 3 * 1000 + 2);
  EXPECT_EQ(cpu_par_counts({96, 10, 3, 5}, Convolution::separable, 2).N_C, 2LL * 10 * (3 * 128 + 5 * 96) + 3 * 960 + 2);
  EXPECT_EQ(cpu_par_counts(s, Convolution::separable, 1).cpu_syncs, 0);  // nothing to wait for
  EXPECT_EQ(c.P, 4);
  EXPECT_EQ(c.cpu_threads, 2);
  EXPECT_EQ(c.N_CG + c.N_GC + c.N_GG + c.N_G, 0);
  EXPECT_EQ(cpu_par_counts({100, 50, 5, 7}, Convolution::full, 1).N_C, 2LL * 5000 * 35 + 3 * 5000 + 2);
  EXPECT_EQ(cpu_par_counts({100, 50, 5, 7}, Convolution::full, 1).N_CW, 2LL * 5000 * 35);
  // The backend declares the same counts, with the threads it runs on.
  BackendOptions o;
  o.threads = 3;
  EXPECT_EQ(step_counts("cpu-par", s, o), cpu_par_counts(s, Convolution::separable, 3));
}

TEST(RbeBackendCounts, CudaSeedIsEquations5_10To5_16) {
  const Shape s{1000, 800, 33, 21};
  const std::int64_t ng = 800000;
  for (auto mem : {HostMemory::pageable, HostMemory::pinned}) {
    BackendOptions o;
    o.host_memory = mem;
    const auto c = step_counts("cuda-seed", s, o);
    EXPECT_EQ(c.N_CG, 2 * ng + 33 + 21 + 1);        // 5.10
    EXPECT_EQ(c.N_GC, 2 * ng);                      // 5.13
    EXPECT_EQ(c.N_GG, 4 * ng + 33 + 21 + 1);        // 5.14
    EXPECT_EQ(c.N_C, ng + 1);                       // 5.15, plus A_c x sum
    EXPECT_EQ(c.N_G, 2 * ng * (33 + 21 + 1));       // 5.16
    EXPECT_EQ(c.N_GR, 2 * ng * 21);                 // the row kernel's taps, one row apart
    EXPECT_EQ(c.N_GW, 2 * ng * 33);                 // the column kernel's, along the row
    EXPECT_EQ(c.laps_CG, 2);                        // the phases the host times up to a synchronize
    EXPECT_EQ(c.laps_G, 2);
    EXPECT_EQ(c.laps_GC, 2);
    EXPECT_EQ(c.host_waits, 0);                     // every wait is inside a component
    EXPECT_EQ(c.N_CS, ng);                          // the host sum: one chain of dependent additions
    EXPECT_EQ(c.transfers_CG, 5);
    EXPECT_EQ(c.transfers_GC, 2);
    EXPECT_EQ(c.launches, 3);
    EXPECT_EQ(c.host_memory, mem);
    EXPECT_EQ(c.gpu_footprint, 4 * (4 * ng + 33 + 21));  // p, u, l and q, the two kernels
  }
}

TEST(RbeBackendCounts, CudaResidentFusedByHand) {
  // Grid 1000 x 1000, kernel 33 x 33, layout 32x8x8: tiles 32 x 64, 32 x 16 = 512 blocks (the
  // last column of tiles is 8 wide in the grid, the last row 40 high: computed whole).
  const Shape s{1000, 1000, 33, 33};
  const Layout l = parse_layout("32x8x8");
  const auto p = resident_plan(s, l);
  EXPECT_EQ(p.passes, Layout::Passes::fused);
  EXPECT_EQ(p.tile_w, 32);
  EXPECT_EQ(p.tile_h, 64);
  EXPECT_EQ(p.blocks(), 32 * 16);
  const std::int64_t B = 512, W = 32, H = 64;
  const std::int64_t per_block = 2 * 33 * W * (H + 32) + 2 * 33 * W * H + 3 * W * H + 2;
  // 132 multiprocessors: 512 blocks run in ceil(512 / 132) = 4 waves, counted as 4 x 132 blocks.
  const auto c = cuda_resident_counts(s, l, 132);
  EXPECT_EQ(c.launches, 1);
  EXPECT_EQ(c.waves, 4);
  EXPECT_EQ(c.atomics, B);  // one atomic add to S_k per block, whatever the multiprocessors
  EXPECT_EQ(cuda_resident_counts(s, l, 8).atomics, B);
  EXPECT_EQ(c.N_G, 4 * 132 * per_block);
  EXPECT_EQ(c.N_GG, 3 * 1000000 + 66 + 2 + 2 * B);
  // Working set: two beliefs and the likelihood (4 MB each) and the two 33-tap kernels.
  EXPECT_EQ(c.gpu_footprint, 4 * (3 * 1000000 + 33 + 33));
  EXPECT_EQ(c.graph_launches, 0);  // a step alone: who launches it is the run's business
  // 128 multiprocessors: 4 whole waves, N_G is the blocks' own FLOPs.
  EXPECT_EQ(cuda_resident_counts(s, l, 128).N_G, B * per_block);
  EXPECT_EQ(cuda_resident_counts(s, l, 128).waves, 4);
  EXPECT_EQ(c.N_CG + c.N_GC + c.N_C, 0);
  // Shared memory: 34 doubles; kernels 8*5 + 8*5 floats; input tile 96 rows x pitch 76 (72
  // columns, 4 more so that pitch / 4 is odd); u tile (64 + 40) rows x pitch 36 (32 + 4).
  EXPECT_EQ(p.smem_bytes, 34 * 8 + 4 * (40 + 40 + 96 * 76 + 104 * 36));
  // Tile fills: 3 blocks at once per multiprocessor (80 registers x 256 threads = 20480 of 64 K;
  // shared memory would allow 5), so the busiest one's 4 blocks fill in ceil(4 / 3) = 2 rounds,
  // each block 96 x 72 tile values and 40 + 40 coefficients.
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kFusedRegs, p.smem_bytes), 3);
  EXPECT_EQ(c.N_GS, 2 * 132 * (96 * 72 + 40 + 40));
  EXPECT_EQ(c.N_GR, 0);  // every tap reads the shared-memory tile
  EXPECT_EQ(cuda_resident_counts(s, l, 128).N_GS, 2 * 128 * (96 * 72 + 40 + 40));
  // A run of 2500 steps: 3 segments of up to 1000, each bringing its sums back in one copy.
  const auto r = cuda_resident_run_counts(s, l, 132, 2500, 1000, true);
  EXPECT_EQ(r.launches, 2500);
  EXPECT_EQ(r.graph_launches, 2500);  // every kernel a node of a segment's graph
  EXPECT_EQ(r.gpu_footprint, c.gpu_footprint);  // a working set: the run's is the step's
  EXPECT_EQ(cuda_resident_run_counts(s, l, 132, 2500, 1000, false).graph_launches, 0);
  EXPECT_EQ(r.N_GC, 2 * 2500);
  EXPECT_EQ(r.transfers_GC, 3);
  // Two segments' sums of 1000 doubles and one of 500, into pinned host memory.
  EXPECT_EQ(r.copies_GC, (std::vector<CopySize>{{8000, 2}, {4000, 1}}));
  EXPECT_EQ(r.host_memory, HostMemory::pinned);
  EXPECT_EQ(r.host_waits, 3);  // each segment's graph launched and waited for
  EXPECT_EQ(r.N_G, 2500 * c.N_G);
  EXPECT_EQ(r.waves, 2500 * 4);
  EXPECT_EQ(r.atomics, 2500 * B);
  EXPECT_EQ(r.N_GG, 2500 * c.N_GG + 2 * 2500 + 3 * 8);
  EXPECT_EQ(r.N_GS, 2500 * c.N_GS);
}

TEST(RbeBackendCounts, CudaResidentFusesOnlyWhenTwoBlocksShareAMultiprocessor) {
  // Layout 32x8x16 (tiles 32 x 128). Kernel 69: input tile 196 rows x pitch 108, u tile 208 x 36,
  // coefficients 72 + 80 floats: 115504 bytes, two blocks take 2 (115504 + 1024) <= 233472.
  // Kernel 70: one more input row, 115936 bytes; two would need 233920: split.
  const Layout l = parse_layout("32x8x16");
  EXPECT_EQ(resident_plan({1000, 1000, 69, 69}, l).smem_bytes, 115504u);
  EXPECT_EQ(resident_plan({1000, 1000, 69, 69}, l).passes, Layout::Passes::fused);
  EXPECT_EQ(resident::fused_geometry({1000, 1000, 70, 70}, l).smem_bytes, 115936u);
  EXPECT_EQ(resident_plan({1000, 1000, 70, 70}, l).passes, Layout::Passes::split);
  EXPECT_EQ(resident_plan({1000, 1000, 70, 70}, parse_layout("32x8x16:fused")).passes, Layout::Passes::fused);
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kFusedRegs, 115936), 1);
}

TEST(RbeBackendCounts, CudaResidentShiftedTilesByHand) {
  // Kernel 31 x 5: halo h_x = 30 - 15 = 15 cells, so tiles start x_shift = 1 cell left of
  // multiples of 32 (the input tile then starts at a multiple of 4). Grid 63 x 40, layout
  // 32x8x4 (tiles 32 x 32): the tiles of a row cover 1 + 63 = 64 columns, 2 blocks; rows 2.
  const Shape s{63, 40, 31, 5};
  const auto p = resident_plan(s, parse_layout("32x8x4"));
  EXPECT_EQ(p.passes, Layout::Passes::fused);
  EXPECT_EQ(p.blocks_x, 2);
  EXPECT_EQ(p.blocks_y, 2);
  const std::int64_t B = 4, W = 32, H = 32;
  // On 4 multiprocessors: one whole wave, N_G is the 4 blocks' FLOPs.
  EXPECT_EQ(cuda_resident_counts(s, parse_layout("32x8x4"), 4).N_G,
            B * (2 * 31 * W * (H + 4) + 2 * 5 * W * H + 3 * W * H + 2));
  // Grid 64 x 40: 65 columns, 3 blocks of tiles per row.
  EXPECT_EQ(resident_plan({64, 40, 31, 5}, parse_layout("32x8x4")).blocks_x, 3);
  // Kernel 33: h_x = 16, no shift: 2 blocks.
  EXPECT_EQ(resident_plan({64, 40, 33, 5}, parse_layout("32x8x4")).blocks_x, 2);
  // Split x-pass tiles (128 wide) shift too: kernel 199 x 199 (h_x = 99, shift 1), grid 256.
  const auto q = resident_plan({256, 300, 199, 199}, parse_layout("32x8x8:split"));
  EXPECT_EQ(q.xblocks_x, 3);
  EXPECT_EQ(q.blocks_x, 8);  // the y-pass tiles do not shift
}

TEST(RbeBackendCounts, CudaResidentSplitByHand) {
  // Kernel 201 x 201 does not fit a fused tile: split. Layout 32x8x8: y-pass tiles 32 x 64;
  // x-pass tiles 128 x 16 (256 threads / 16).
  const Shape s{1000, 1000, 201, 201};
  const Layout l = parse_layout("32x8x8");
  const auto p = resident_plan(s, l);
  EXPECT_EQ(p.passes, Layout::Passes::split);
  EXPECT_EQ(p.xtile_w, 128);
  EXPECT_EQ(p.xtile_h, 16);
  const std::int64_t B = 32 * 16, XB = 8 * 63;
  EXPECT_EQ(p.xblocks(), XB);
  const auto c = cuda_resident_counts(s, l, 132);
  EXPECT_EQ(c.launches, 2);
  // 132 multiprocessors: x-pass ceil(504 / 132) = 4 waves, y-pass ceil(512 / 132) = 4.
  EXPECT_EQ(c.waves, 4 + 4);
  EXPECT_EQ(c.atomics, B);  // the y-pass blocks only: the x-pass sums nothing
  EXPECT_EQ(c.N_G, 4 * 132 * 2 * 201 * 128 * 16 + 4 * 132 * (2 * 201 * 32 * 64 + 3 * 32 * 64 + 2));
  // 8 multiprocessors divide both grids: N_G is the blocks' own FLOPs.
  EXPECT_EQ(cuda_resident_counts(s, l, 8).N_G, XB * 2 * 201 * 128 * 16 + B * (2 * 201 * 32 * 64 + 3 * 32 * 64 + 2));
  EXPECT_EQ(cuda_resident_counts(s, l, 8).waves, XB / 8 + B / 8);
  EXPECT_EQ(c.N_GG, 5 * 1000000 + 402 + 2 + 2 * B);
  EXPECT_EQ(c.gpu_footprint, 4 * (4 * 1000000 + 201 + 201));  // u between the passes too
  // Tile fills. x-pass: 16 rows x (128 + 208) values and 208 coefficients per block, pitch 340,
  // 22864 bytes; 48 registers: 5 blocks at once, so its 4 blocks per multiprocessor fill in one
  // round. y-pass: u tile 64 + 8 x 26 = 272 rows x 32 values (pitch 36) and 208 coefficients,
  // 40272 bytes; 72 registers: 3 at once, 2 rounds.
  EXPECT_EQ(p.xsmem_bytes, 34 * 8 + 4 * (16 * 340 + 208));
  EXPECT_EQ(p.smem_bytes, 34 * 8 + 4 * (272 * 36 + 208));
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kXpassRegs, p.xsmem_bytes), 5);
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kYpassRegs, p.smem_bytes), 3);
  EXPECT_EQ(c.N_GS, 1 * 132 * (16 * 336 + 208) + 2 * 132 * (272 * 32 + 208));
  EXPECT_EQ(resident_plan(s, parse_layout("32x8x8:split")).passes, Layout::Passes::split);
  EXPECT_THROW(resident_plan(s, parse_layout("32x8x8:fused")), InputError);  // does not fit
}

TEST(RbeBackendCounts, CudaResidentChunksAKernelTallerThanAnyTile) {
  // A kernel 4000 rows tall, as the search-and-rescue team's stretched steps need at 4000 x 4000
  // (here 75 columns wide), layout 32x8x16 (y-pass tiles 32 x 128). The whole kernel's u tile would be 128 + 16 x 250 = 4128 rows of
  // pitch 36 and 4000 coefficients: 34 x 8 + 4 (4128 x 36 + 4000) = 610704 bytes, more than a
  // block may have, so the y-pass walks the kernel in chunks of C taps (a multiple of 16), the
  // most whose tile fits two blocks on a multiprocessor: 272 + 4 ((128 + C) 36 + C) <=
  // 233472 / 2 - 1024 = 115712, C <= 655.5, so C = 640: 7 chunks (6 x 640 + 160).
  const Shape s{4000, 4000, 75, 4000};
  const Layout l = parse_layout("32x8x16");
  EXPECT_EQ(resident::ypass_geometry(s, l).smem_bytes, 610704u);
  const auto p = resident_plan(s, l);
  EXPECT_EQ(p.passes, Layout::Passes::split);
  EXPECT_EQ(p.y_chunk, 640);
  EXPECT_EQ(p.y_chunks, 7);
  EXPECT_EQ(p.smem_bytes, 272u + 4u * ((128 + 640) * 36 + 640));
  // The x-pass (16 rows x 128 + 80 columns, pitch 212, 80 coefficients) fits whole: one chunk.
  EXPECT_EQ(p.x_chunk, 0);
  EXPECT_EQ(p.x_chunks, 1);
  EXPECT_EQ(p.xsmem_bytes, 272u + 4u * (16 * 212 + 80));
  EXPECT_EQ(resident_plan(s, parse_layout("32x8x16:split")).y_chunks, 7);
  EXPECT_THROW(resident_plan(s, parse_layout("32x8x16:fused")), InputError);  // fused never chunks

  // Counts on 132 multiprocessors. y-pass: 125 x 32 = 4000 blocks, 31 waves; x-pass: h_x = 37,
  // tiles shifted 3 cells, ceil(4003 / 128) x 4000 / 16 = 32 x 250 = 8000 blocks, 61 waves.
  const std::int64_t B = 4000, XB = 8000, W = 32, H = 128;
  EXPECT_EQ(p.blocks(), B);
  EXPECT_EQ(p.xblocks(), XB);
  const auto c = cuda_resident_counts(s, l, 132);
  EXPECT_EQ(c.launches, 2);
  EXPECT_EQ(c.waves, 61 + 31);
  EXPECT_EQ(c.atomics, B);
  // The chunks change no FLOP: every output still takes each of its 4000 taps once.
  EXPECT_EQ(c.N_G, std::int64_t{61} * 132 * 2 * 75 * 128 * 16 + 31 * 132 * (2 * 4000 * W * H + 3 * W * H + 2));
  EXPECT_EQ(c.N_GG, 5 * 16000000 + 75 + 4000 + 2 + 2 * B);
  // Tile fills. x-pass: 48 registers, 5 blocks at once, its 61 rounds in 13, each 16 x 208
  // values and 80 coefficients. y-pass: 72 registers (3 blocks) and 113424 bytes (2 blocks): 2
  // at once, 31 rounds in 16, each block filling 7 chunks of 768 x 32 u values and 640
  // coefficients.
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kYpassRegs, p.smem_bytes), 2);
  EXPECT_EQ(resident::blocks_per_sm(256, resident::kXpassRegs, p.xsmem_bytes), 5);
  EXPECT_EQ(c.N_GS, 13 * 132 * (16 * 208 + 80) + 16 * 132 * 7 * (768 * 32 + 640));
}

TEST(RbeBackendCounts, CudaResidentChunksBothPassesByHand) {
  // Grid 1100 x 320, kernel 801 x 301, layout 1024x1x1 (y-pass tiles 1024 x 1, x-pass tiles 128 x
  // 64). x-pass: the whole kernel needs 64 rows x pitch 940 (128 + 808 columns) and 808
  // coefficients, 244144 bytes: chunks of C (a multiple of 8) with 272 + 4 (64 pitch(128 + C) +
  // C) <= 115712: C = 312 (pitch 444: 115184 bytes; C = 320 has pitch 452: 117264), 3 chunks
  // (312, 312, 177). y-pass: pitch 1028; 272 + 4 ((1 + C) 1028 + C) <= 115712 gives C <= 27,
  // a multiple of 4: 24, 13 chunks (12 x 24 + 13).
  const Shape s{1100, 320, 801, 301};
  const Layout l = parse_layout("1024x1x1");
  const auto p = resident_plan(s, l);
  EXPECT_EQ(p.passes, Layout::Passes::split);
  EXPECT_EQ(p.x_chunk, 312);
  EXPECT_EQ(p.x_chunks, 3);
  EXPECT_EQ(p.xsmem_bytes, 115184u);
  EXPECT_EQ(p.y_chunk, 24);
  EXPECT_EQ(p.y_chunks, 13);
  EXPECT_EQ(p.smem_bytes, 272u + 4u * (25 * 1028 + 24));
  // h_x = 400: no shift. x-pass 9 x 5 = 45 blocks, y-pass 2 x 320 = 640 blocks; on 8
  // multiprocessors 6 and 80 waves.
  EXPECT_EQ(p.xblocks(), 45);
  EXPECT_EQ(p.blocks(), 640);
  const auto c = cuda_resident_counts(s, l, 8);
  EXPECT_EQ(c.waves, 6 + 80);
  EXPECT_EQ(c.N_G, std::int64_t{6} * 8 * 2 * 801 * 128 * 64 + 80 * 8 * (2 * 301 * 1024 + 3 * 1024 + 2));
  // One block of 1024 threads at a time on a multiprocessor (the counted registers: 48 or 72 per
  // thread leave room for one), so 6 and 80 rounds; per round 3 x (64 x 440 + 312) and
  // 13 x (25 x 1024 + 24) values.
  EXPECT_EQ(resident::blocks_per_sm(1024, resident::kXpassRegs, p.xsmem_bytes), 1);
  EXPECT_EQ(resident::blocks_per_sm(1024, resident::kYpassRegs, p.smem_bytes), 1);
  EXPECT_EQ(c.N_GS, 6 * 8 * 3 * (64 * 440 + 312) + 80 * 8 * 13 * (25 * 1024 + 24));
  // A kernel as large as the grid is planned too (every tap a chunk can hold).
  EXPECT_NO_THROW(resident_plan({1100, 320, 1100, 320}, l));
  EXPECT_NO_THROW(resident_plan({4000, 4000, 4000, 4000}, parse_layout("32x8x16")));
}

TEST(RbeBackendCounts, CudaResidentWavesByHand) {
  // Kernel 33 x 33 (h_x = 16: tiles do not shift), layout 32x8x4: fused tiles 32 x 32, so a
  // grid of 32a x 32b cells is a x b blocks. S = 132 multiprocessors.
  const int S = 132;
  const Layout fused = parse_layout("32x8x4:fused");
  const std::int64_t W = 32, H = 32;
  const std::int64_t per_block = 2 * 33 * W * (H + 32) + 2 * 33 * W * H + 3 * W * H + 2;
  struct Case {
    std::int64_t nx, ny, blocks, waves;
  };
  for (const Case& k : {Case{320, 320, 100, 1},    // B < S: one wave, 32 multiprocessors idle
                        Case{384, 352, 132, 1},    // B = S: one full wave
                        Case{224, 608, 133, 2},    // B = S + 1: a second wave for one block
                        Case{384, 704, 264, 2}}) { // B = 2S
    const Shape s{k.nx, k.ny, 33, 33};
    ASSERT_EQ(resident_plan(s, fused).blocks(), k.blocks) << k.nx << "x" << k.ny;
    const auto c = cuda_resident_counts(s, fused, S);
    EXPECT_EQ(c.waves, k.waves) << k.nx << "x" << k.ny;
    EXPECT_EQ(c.N_G, k.waves * S * per_block) << k.nx << "x" << k.ny;
    EXPECT_GE(c.N_G, k.blocks * per_block);
    EXPECT_EQ(c.N_GG, 3 * k.nx * k.ny + 66 + 2 + 2 * k.blocks);  // unchanged by waves
  }
  // The same 133 blocks on 100 multiprocessors: 2 waves of 100.
  EXPECT_EQ(cuda_resident_counts({224, 608, 33, 33}, fused, 100).N_G, 2 * 100 * per_block);

  // Split, two kernels, each quantized on its own. Y-pass tiles 32 x 32, x-pass tiles 128 x 16
  // (256 threads / 16).
  const Layout split = parse_layout("32x8x4:split");
  const std::int64_t ypass_block = 2 * 33 * W * H + 3 * W * H + 2, xpass_block = 2 * 33 * 128 * 16;
  {
    // Grid 384 x 352: y-pass 12 x 11 = 132 blocks (1 wave), x-pass 3 x 22 = 66 (1 wave).
    const Shape s{384, 352, 33, 33};
    const auto p = resident_plan(s, split);
    ASSERT_EQ(p.passes, Layout::Passes::split);
    ASSERT_EQ(p.xtile_w, 128);
    ASSERT_EQ(p.xtile_h, 16);
    ASSERT_EQ(p.blocks(), 132);
    ASSERT_EQ(p.xblocks(), 66);
    const auto c = cuda_resident_counts(s, split, S);
    EXPECT_EQ(c.launches, 2);
    EXPECT_EQ(c.waves, 1 + 1);
    EXPECT_EQ(c.N_G, 1 * S * xpass_block + 1 * S * ypass_block);
    EXPECT_EQ(c.N_GG, 5 * 384 * 352 + 66 + 2 + 2 * 132);
  }
  {
    // Grid 224 x 608: y-pass 7 x 19 = 133 blocks (2 waves), x-pass 2 x 38 = 76 (1 wave).
    const Shape s{224, 608, 33, 33};
    const auto p = resident_plan(s, split);
    ASSERT_EQ(p.blocks(), 133);
    ASSERT_EQ(p.xblocks(), 76);
    const auto c = cuda_resident_counts(s, split, S);
    EXPECT_EQ(c.waves, 1 + 2);
    EXPECT_EQ(c.N_G, 1 * S * xpass_block + 2 * S * ypass_block);
    // A run: waves and N_G per step times the steps.
    const auto r = cuda_resident_run_counts(s, split, S, 250, 100, true);
    EXPECT_EQ(r.waves, 250 * 3);
    EXPECT_EQ(r.N_G, 250 * c.N_G);
    EXPECT_EQ(r.graph_launches, 250 * 2);  // both passes of every step, from the graphs
  }
  EXPECT_THROW(cuda_resident_counts({384, 352, 33, 33}, fused, 0), InputError);

  // Through the registry: gpu_sms chooses the multiprocessors; 0 is this machine's GPU, else
  // kDefaultGpuSms.
  BackendOptions o;
  o.layout = fused;
  o.gpu_sms = 100;
  EXPECT_EQ(step_counts("cuda-resident", {224, 608, 33, 33}, o).N_G, 2 * 100 * per_block);
  o.gpu_sms = 0;
  const int here = cuda::device_sms() > 0 ? cuda::device_sms() : kDefaultGpuSms;
  EXPECT_EQ(counted_gpu_sms(o), here);
  EXPECT_EQ(step_counts("cuda-resident", {224, 608, 33, 33}, o).N_G, ((133 + here - 1) / here) * here * per_block);
}

TEST(RbeLayout, ParsesAndRejectsWithAMessage) {
  EXPECT_EQ(parse_layout("32x8"), (Layout{32, 8, Layout{}.cells_per_thread, Layout::Passes::automatic}));
  EXPECT_EQ(parse_layout("64x4x16:split"), (Layout{64, 4, 16, Layout::Passes::split}));
  EXPECT_EQ(to_string(parse_layout("64x4x16:fused")), "64x4x16:fused");
  for (const char* bad : {"", "32", "32x", "x8", "32x8x4x2", "32xq", "32x8:fast", "-32x8", "0x8"})
    EXPECT_THROW(parse_layout(bad), InputError) << bad;
  const Shape s{500, 500, 9, 9};
  auto message = [&](const char* text) {
    try {
      resident_plan(s, parse_layout(text));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("12x8").find("multiple of 8"), std::string::npos);
  EXPECT_NE(message("64x32").find("more than 1024"), std::string::npos);
  EXPECT_NE(message("8x3").find("whole warps"), std::string::npos);
  EXPECT_NE(message("32x8x3").find("cells_per_thread"), std::string::npos);
  EXPECT_EQ(message("32x1x1:fused"), "");
  EXPECT_EQ(message("1024x1x1"), "");
  // The backend rejects an invalid layout when it is made, before any device is touched.
  BackendOptions o;
  o.layout = parse_layout("20x8");
  EXPECT_THROW(make_backend("cuda-resident", o), InputError);
}

}  // namespace
}  // namespace dtflop::rbe
