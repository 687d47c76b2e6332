// A uniform grid of cells over a set of 2D points, for the nearest points within a fixed radius:
// the DCT workload's matching (each reference dot asks for the nearest two frame dots within the
// search radius) and the cpu-match probe that prices it run this one source.
//
// The cells are about as wide as the points' spacing (sqrt(area / n), area: the points' bounding
// box), so the grid has about n cells or fewer and costs O(n) memory, and a cell holds about one
// point of an evenly spread set. A search reads the cells within one cell's width of the query
// (or within the radius, if smaller), and twice as far, up to the radius, until the two nearest
// found lie within what it read: with the matching's radius (0.4 of the spacing) one pass over 1
// to 4 cells, and a larger radius costs about what the two nearest's distance does, not what the
// radius does. Building is a counting
// sort of the points by cell (two passes over the points, one over the cells); the points are kept
// in cell order, so a search reads a few short runs of contiguous coordinates instead of chasing a
// tree's pointers.
//
// Header only; it depends on nothing.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace dtflop::kernels {

// One point found by a search: its index in the set the grid was built over, and its squared
// distance to the query.
struct GridHit {
  std::uint32_t index = 0;
  double d2 = 0;
};

class PointGrid {
 public:
  // Bins points[0..n) (anything with members x and y; finite) for searches within `radius`
  // (finite, > 0). The points are copied: they need not outlive the grid.
  template <class P>
  void build(const P* points, std::size_t n, double radius) {
    radius_ = radius;
    n_ = n;
    x_.resize(n);
    y_.resize(n);
    index_.resize(n);
    if (n == 0) {
      nx_ = ny_ = 0;
      start_.assign(1, 0);
      return;
    }
    double x0 = points[0].x, x1 = x0, y0 = points[0].y, y1 = y0;
    for (std::size_t i = 1; i < n; ++i) {
      x0 = std::min(x0, points[i].x);
      x1 = std::max(x1, points[i].x);
      y0 = std::min(y0, points[i].y);
      y1 = std::max(y1, points[i].y);
    }
    const double w = x1 - x0, h = y1 - y0, count = static_cast<double>(n);
    // About one point per cell; never more than n cells along a side.
    cell_ = std::max(std::sqrt(w * h / count), std::max(w, h) / count);
    if (!(cell_ > 0)) cell_ = radius > 0 ? radius : 1;  // one point, or all at one place
    x0_ = x0;
    y0_ = y0;
    nx_ = static_cast<std::size_t>(w / cell_) + 1;
    ny_ = static_cast<std::size_t>(h / cell_) + 1;
    start_.assign(nx_ * ny_ + 1, 0);
    cell_of_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t c = cell(points[i].x, points[i].y);
      cell_of_[i] = static_cast<std::uint32_t>(c);
      ++start_[c + 1];
    }
    for (std::size_t c = 0; c < nx_ * ny_; ++c) start_[c + 1] += start_[c];
    fill_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {  // in index order: a cell's points keep their order
      const std::uint32_t at = fill_[cell_of_[i]]++;
      x_[at] = points[i].x;
      y_[at] = points[i].y;
      index_[at] = static_cast<std::uint32_t>(i);
    }
  }

  // The nearest and the second-nearest of the points within the radius of (qx, qy) (distance
  // <= radius), nearest first, in hit[0] and hit[1]; equally distant points in index order.
  // Returns how many it found: 0, 1 or 2. A query that is not finite finds nothing.
  int nearest_two(double qx, double qy, GridHit hit[2]) const {
    if (n_ == 0) return 0;
    // The cells within `reach` of the query first, `reach` one cell (or the radius, if smaller);
    // when the two nearest found lie within it, no point outside can be nearer; else twice the
    // reach, up to the radius. With the matching's radius (0.4 of the spacing) one pass of 1 to 4
    // cells.
    double reach = std::min(radius_, cell_);
    int found = 0;
    for (;;) {
      found = 0;
      scan_box(qx, qy, reach, hit, found);
      if (reach >= radius_ || (found == 2 && std::sqrt(hit[1].d2) <= reach)) return found;
      reach = std::min(radius_, 2 * reach);
    }
  }

  std::size_t size() const { return n_; }
  std::size_t cells() const { return nx_ * ny_; }
  double cell_width() const { return cell_; }

 private:
  static bool before(const GridHit& a, const GridHit& b) { return a.d2 < b.d2 || (a.d2 == b.d2 && a.index < b.index); }
  // Every point in the cells that the square [q - reach, q + reach] touches, through scan. The
  // columns and rows are computed as doubles and clamped to the grid before they become integers
  // (a query far outside, or not finite, reads nothing).
  void scan_box(double qx, double qy, double reach, GridHit hit[2], int& found) const {
    const double fx0 = (qx - reach - x0_) / cell_, fx1 = (qx + reach - x0_) / cell_;
    const double fy0 = (qy - reach - y0_) / cell_, fy1 = (qy + reach - y0_) / cell_;
    const double nx = static_cast<double>(nx_), ny = static_cast<double>(ny_);
    if (!(fx1 >= 0 && fx0 < nx && fy1 >= 0 && fy0 < ny)) return;
    const std::size_t ix0 = fx0 > 0 ? static_cast<std::size_t>(fx0) : 0;
    const std::size_t ix1 = fx1 < nx ? static_cast<std::size_t>(fx1) : nx_ - 1;
    const std::size_t iy0 = fy0 > 0 ? static_cast<std::size_t>(fy0) : 0;
    const std::size_t iy1 = fy1 < ny ? static_cast<std::size_t>(fy1) : ny_ - 1;
    for (std::size_t iy = iy0; iy <= iy1; ++iy) {
      const std::size_t row = iy * nx_;
      // A row's touched cells are contiguous in cell order: one run of points.
      scan(start_[row + ix0], start_[row + ix1 + 1], qx, qy, hit, found);
    }
  }
  // The points [from, to) in cell order, each kept if within the radius and nearer than the two held.
  void scan(std::uint32_t from, std::uint32_t to, double qx, double qy, GridHit hit[2], int& found) const {
    for (std::uint32_t k = from; k < to; ++k) {
      const double dx = x_[k] - qx, dy = y_[k] - qy, d2 = dx * dx + dy * dy;
      if (!(std::sqrt(d2) <= radius_)) continue;
      const GridHit h{index_[k], d2};
      if (found == 0) {
        hit[0] = h;
        found = 1;
      } else if (before(h, hit[0])) {
        hit[1] = hit[0];
        hit[0] = h;
        found = 2;
      } else if (found == 1 || before(h, hit[1])) {
        hit[1] = h;
        found = 2;
      }
    }
  }
  std::size_t cell(double x, double y) const {
    const auto ix = std::min(static_cast<std::size_t>((x - x0_) / cell_), nx_ - 1);
    const auto iy = std::min(static_cast<std::size_t>((y - y0_) / cell_), ny_ - 1);
    return iy * nx_ + ix;
  }

  double radius_ = 0, cell_ = 1, x0_ = 0, y0_ = 0;
  std::size_t n_ = 0, nx_ = 0, ny_ = 0;
  std::vector<std::uint32_t> start_;    // per cell, its first point in cell order; one past the end last
  std::vector<std::uint32_t> fill_;     // building: the next free place of each cell
  std::vector<std::uint32_t> cell_of_;  // building: each point's cell
  std::vector<double> x_, y_;           // the points in cell order
  std::vector<std::uint32_t> index_;    // their indices in the set given
};

// Why a query of a matching pass found no point (none: it did).
enum class MatchLoss : std::uint8_t { none = 0, nothing_near, ambiguous, claimed_by_other };

// One pass of the DCT workload's matching over a grid of the frame's points (the workload's
// Matcher and the cpu-match probe run this one source): each listed query q, at where[q], proposes
// its nearest point within the grid's radius, unless a second point lies within `ambiguity` times
// that distance (ambiguous); a point two queries propose goes to the nearer, and the other query is
// lost (claimed_by_other). Query which[q]'s match goes to match[which[q]] (a point's index, or -1)
// and its outcome to loss[which[q]]; owner[k] and owner_d[k] (one per point of the grid, -1 and 0
// before the first pass) hold the query that has point k and its distance. One step a query.
template <class P>
void match_pass(const PointGrid& grid, const int* which, const P* where, std::size_t n, double ambiguity, int* match,
                MatchLoss* loss, int* owner, double* owner_d) {
  GridHit hit[2];
  for (std::size_t q = 0; q < n; ++q) {
    const int j = which[q];
    const int found = grid.nearest_two(where[q].x, where[q].y, hit);
    if (found == 0) {
      loss[j] = MatchLoss::nothing_near;
      continue;
    }
    const double d1 = std::sqrt(hit[0].d2);
    if (found > 1 && std::sqrt(hit[1].d2) < ambiguity * d1) {
      loss[j] = MatchLoss::ambiguous;
      continue;
    }
    const int k = static_cast<int>(hit[0].index);
    if (owner[k] >= 0) {
      if (owner_d[k] <= d1) {
        loss[j] = MatchLoss::claimed_by_other;
        continue;
      }
      match[owner[k]] = -1;
      loss[owner[k]] = MatchLoss::claimed_by_other;
    }
    owner[k] = j;
    owner_d[k] = d1;
    match[j] = k;
    loss[j] = MatchLoss::none;
  }
}

}  // namespace dtflop::kernels
