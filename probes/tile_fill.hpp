// The host side of the gpu-tiles probe (B_GS), plain C++ so that it is tested without a GPU: the
// tiles the probe's kernel fills (cuda-resident's fused tile, resident_geometry.hpp), where each
// block's tile lies in the probe's grid, the bytes the model counts for a launch (N_GS,
// backend_counts.hpp), and the exact sum every block must find in its tile.
#pragma once

#include <cstdint>
#include <vector>

namespace dtflop::probes::tiles {

// cuda-resident's default layout (32 x 8 threads, 16 cells a thread: tiles of 32 x 128 outputs)
// with a 33 x 33 kernel: input tiles of 128 + 32 rows x (32 + 40) columns, rows 76 floats apart
// in shared memory (vec_pitch), every row starting at a column that is a multiple of 4.
inline constexpr int kThreads = 256;
inline constexpr int kOutWidth = 32;   // outputs per tile row: neighbouring tiles start 32 columns apart
inline constexpr int kCols = 72;       // columns a tile copies (32 + 8 ceil(33 / 8))
inline constexpr int kPitch = 76;      // floats between the rows of a tile in shared memory
inline constexpr int kHaloRows = 32;   // rows a tile shares with the next one down (33 taps)
inline constexpr int kBlocksPerSm = 3; // what cuda-resident's fused kernel runs at once (80 registers)

// The probe's grid: n x n floats (16 MiB at n = 2048, resident in the L2 cache of the GPUs that
// cuda-resident targets, as a step's belief of up to ~2000 x 2000 cells is), rows n floats apart.
inline constexpr int kGridN = 2048;

// Cell (x, y) of the grid: a small integer, so that every sum the probe forms (at most 224 x 72
// x 15 < 2^24) is exact in float whatever order the threads add in.
inline float cell_value(int x, int y) { return static_cast<float>((x * 3 + y * 5) & 15); }
std::vector<float> make_grid(int n);

// Where block `b` fills its tile of `rows` rows: tiles of a row of blocks start kOutWidth
// columns apart (as many as fit their kPitch columns inside the grid), the rows of blocks
// rows - kHaloRows rows apart (as cuda-resident's tiles overlap by their halo), wrapping round
// the n - rows + 1 rows a tile can start at. x is a multiple of 4. Needs kHaloRows < rows <= n.
struct Origin {
  int x = 0, y = 0;
};
Origin tile_origin(int block, int rows, int n);

// The exact sums of rectangles of a grid (2D prefix sums of integer-valued cells).
class GridSums {
 public:
  GridSums(const std::vector<float>& grid, int n);
  // Sum of the cells [x, x + cols) x [y, y + rows), which must lie inside the grid.
  std::int64_t sum(int x, int y, int cols, int rows) const;

 private:
  int n_;
  std::vector<std::int64_t> s_;  // (n + 1)^2
};

// The tile bytes the model counts for one launch of `blocks` blocks of tiles of `values` floats
// on `sms` multiprocessors running `occ` at once (backend_counts.hpp, N_GS): the busiest
// multiprocessor fills ceil(ceil(blocks / sms) / occ) rounds, counted on every multiprocessor.
std::int64_t counted_fill_bytes(std::int64_t blocks, int sms, int occ, std::int64_t values);

// The tile heights the probe sweeps (largest last), those of `smem_per_block` bytes of shared
// memory that also leave `scratch` bytes: from 48 rows (16 outputs a column) to 224.
std::vector<int> fill_rows(int smem_per_block, int scratch);

}  // namespace dtflop::probes::tiles
