// The host side of the gpu-tiles probe: the tiles it fills are cuda-resident's, where each block's
// tile lies, the exact sums it checks the blocks against, the bytes it counts as N_GS does.
#include <cstdint>
#include <algorithm>
#include <array>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "probes/tile_fill.hpp"
#include "workloads/rbe/resident_geometry.hpp"

namespace dtflop::probes::tiles {
namespace {

// The probe's tile is the fused kernel's input tile of cuda-resident's default layout with a 33 x 33
// kernel, and as many of its blocks share a multiprocessor as of cuda-resident's.
TEST(TileFill, TheTileIsCudaResidentsDefaultFusedTile) {
  const rbe::Layout layout;  // the default, 32x8x16
  const auto g = rbe::resident::fused_geometry(rbe::Shape{2000, 2000, 33, 33}, layout);
  EXPECT_EQ(g.in_cols, kCols);
  EXPECT_EQ(g.in_pitch, kPitch);
  EXPECT_EQ(g.in_rows - g.out_h, kHaloRows);
  EXPECT_EQ(g.out_w, kOutWidth);
  EXPECT_EQ(layout.block_x * layout.block_y, kThreads);
  EXPECT_EQ(rbe::resident::blocks_per_sm(kThreads, rbe::resident::kFusedRegs, g.smem_bytes), kBlocksPerSm);
  // cuda-resident's tile height (128 + 32 rows) is one of the heights the probe sweeps.
  const auto rows = fill_rows(233472 / 3 - 1024, 64);
  EXPECT_NE(std::find(rows.begin(), rows.end(), g.in_rows), rows.end());
}

TEST(TileFill, CellsAreSmallIntegers) {
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      const float v = cell_value(x, y);
      EXPECT_GE(v, 0.f);
      EXPECT_LE(v, 15.f);
      EXPECT_EQ(v, static_cast<float>(static_cast<int>(v)));
    }
  // The largest tile's sum stays exact in float.
  EXPECT_LT(224.0 * kCols * 15, 16777216.0);
}

TEST(TileFill, TilesLieInsideTheGridOnAlignedColumnsAndOverlapByTheirHalo) {
  const int n = kGridN;
  for (int rows : {48, 160, 224}) {
    std::set<std::pair<int, int>> seen;
    for (int b = 0; b < 5000; ++b) {
      const Origin o = tile_origin(b, rows, n);
      EXPECT_EQ(o.x % 4, 0) << b;
      EXPECT_GE(o.x, 0);
      EXPECT_GE(o.y, 0);
      EXPECT_LE(o.x + kPitch, n) << b;  // the accelerator's box is kPitch wide
      EXPECT_LE(o.y + rows, n) << b;
      seen.insert({o.x, o.y});
    }
    EXPECT_GT(seen.size(), 1000u) << rows;  // not every block on the same few tiles
    // Neighbours along a row start kOutWidth apart; the next row of blocks rows - halo lower.
    const int per_row = (n - kPitch) / kOutWidth + 1;
    EXPECT_EQ(tile_origin(1, rows, n).x - tile_origin(0, rows, n).x, kOutWidth);
    EXPECT_EQ(tile_origin(per_row, rows, n).x, 0);
    EXPECT_EQ(tile_origin(per_row, rows, n).y, rows - kHaloRows);
  }
  EXPECT_THROW(tile_origin(0, kHaloRows, n), std::invalid_argument);
  EXPECT_THROW(tile_origin(0, n + 1, n), std::invalid_argument);
  EXPECT_THROW(tile_origin(-1, 64, n), std::invalid_argument);
}

TEST(TileFill, GridSumsAreTheSumsOfTheCells) {
  const int n = 97;
  const std::vector<float> g = make_grid(n);
  ASSERT_EQ(g.size(), 97u * 97u);
  const GridSums s(g, n);
  for (auto [x, y, c, r] : std::vector<std::array<int, 4>>{{0, 0, 97, 97}, {4, 7, 72, 48}, {96, 96, 1, 1}, {5, 5, 0, 3}}) {
    std::int64_t want = 0;
    for (int yy = y; yy < y + r; ++yy)
      for (int xx = x; xx < x + c; ++xx) want += static_cast<std::int64_t>((xx * 3 + yy * 5) & 15);
    EXPECT_EQ(s.sum(x, y, c, r), want) << x << "," << y << " " << c << "x" << r;
  }
  EXPECT_THROW(s.sum(90, 0, 8, 1), std::invalid_argument);
  EXPECT_THROW(s.sum(-1, 0, 1, 1), std::invalid_argument);
  EXPECT_THROW(GridSums(g, 96), std::invalid_argument);
}

TEST(TileFill, BytesAreCountedAsNGsCountsThem) {
  // 24 blocks per multiprocessor on 132, 3 at once: 8 rounds of one 160 x 72 tile on each.
  EXPECT_EQ(counted_fill_bytes(24 * 132, 132, 3, 160 * 72), std::int64_t{8} * 132 * 160 * 72 * 4);
  // One block more makes the busiest multiprocessor run 25 blocks: 9 rounds.
  EXPECT_EQ(counted_fill_bytes(24 * 132 + 1, 132, 3, 160 * 72), std::int64_t{9} * 132 * 160 * 72 * 4);
  // Fewer blocks than multiprocessors still count a round on every one.
  EXPECT_EQ(counted_fill_bytes(5, 132, 3, 100), std::int64_t{132} * 100 * 4);
  EXPECT_THROW(counted_fill_bytes(0, 132, 3, 1), std::invalid_argument);
  EXPECT_THROW(counted_fill_bytes(1, 132, 0, 1), std::invalid_argument);
}

TEST(TileFill, HeightsFitTheSharedMemoryGiven) {
  EXPECT_EQ(fill_rows(233472 / 3 - 1024, 64), (std::vector<int>{48, 64, 96, 128, 160, 192, 224}));
  // 160 rows of 76 floats and the scratch fit in 48704 bytes, 192 rows do not.
  EXPECT_EQ(fill_rows(160 * kPitch * 4 + 64, 64), (std::vector<int>{48, 64, 96, 128, 160}));
  EXPECT_TRUE(fill_rows(1000, 64).empty());
}

}  // namespace
}  // namespace dtflop::probes::tiles
