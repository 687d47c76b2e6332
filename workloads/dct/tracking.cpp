#include "workloads/dct/tracking.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nanoflann.hpp>

#include "kernels/point_grid.hpp"
#include "model/errors.hpp"

namespace dtflop::dct {

// nanoflann 1.4 and later (Debian 12 ships 1.4.2) build the index in the tree's constructor; a
// buildIndex() after it built the whole tree a second time (the matching's trees were built twice
// until 2026-11-27, against the one build tree_build_steps counts and the cpu-tree probe times).
static_assert(NANOFLANN_VERSION >= 0x140, "nanoflann 1.4 or later: its constructor builds the index");

// The cloud and the tree are the Impl's own types (not in an anonymous namespace: tracking.hpp
// declares Impl, and a unity build compiles this file as an included one).
struct PointIndex::Impl {
  struct Cloud {
    const std::vector<Vec2>* pts;
    std::size_t kdtree_get_point_count() const { return pts->size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return dim == 0 ? (*pts)[i].x : (*pts)[i].y; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const { return false; }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 2, std::uint32_t>;
  Cloud cloud;
  Tree tree;
  explicit Impl(const std::vector<Vec2>& p)
      : cloud{&p}, tree(2, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kKdTreeLeaf)) {}
};

PointIndex::PointIndex(const std::vector<Vec2>& points) : impl_(std::make_unique<Impl>(points)) {}
PointIndex::~PointIndex() = default;
std::size_t PointIndex::size() const { return impl_->cloud.pts->size(); }

void PointIndex::knn(Vec2 q, int k, std::vector<std::uint32_t>& idx, std::vector<double>& d2) const {
  const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(std::max(k, 0)), size());
  idx.assign(n, 0);
  d2.assign(n, 0);
  if (n == 0) return;
  const double qq[2] = {q.x, q.y};
  const std::size_t got = impl_->tree.knnSearch(qq, n, idx.data(), d2.data());
  idx.resize(got);
  d2.resize(got);
}

void PointIndex::within(Vec2 q, double radius, std::vector<std::pair<std::uint32_t, double>>& out) const {
  out.clear();
  if (size() == 0) return;
  const double qq[2] = {q.x, q.y};
  impl_->tree.radiusSearch(qq, radius * radius, out, nanoflann::SearchParams(32, 0, true));
}

double median_spacing(const std::vector<Vec2>& points) {
  if (points.size() < 2) return 0;
  PointIndex index(points);
  std::vector<double> nn;
  nn.reserve(points.size());
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (const auto& p : points) {
    index.knn(p, 2, idx, d2);
    nn.push_back(std::sqrt(d2.back()));
  }
  std::nth_element(nn.begin(), nn.begin() + static_cast<std::ptrdiff_t>(nn.size() / 2), nn.end());
  return nn[nn.size() / 2];
}

std::string Matches::summary() const {
  int nothing = 0, ambiguous = 0, claimed = 0;
  for (auto r : lost_reason) {
    nothing += r == LostReason::nothing_near;
    ambiguous += r == LostReason::ambiguous;
    claimed += r == LostReason::claimed_by_other;
  }
  const int lost = nothing + ambiguous + claimed;
  std::string s = fmt::format("{} of {} reference dots matched", matched, ref_to_def.size());
  if (lost > 0)
    s += fmt::format(", {} lost ({} with no dot within {:.1f} px, {} ambiguous, {} claimed by a nearer dot)", lost,
                     nothing, search_radius, ambiguous, claimed);
  if (!appeared.empty()) s += fmt::format(", {} unmatched dot(s) appeared", appeared.size());
  return s;
}

MatchWork match_work(std::int64_t reference, std::int64_t deformed, std::int64_t refined, std::int64_t retried,
                     int refine_neighbours, bool radius_given) {
  MatchWork w;
  if (!radius_given && reference >= 2) w.tree_steps += tree_build_steps(reference) + reference * tree_search_steps(reference, 2);
  if (deformed == 0 || reference == 0) return w;
  w.match_steps = deformed + reference + retried;
  if (refined > 0) w.tree_steps += tree_build_steps(reference) + refined * tree_search_steps(reference, 2 * refine_neighbours + 1);
  return w;
}

Matches match_dots(const std::vector<Vec2>& reference, const std::vector<Vec2>& deformed, const MatchOptions& o,
                   const std::vector<Vec2>& predicted) {
  Matcher matcher;
  return matcher.match(reference, deformed, o, predicted);
}

Matches Matcher::match(const std::vector<Vec2>& reference, const std::vector<Vec2>& deformed, const MatchOptions& o,
                       const std::vector<Vec2>& predicted) {
  if (!predicted.empty() && predicted.size() != reference.size())
    throw InputError("predicted positions must be given for every reference dot");
  if (!(o.ambiguity >= 1)) throw InputError("the ambiguity ratio must be >= 1");
  for (std::size_t k = 0; k < deformed.size(); ++k)
    if (!std::isfinite(deformed[k].x) || !std::isfinite(deformed[k].y))
      throw InputError(fmt::format("dot {} of the frame is at a position that is not finite ({}, {}); the frame's "
                                   "analysis gave it: check the image",
                                   k, deformed[k].x, deformed[k].y));
  const std::size_t n = reference.size();
  Matches m;
  m.ref_to_def.assign(n, -1);
  m.lost_reason.assign(n, LostReason::nothing_near);
  m.search_radius = o.search_radius > 0 ? o.search_radius : 0.4 * median_spacing(reference);
  // The search radius given, no tree over the reference is built for it.
  if (!(o.search_radius > 0) && n >= 2)
    m.tree_steps = tree_build_steps(static_cast<std::int64_t>(n)) +
                   static_cast<std::int64_t>(n) * tree_search_steps(static_cast<std::int64_t>(n), 2);
  if (!(m.search_radius > 0)) m.search_radius = 1;  // one dot: nothing to scale by
  if (deformed.empty() || n == 0) {
    for (std::size_t k = 0; k < deformed.size(); ++k) m.appeared.push_back(static_cast<int>(k));
    return m;
  }
  // Only dots within the search radius decide a match (the nearest must be inside it, and a
  // second-nearest makes it ambiguous only if inside it too), so a grid of cells of about one dot
  // each answers what a k-d tree would, in a few contiguous reads (kernels/point_grid.hpp).
  grid_.build(deformed.data(), deformed.size(), m.search_radius);
  m.match_steps = static_cast<std::int64_t>(deformed.size());
  std::vector<int>& owner = owner_;
  std::vector<double>& owner_d = owner_d_;
  owner.assign(deformed.size(), -1);
  owner_d.assign(deformed.size(), 0);

  // One pass: each listed reference dot proposes its nearest deformed dot; conflicts go to
  // the nearer proposer and the other is lost (claimed).
  auto pass = [&](const std::vector<int>& which, const std::vector<Vec2>& where) {
    kernels::match_pass(grid_, which.data(), where.data(), which.size(), o.ambiguity, m.ref_to_def.data(),
                        m.lost_reason.data(), owner.data(), owner_d.data());
    m.match_steps += static_cast<std::int64_t>(which.size());
  };
  which_.resize(n);
  where_.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    which_[j] = static_cast<int>(j);
    where_[j] = predicted.empty() ? reference[j] : predicted[j];
  }
  pass(which_, where_);

  // Second pass for the lost: predict from the mean displacement of matched neighbours (their
  // k nearest in the reference: a k-d tree, built only when a dot was lost).
  std::vector<int> lost;
  for (std::size_t j = 0; j < n; ++j)
    if (m.ref_to_def[j] < 0) lost.push_back(static_cast<int>(j));
  if (!lost.empty() && o.refine_neighbours > 0 && lost.size() < n) {
    PointIndex ref_index(reference);
    m.tree_steps += tree_build_steps(static_cast<std::int64_t>(n));
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    std::vector<Vec2> guess;
    std::vector<int> retry;
    for (int j : lost) {
      ref_index.knn(reference[j], o.refine_neighbours * 2 + 1, idx, d2);
      m.tree_steps += tree_search_steps(static_cast<std::int64_t>(n), o.refine_neighbours * 2 + 1);
      double sx = 0, sy = 0;
      int c = 0;
      for (auto k : idx) {
        const int t = m.ref_to_def[k];
        if (t < 0 || c >= o.refine_neighbours) continue;
        sx += deformed[t].x - reference[k].x;
        sy += deformed[t].y - reference[k].y;
        ++c;
      }
      if (c == 0) continue;
      retry.push_back(j);
      guess.push_back({reference[j].x + sx / c, reference[j].y + sy / c});
    }
    pass(retry, guess);
  }
  m.matched = static_cast<int>(std::count_if(m.ref_to_def.begin(), m.ref_to_def.end(), [](int t) { return t >= 0; }));
  for (std::size_t k = 0; k < deformed.size(); ++k)
    if (owner[k] < 0) m.appeared.push_back(static_cast<int>(k));
  return m;
}

}  // namespace dtflop::dct
