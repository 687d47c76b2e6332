// The matching (workloads/dct/tracking.hpp) and its grid (kernels/point_grid.hpp) against
// references written here from their rules alone: every point's distance computed, no grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "kernels/point_grid.hpp"
#include "model/errors.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {
namespace {

// The nearest two points within `radius` of q, by looking at all of them (ties: lower index).
int brute_nearest_two(const std::vector<Vec2>& pts, Vec2 q, double radius, kernels::GridHit hit[2]) {
  std::vector<kernels::GridHit> in;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double dx = pts[i].x - q.x, dy = pts[i].y - q.y, d2 = dx * dx + dy * dy;
    if (std::sqrt(d2) <= radius) in.push_back({static_cast<std::uint32_t>(i), d2});
  }
  std::sort(in.begin(), in.end(), [](const auto& a, const auto& b) { return a.d2 < b.d2 || (a.d2 == b.d2 && a.index < b.index); });
  const int n = static_cast<int>(std::min<std::size_t>(in.size(), 2));
  for (int k = 0; k < n; ++k) hit[k] = in[static_cast<std::size_t>(k)];
  return n;
}

void expect_same_as_brute(const std::vector<Vec2>& pts, const std::vector<Vec2>& queries, double radius) {
  kernels::PointGrid grid;
  grid.build(pts.data(), pts.size(), radius);
  EXPECT_LE(grid.cells(), 3 * pts.size() + 1);  // O(n) memory, whatever the radius
  for (const Vec2& q : queries) {
    kernels::GridHit a[2], b[2];
    const int na = grid.nearest_two(q.x, q.y, a), nb = brute_nearest_two(pts, q, radius, b);
    ASSERT_EQ(na, nb) << "query (" << q.x << ", " << q.y << "), radius " << radius;
    for (int k = 0; k < na; ++k) {
      EXPECT_EQ(a[k].index, b[k].index) << "query (" << q.x << ", " << q.y << ")";
      EXPECT_EQ(a[k].d2, b[k].d2);
    }
  }
}

TEST(PointGrid, FindsWhatLookingAtEveryPointFinds) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1000);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Vec2> pts(1 + trial * 37), queries(500);
    for (auto& p : pts) p = {u(rng), u(rng)};
    // Some points twice (equal distances), queries inside, on the edge and far outside.
    for (std::size_t i = 0; i + 7 < pts.size(); i += 7) pts[i + 3] = pts[i];
    for (auto& q : queries) q = {u(rng) * 1.2 - 100, u(rng) * 1.2 - 100};
    queries.push_back({1e300, -1e300});
    for (double radius : {0.5, 7.0, 40.0, 300.0, 5000.0}) expect_same_as_brute(pts, queries, radius);
  }
}

TEST(PointGrid, DegenerateSetsAndQueries) {
  const std::vector<Vec2> one = {{5, 5}};
  expect_same_as_brute(one, {{5, 5}, {5.5, 5}, {7, 5}, {-1e9, 3}}, 1);
  std::vector<Vec2> line, same(10, Vec2{2, 3});
  for (int i = 0; i < 200; ++i) line.push_back({1000.0 * i, 0});  // no area: cells along a line
  expect_same_as_brute(line, {{0, 0}, {1000, 1}, {50'500, 0}, {1e5, 2}}, 600);
  expect_same_as_brute(same, {{2, 3}, {2, 3.5}}, 1);  // all at one place: ties by index
  kernels::PointGrid grid;
  grid.build(line.data(), 0, 1);  // an empty set finds nothing
  kernels::GridHit hit[2];
  EXPECT_EQ(grid.nearest_two(0, 0, hit), 0);
  grid.build(line.data(), line.size(), 600);
  EXPECT_EQ(grid.nearest_two(std::numeric_limits<double>::quiet_NaN(), 0, hit), 0);
  EXPECT_EQ(grid.nearest_two(std::numeric_limits<double>::infinity(), 0, hit), 0);
}

// The first pass of the matching, from its rules (tracking.hpp): a reference dot takes the nearest
// frame dot within the radius unless a second one within it is closer than `ambiguity` times; a
// frame dot proposed by several goes to the nearest proposer (the first on a tie).
std::vector<int> brute_match(const std::vector<Vec2>& ref, const std::vector<Vec2>& def, double radius, double ambiguity) {
  std::vector<int> best(def.size(), -1);
  std::vector<double> best_d(def.size(), 0);
  std::vector<int> proposal(ref.size(), -1);
  for (std::size_t j = 0; j < ref.size(); ++j) {
    kernels::GridHit hit[2];
    const int n = brute_nearest_two(def, ref[j], radius, hit);
    if (n == 0) continue;
    const double d1 = std::sqrt(hit[0].d2);
    if (n == 2 && std::sqrt(hit[1].d2) < ambiguity * d1) continue;
    proposal[j] = static_cast<int>(hit[0].index);
    if (best[hit[0].index] < 0 || d1 < best_d[hit[0].index]) {
      best[hit[0].index] = static_cast<int>(j);
      best_d[hit[0].index] = d1;
    }
  }
  std::vector<int> out(ref.size(), -1);
  for (std::size_t j = 0; j < ref.size(); ++j)
    if (proposal[j] >= 0 && best[proposal[j]] == static_cast<int>(j)) out[j] = proposal[j];
  return out;
}

TEST(DctMatching, FirstPassIsWhatItsRulesGive) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> jitter(0, 1.5), moved(0, 2.5);
  std::uniform_real_distribution<double> u(0, 1);
  std::ptrdiff_t ambiguous = 0;
  for (int trial = 0; trial < 10; ++trial) {
    std::vector<Vec2> ref, def;
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 40; ++x) ref.push_back({12.0 * x + jitter(rng), 12.0 * y + jitter(rng)});
    for (const Vec2& p : ref) {
      if (u(rng) < 0.03) continue;  // lost
      def.push_back({p.x + moved(rng), p.y + moved(rng)});
      if (u(rng) < 0.03) def.push_back({p.x + 4 * moved(rng), p.y + 4 * moved(rng)});  // a stray dot nearby
    }
    std::shuffle(def.begin(), def.end(), rng);
    MatchOptions o;
    o.search_radius = 5;
    o.refine_neighbours = 0;  // the first pass alone
    const Matches m = match_dots(ref, def, o);
    const std::vector<int> want = brute_match(ref, def, o.search_radius, o.ambiguity);
    EXPECT_EQ(m.ref_to_def, want) << "trial " << trial;
    EXPECT_EQ(m.matched, std::count_if(want.begin(), want.end(), [](int k) { return k >= 0; }));
    // Some dots were lost, so the rules were exercised (the stray dots make some ambiguous in most
    // trials: counted over all of them below).
    EXPECT_GT(std::count(m.lost_reason.begin(), m.lost_reason.end(), LostReason::nothing_near), 0);
    ambiguous += std::count(m.lost_reason.begin(), m.lost_reason.end(), LostReason::ambiguous);
    EXPECT_LT(m.matched, static_cast<int>(ref.size()));
    EXPECT_GT(m.matched, static_cast<int>(ref.size()) * 8 / 10);
  }
  EXPECT_GT(ambiguous, 0);
}

// One Matcher over frames of changing sizes, as a pipeline keeps one: each frame matched as a fresh
// one matches it (nothing of an earlier frame's grid or buffers left in the result).
TEST(DctMatching, AMatcherKeptFromFrameToFrameMatchesAsAFreshOne) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> jitter(0, 1.0), moved(0, 1.5);
  std::uniform_real_distribution<double> u(0, 1);
  Matcher kept;
  MatchOptions o;
  o.search_radius = 4;
  for (int side : {40, 5, 0, 30, 1, 45}) {
    std::vector<Vec2> ref, def;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) ref.push_back({10.0 * x + jitter(rng), 10.0 * y + jitter(rng)});
    for (const Vec2& p : ref)
      if (u(rng) > 0.05) def.push_back({p.x + moved(rng), p.y + moved(rng)});
    const Matches a = kept.match(ref, def, o), b = match_dots(ref, def, o);
    EXPECT_EQ(a.ref_to_def, b.ref_to_def) << side;
    EXPECT_EQ(a.lost_reason, b.lost_reason) << side;
    EXPECT_EQ(a.appeared, b.appeared) << side;
    EXPECT_EQ(a.match_steps, b.match_steps) << side;
    EXPECT_EQ(a.tree_steps, b.tree_steps) << side;
  }
}

TEST(DctMatching, AFrameDotNotFiniteIsBadInput) {
  const std::vector<Vec2> ref = {{0, 0}, {10, 0}, {0, 10}};
  std::vector<Vec2> def = ref;
  def[1].y = std::numeric_limits<double>::quiet_NaN();
  MatchOptions o;
  o.search_radius = 3;
  EXPECT_THROW(match_dots(ref, def, o), InputError);
}

}  // namespace
}  // namespace dtflop::dct
