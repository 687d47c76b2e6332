// Belief snapshots as images: the belief (colour map of the square root of belief / its maximum), the true raft's
// track and position (white), each helicopter's track and position (one colour each).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "workloads/rbe/grid.hpp"

namespace dtflop::sar {

struct Track {
  std::vector<rbe::Point> points;  // oldest first; the last is the current position
};

// Whether this build can write images (DTFLOP_IMAGE_IO).
bool can_write_images();
// Writes a PNG of `belief` on `grid` with the tracks drawn, `pixels_per_cell` >= 1. Throws
// InputError when images are not built in or the file cannot be written.
void write_snapshot(const std::string& path, const rbe::Grid& grid, std::span<const double> belief,
                    const Track& raft, const std::vector<Track>& helicopters, int pixels_per_cell = 4);

}  // namespace dtflop::sar
