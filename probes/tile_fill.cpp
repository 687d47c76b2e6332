#include "probes/tile_fill.hpp"

#include <stdexcept>
#include <string>

namespace dtflop::probes::tiles {

std::vector<float> make_grid(int n) {
  std::vector<float> g(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) g[static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + x] = cell_value(x, y);
  return g;
}

Origin tile_origin(int block, int rows, int n) {
  if (rows <= kHaloRows || rows > n || n < kPitch || block < 0)
    throw std::invalid_argument("tile_origin: needs " + std::to_string(kHaloRows) + " < rows <= n, n >= " +
                                std::to_string(kPitch) + " and block >= 0");
  const int per_row = (n - kPitch) / kOutWidth + 1;
  const std::int64_t row = block / per_row;
  Origin o;
  o.x = (block % per_row) * kOutWidth;
  o.y = static_cast<int>(row * (rows - kHaloRows) % (n - rows + 1));
  return o;
}

GridSums::GridSums(const std::vector<float>& grid, int n)
    : n_(n), s_(static_cast<std::size_t>(n + 1) * static_cast<std::size_t>(n + 1), 0) {
  if (n < 1 || grid.size() != static_cast<std::size_t>(n) * static_cast<std::size_t>(n))
    throw std::invalid_argument("GridSums: the grid must hold n x n cells");
  const auto at = [n](int x, int y) { return static_cast<std::size_t>(y) * static_cast<std::size_t>(n + 1) + x; };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      s_[at(x + 1, y + 1)] = static_cast<std::int64_t>(grid[static_cast<std::size_t>(y) * n + x]) + s_[at(x, y + 1)] +
                             s_[at(x + 1, y)] - s_[at(x, y)];
}

std::int64_t GridSums::sum(int x, int y, int cols, int rows) const {
  if (x < 0 || y < 0 || cols < 0 || rows < 0 || x + cols > n_ || y + rows > n_)
    throw std::invalid_argument("GridSums::sum: the rectangle must lie inside the grid");
  const auto at = [this](int cx, int cy) {
    return s_[static_cast<std::size_t>(cy) * static_cast<std::size_t>(n_ + 1) + cx];
  };
  return at(x + cols, y + rows) - at(x, y + rows) - at(x + cols, y) + at(x, y);
}

std::int64_t counted_fill_bytes(std::int64_t blocks, int sms, int occ, std::int64_t values) {
  if (blocks < 1 || sms < 1 || occ < 1 || values < 1)
    throw std::invalid_argument("counted_fill_bytes: blocks, sms, occ and values must be >= 1");
  const std::int64_t q = (blocks + sms - 1) / sms;
  return (q + occ - 1) / occ * sms * values * static_cast<std::int64_t>(sizeof(float));
}

std::vector<int> fill_rows(int smem_per_block, int scratch) {
  std::vector<int> out;
  for (int rows : {48, 64, 96, 128, 160, 192, 224})
    if (static_cast<std::int64_t>(rows) * kPitch * static_cast<std::int64_t>(sizeof(float)) + scratch <= smem_per_block)
      out.push_back(rows);
  return out;
}

}  // namespace dtflop::probes::tiles
