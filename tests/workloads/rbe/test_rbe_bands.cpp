// cuda-bands without a device: the partition into bands, each band's launches and halo messages,
// the placement of partitions on GPUs, and the exact counts against formulas written out by hand
// (and, for one partition, against cuda-resident's own counts, which the same kernel must give).
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/band_counts.hpp"
#include "workloads/rbe/backend_counts.hpp"

namespace dtflop::rbe {
namespace {

TEST(RbeBands, PartitionGivesTheFirstBandsTheRowsLeftOver) {
  const BandPlan p = band_plan({1000, 1000, 33, 33}, 3);
  ASSERT_EQ(p.partitions(), 3);
  EXPECT_EQ(p.bands[0].first, 0);
  EXPECT_EQ(p.bands[0].rows, 334);
  EXPECT_EQ(p.bands[1].first, 334);
  EXPECT_EQ(p.bands[1].rows, 333);
  EXPECT_EQ(p.bands[2].first, 667);
  EXPECT_EQ(p.bands[2].rows, 333);
  // Kernel 33: centre 16, 16 rows each way.
  EXPECT_EQ(p.halo_before, 16);
  EXPECT_EQ(p.halo_after, 16);
  EXPECT_EQ(p.ld, 1000);
  EXPECT_EQ(p.buffer_rows(1), 16 + 333 + 16);
  // I_y = 34: centre 16, 17 rows before a cell, 16 after; n_x 1001 pitched to 1004.
  const BandPlan q = band_plan({1001, 100, 5, 34}, 2);
  EXPECT_EQ(q.halo_before, 17);
  EXPECT_EQ(q.halo_after, 16);
  EXPECT_EQ(q.ld, 1004);
}

TEST(RbeBands, HalosOfEvenAndOddKernels) {
  // I_y = 4: c = 1, h_b = 4 - 1 - 1 = 2 rows before a cell, h_a = 1 after.
  const BandPlan a = band_plan({100, 10, 5, 4}, 3);
  EXPECT_EQ(a.halo_before, 2);
  EXPECT_EQ(a.halo_after, 1);
  EXPECT_EQ(a.bands[0].rows, 4);
  EXPECT_EQ(a.bands[1].rows, 3);
  EXPECT_EQ(a.bands[2].rows, 3);
  // I_y = 2: c = 0: one row before, none after.
  const BandPlan b = band_plan({100, 10, 5, 2}, 2);
  EXPECT_EQ(b.halo_before, 1);
  EXPECT_EQ(b.halo_after, 0);
  // I_y = 1: no halo.
  const BandPlan c = band_plan({100, 10, 5, 1}, 10);
  EXPECT_EQ(c.halo_before, 0);
  EXPECT_EQ(c.halo_after, 0);
  EXPECT_EQ(c.bands[9].rows, 1);
}

TEST(RbeBands, RefusesBandsLowerThanTheKernelsReach) {
  // 40 rows in 3 bands of 13: a 33-row kernel reaches 16 rows past a cell.
  try {
    (void)band_plan({100, 40, 33, 33}, 3);
    FAIL() << "a band lower than the halo was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("at most 2 partitions"), std::string::npos) << e.what();
  }
  EXPECT_EQ(band_plan({100, 40, 33, 33}, 2).bands[1].rows, 20);
  EXPECT_THROW((void)band_plan({100, 5, 1, 1}, 6), InputError);  // a band of no rows
  EXPECT_THROW((void)band_plan({100, 100, 1, 1}, 0), InputError);
  EXPECT_THROW((void)band_plan({100, 100, 1, 1}, kMaxPartitions + 1), InputError);
  EXPECT_NO_THROW((void)band_plan({100, 100, 1, 1}, kMaxPartitions));
}

TEST(RbeBands, LaunchesSplitTheEdgeRowsFromTheInnerRows) {
  const BandPlan p = band_plan({1000, 1000, 33, 33}, 3);
  const auto top = band_launches(p, 0), mid = band_launches(p, 1), bottom = band_launches(p, 2);
  // The top band needs no halo above it: its inner rows start at 0.
  EXPECT_EQ(top.inner, (std::vector<RowRange>{{0, 334 - 16}}));
  EXPECT_EQ(top.edges, (std::vector<RowRange>{{334 - 16, 334}}));
  EXPECT_EQ(mid.inner, (std::vector<RowRange>{{16, 333 - 16}}));
  EXPECT_EQ(mid.edges, (std::vector<RowRange>{{0, 16}, {333 - 16, 333}}));
  EXPECT_EQ(bottom.inner, (std::vector<RowRange>{{16, 333}}));
  EXPECT_EQ(bottom.edges, (std::vector<RowRange>{{0, 16}}));
  // One band: everything inner.
  const BandPlan one = band_plan({50, 40, 9, 9}, 1);
  EXPECT_EQ(band_launches(one, 0).inner, (std::vector<RowRange>{{0, 40}}));
  EXPECT_TRUE(band_launches(one, 0).edges.empty());
  // Bands of 8 rows with 4 halo rows each way: a middle band has no inner rows, one launch.
  const BandPlan low = band_plan({50, 40, 9, 9}, 5);
  EXPECT_TRUE(band_launches(low, 2).inner.empty());
  EXPECT_EQ(band_launches(low, 2).edges, (std::vector<RowRange>{{0, 8}}));
  EXPECT_EQ(band_launches(low, 0).inner, (std::vector<RowRange>{{0, 4}}));
  // Every band's launches cover its rows once.
  for (int G : {1, 2, 3, 5})
    for (std::size_t b = 0; b < std::size_t(G); ++b) {
      const BandPlan q = band_plan({50, 40, 9, 9}, G);
      const auto l = band_launches(q, b);
      std::vector<int> covered(std::size_t(q.bands[b].rows), 0);
      for (const auto* rs : {&l.inner, &l.edges})
        for (const RowRange& r : *rs)
          for (std::int64_t y = r.begin; y < r.end; ++y) ++covered[std::size_t(y)];
      for (int c : covered) EXPECT_EQ(c, 1) << "G " << G << " band " << b;
    }
}

// cuda-bands sends a band's rows once its edge launch has written them: the edges must hold
// every row sent to a neighbour and every row that reads a neighbour's halo, also where the
// kernel reaches further one way than the other (I_y even).
TEST(RbeBands, EdgeLaunchesHoldEveryRowSentAndEveryRowReadingAHalo) {
  for (std::int64_t Iy : {2, 4, 9, 10}) {
    const BandPlan p = band_plan({64, 90, 3, Iy}, 3);
    ASSERT_EQ(p.halo_before + p.halo_after, Iy - 1);
    for (std::size_t b = 0; b < 3; ++b) {
      const std::int64_t rows = p.bands[b].rows;
      std::vector<int> edge(std::size_t(rows), 0);
      for (const RowRange& r : band_launches(p, b).edges)
        for (std::int64_t y = r.begin; y < r.end; ++y) edge[std::size_t(y)] = 1;
      std::vector<std::int64_t> must;  // rows sent, and rows reading a halo, side by side
      if (b > 0) {
        for (std::int64_t y = 0; y < p.halo_after; ++y) must.push_back(y);   // sent up
        for (std::int64_t y = 0; y < p.halo_before; ++y) must.push_back(y);  // read the halo above
      }
      if (b < 2) {
        for (std::int64_t y = rows - p.halo_before; y < rows; ++y) must.push_back(y);  // sent down
        for (std::int64_t y = rows - p.halo_after; y < rows; ++y) must.push_back(y);   // read the halo below
      }
      for (std::int64_t y : must) EXPECT_EQ(edge[std::size_t(y)], 1) << "I_y " << Iy << " band " << b << " row " << y;
    }
  }
  // I_y = 4: one halo row one way and two the other; every edge is 2 rows.
  const BandPlan q = band_plan({64, 90, 3, 4}, 3);
  EXPECT_EQ(std::max(q.halo_before, q.halo_after), 2);
  EXPECT_EQ(std::min(q.halo_before, q.halo_after), 1);
  EXPECT_EQ(band_launches(q, 1).edges, (std::vector<RowRange>{{0, 2}, {28, 30}}));
  EXPECT_EQ(band_launches(q, 1).inner, (std::vector<RowRange>{{2, 28}}));
}

TEST(RbeBands, HaloSendsAreWholePitchedRows) {
  const BandPlan p = band_plan({1001, 1000, 33, 33}, 3);  // ld 1004
  EXPECT_EQ(halo_sends(p, 0).messages, 1);
  EXPECT_EQ(halo_sends(p, 0).values, 16 * 1004);
  EXPECT_EQ(halo_sends(p, 1).messages, 2);
  EXPECT_EQ(halo_sends(p, 1).values, 2 * 16 * 1004);
  EXPECT_EQ(halo_sends(p, 2).messages, 1);
  // I_y = 2: one row before a cell, none after: only the messages down.
  const BandPlan q = band_plan({100, 10, 3, 2}, 3);
  EXPECT_EQ(halo_sends(q, 0).messages, 1);
  EXPECT_EQ(halo_sends(q, 0).values, 100);
  EXPECT_EQ(halo_sends(q, 1).messages, 1);
  EXPECT_EQ(halo_sends(q, 2).messages, 0);
  EXPECT_EQ(halo_sends(band_plan({100, 10, 3, 2}, 1), 0).messages, 0);
}

TEST(RbeBands, PlacementIsOnePartitionPerGpuOrAllOnOne) {
  EXPECT_EQ(band_placement(4, 4).path, PeerPath::link);
  EXPECT_EQ(band_placement(4, 1).path, PeerPath::device);
  EXPECT_EQ(band_placement(1, 1).path, PeerPath::device);
  try {
    (void)band_placement(4, 2);
    FAIL() << "4 partitions over 2 GPUs were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--gpus 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)band_placement(0, 1), InputError);
  EXPECT_THROW((void)band_placement(1, 0), InputError);
  BackendOptions o;
  o.gpus = 1;
  o.partitions = 3;
  EXPECT_EQ(band_placement(o).partitions, 3);
  o.partitions = 0;  // one per GPU
  EXPECT_EQ(band_placement(o).partitions, 1);
  o.gpus = 2;
  EXPECT_EQ(band_placement(o).partitions, 2);
  EXPECT_EQ(band_placement(o).path, PeerPath::link);
  o.gpus = -1;
  EXPECT_THROW((void)band_placement(o), InputError);
  // The backend refuses a placement that is not built when it is made.
  BackendOptions bad;
  bad.partitions = 3;
  bad.gpus = 2;
  EXPECT_THROW((void)make_backend("cuda-bands", bad), InputError);
}

TEST(RbeBands, OnePartitionCountsAreCudaResidents) {
  for (const Shape s : {Shape{1000, 1000, 33, 33}, Shape{257, 130, 9, 64}, Shape{16000, 16000, 33, 33}}) {
    const Layout l = parse_layout("32x8x8");
    CostCounts bands = cuda_bands_counts(s, l, 132, band_placement(1, 1));
    bands.peer_path = PeerPath::link;
    EXPECT_EQ(bands, cuda_resident_counts(s, l, 132));
    CostCounts run = cuda_bands_run_counts(s, l, 132, band_placement(1, 1), 2500, 1000);
    run.peer_path = PeerPath::link;
    EXPECT_EQ(run, cuda_resident_run_counts(s, l, 132, 2500, 1000, false));  // bands launch without graphs
  }
}

TEST(RbeBands, TwoGpusByHand) {
  // Grid 1000 x 1000, kernel 33, layout 32x8x8 (tiles 32 x 64, no x shift: 32 columns of tiles),
  // 132 SMs. Each band 500 rows: 484 rows without halo (ceil(484 / 64) = 8 rows of tiles, 256
  // blocks, 2 waves) and 16 edge rows (one row of tiles, 32 blocks, 1 wave).
  const Shape s{1000, 1000, 33, 33};
  const Layout l = parse_layout("32x8x8");
  const std::int64_t W = 32, H = 64, S = 132;
  const std::int64_t per_block = 2 * 33 * W * (H + 32) + 2 * 33 * W * H + 3 * W * H + 2;
  const auto c = cuda_bands_counts(s, l, 132, band_placement(2, 2));
  // Two launches of the fused kernel and one of the scale kernel (6 float64 values, 12 of 4 bytes).
  EXPECT_EQ(c.launches, 2 + 1);
  EXPECT_EQ(c.waves, 2 + 1);
  EXPECT_EQ(c.atomics, 256 + 32);
  EXPECT_EQ(c.N_G, (2 + 1) * S * per_block);
  EXPECT_EQ(c.N_GG, 3 * 500 * 1000 + 2 * (33 + 33 + 2) + 2 * (256 + 32) + 12);
  // Tile fills: 3 blocks at once per SM; 2 waves fill in 1 round, 1 wave in 1.
  EXPECT_EQ(c.N_GS, 2 * S * (96 * 72 + 40 + 40));
  EXPECT_EQ(c.peer_path, PeerPath::link);
  EXPECT_EQ(c.peer_messages, 1);
  EXPECT_EQ(c.N_peer, 16 * 1000);
  EXPECT_EQ(c.collectives, 1);
  EXPECT_EQ(c.collective_bytes, 8);
  EXPECT_EQ(c.N_CG + c.N_GC + c.N_C + c.host_waits, 0);
  // Both partitions on one GPU: the same launches twice, both messages copies, two reductions
  // of two partial sums each (reads 2 x 8 bytes, writes 8).
  const auto d = cuda_bands_counts(s, l, 132, band_placement(2, 1));
  EXPECT_EQ(d.peer_path, PeerPath::device);
  EXPECT_EQ(d.launches, 2 * (2 + 1));
  EXPECT_EQ(d.N_G, 2 * c.N_G);
  EXPECT_EQ(d.N_GG, 2 * c.N_GG);
  EXPECT_EQ(d.peer_messages, 2);
  EXPECT_EQ(d.N_peer, 2 * 16 * 1000);
  EXPECT_EQ(d.collectives, 2);
  EXPECT_EQ(d.collective_bytes, 2 * (2 * 8 + 8));
  // A run of 2500 steps in segments of 1000: per segment and band the partial sums zeroed, the
  // total carried in and out and E_1 carried in (3 copies of 4 values); band 0 sends its
  // evidences to the host. The scale kernel runs m + 1 times in a segment of m steps: at k = 0
  // it reads T_0, E_1 and writes E_2 (3 float64), at 1 <= k <= m - 2 six values, at k = m - 1 and
  // m it reads T_k, E_k, T_{k-1} and writes rho_k (4 each): 3 + 6 (m - 2) + 8 = 6m - 1 values.
  const auto r = cuda_bands_run_counts(s, l, 132, band_placement(2, 2), 2500, 1000);
  const std::int64_t scale_1000 = 2 * (3 + 6 * 998 + 8), scale_500 = 2 * (3 + 6 * 498 + 8);
  const std::int64_t fused = c.N_GG - 12;  // the step's counts without its scale kernel
  EXPECT_EQ(r.N_GG, 2500 * fused + 2 * 2500 + 3 * 12 + 2 * scale_1000 + scale_500);
  EXPECT_EQ(r.launches, 2500 * 2 + 2 * 1001 + 501);
  EXPECT_EQ(r.N_GC, 2 * 2500);
  EXPECT_EQ(r.transfers_GC, 3);
  EXPECT_EQ(r.copies_GC, (std::vector<CopySize>{{8000, 2}, {4000, 1}}));
  EXPECT_EQ(r.host_waits, 3);
  EXPECT_EQ(r.peer_messages, 2500);
  EXPECT_EQ(r.collectives, 2500);
  const auto rd = cuda_bands_run_counts(s, l, 132, band_placement(2, 1), 2500, 1000);
  EXPECT_EQ(rd.N_GG, 2 * (2500 * fused + 2 * 2500 + 3 * 12 + 2 * scale_1000 + scale_500));
  EXPECT_EQ(rd.launches, 2 * (2500 * 2 + 2 * 1001 + 501));
  // A last segment of one step: its k = 0 does nothing, k = 1 reads 3 values and writes rho_1.
  const auto r1 = cuda_bands_run_counts(s, l, 132, band_placement(2, 2), 1001, 1000);
  EXPECT_EQ(r1.N_GG, 1001 * fused + 2 * 1001 + 2 * 12 + scale_1000 + 2 * 4);
  EXPECT_EQ(r1.launches, 1001 * 2 + 1001 + 2);
  EXPECT_NO_THROW(check_consistent(r));
  EXPECT_NO_THROW(check_consistent(rd));
}

TEST(RbeBands, BusiestDeviceTakesEachCountsLargest) {
  // Three bands of 334, 333 and 333 rows: the top one moves the most rows, the middle one sends
  // two messages and launches three fused kernels (and, as every band, one scale kernel).
  const Shape s{1000, 1000, 33, 33};
  const Layout l = parse_layout("32x8x8");
  const auto c = cuda_bands_counts(s, l, 132, band_placement(3, 3));
  EXPECT_EQ(c.launches, 3 + 1);
  EXPECT_EQ(c.peer_messages, 2);
  EXPECT_EQ(c.N_peer, 2 * 16 * 1000);
  // Top band: 318 inner rows (5 rows of tiles, 160 blocks) and 16 edge rows (32 blocks).
  EXPECT_EQ(c.N_GG, 3 * 334 * 1000 + 2 * 68 + 2 * (160 + 32) + 12);
  // Middle band: 301 inner rows (5 rows of tiles) and two edges of 16: 224 blocks.
  EXPECT_EQ(c.atomics, 160 + 32 + 32);
}

TEST(RbeBands, RefusesTheSplitPasses) {
  EXPECT_THROW((void)cuda_bands_counts({1000, 1000, 201, 201}, parse_layout("32x8x8:split"), 132,
                                       band_placement(2, 2)),
               InputError);
  EXPECT_THROW((void)step_counts("cuda-bands", {1000, 1000, 201, 201}, [] {
                 BackendOptions o;
                 o.layout = parse_layout("32x8x8:split");
                 o.partitions = 2;
                 o.gpus = 1;
                 return o;
               }()),
               InputError);
}

}  // namespace
}  // namespace dtflop::rbe
