// The frames gpu-centroid times (probes/centroid_specimen.hpp): drawn where they say, their
// windows what the counts call window pixels, and the check that guards the device's centroids
// failing where it must. The float64 centroids here are the shared arithmetic
// (kernels/dot_centroid.hpp) that the device's are checked against; they are checked in turn
// against the centres the dots were drawn at, which the arithmetic never sees.
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/centroid_specimen.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes::centroid {
namespace {

TEST(CentroidSpecimen, HostCentroidsFindTheDrawnCentres) {
  for (double radius : {4.0, 8.5, 14.0, 24.0}) {
    const Specimen s = make_specimen(radius, 60, 3);
    ASSERT_EQ(s.host.size(), 120u);
    ASSERT_EQ(s.centres.size(), 120u);
    double worst = 0;
    for (std::size_t k = 0; k < 60; ++k)
      worst = std::max(worst, std::hypot(s.host[2 * k] - s.centres[2 * k], s.host[2 * k + 1] - s.centres[2 * k + 1]));
    // 8-bit rounding of the edge pixels: 0.0018 (radius 24) to 0.0052 px (radius 4) at this seed.
    EXPECT_LT(worst, 0.01) << "radius " << radius;
  }
}

TEST(CentroidSpecimen, WindowsHoldTheirDotsAndAddUpToTheWindowPixels) {
  const Specimen s = make_specimen(4, 100, 5);
  const gpu::CentroidFrame& f = s.frame;
  ASSERT_EQ(f.component.size(), 100u);
  ASSERT_EQ(f.windows.size(), 400u);
  ASSERT_EQ(f.image.size(), static_cast<std::size_t>(f.width) * f.height);
  std::vector<std::int64_t> area(100, 0);
  for (int l : f.labels)
    if (l >= 0) ++area.at(static_cast<std::size_t>(l));
  std::int64_t pixels = 0;
  int overlapping = 0;
  for (std::size_t k = 0; k < 100; ++k) {
    const int* q = &f.windows[4 * k];
    ASSERT_GE(q[0], 0);
    ASSERT_GE(q[1], 0);
    ASSERT_LE(q[0] + q[2], f.width);
    ASSERT_LE(q[1] + q[3], f.height);
    pixels += static_cast<std::int64_t>(q[2]) * q[3];
    EXPECT_NEAR(static_cast<double>(area[k]), std::numbers::pi * 16, 0.25 * std::numbers::pi * 16);
    // The dot's labels lie inside its window, at least margin + ring from its edges.
    std::int64_t inside = 0;
    for (int y = q[1] + 4; y < q[1] + q[3] - 4; ++y)
      for (int x = q[0] + 4; x < q[0] + q[2] - 4; ++x) inside += f.labels[static_cast<std::size_t>(y) * f.width + x] == static_cast<int>(k);
    EXPECT_EQ(inside, area[k]);
    if (k + 1 < 100 && k % 10 != 9 && q[0] + q[2] > f.windows[4 * (k + 1)]) ++overlapping;
  }
  EXPECT_EQ(pixels, s.window_pixels);
  // Centres 3 radii + 1 px apart, as close as the workload's: neighbours' windows overlap.
  EXPECT_EQ(overlapping, 90);
}

TEST(CentroidSpecimen, CheckFailsOnAMovedOrMissingCentroid) {
  const Specimen s = make_specimen(6, 20, 9);
  EXPECT_NO_THROW(check(s, s.host, 1e-3, "host's"));
  std::vector<double> moved = s.host;
  moved[7] += 2e-3;
  EXPECT_THROW(check(s, moved, 1e-3, "moved"), ValidationError);
  std::vector<double> nan = s.host;
  nan[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(check(s, nan, 1e-3, "missing"), ValidationError);
  EXPECT_THROW(check(s, std::vector<double>(s.host.begin(), s.host.end() - 2), 1e-3, "short"), ValidationError);
}

TEST(CentroidSpecimen, RefusesSizesOutsideItsRange) {
  EXPECT_THROW(make_specimen(2.5, 10, 1), std::invalid_argument);
  EXPECT_THROW(make_specimen(41, 10, 1), std::invalid_argument);
  EXPECT_THROW(make_specimen(8, 0, 1), std::invalid_argument);
  EXPECT_THROW(make_specimen(8, 20001, 1), std::invalid_argument);
  EXPECT_THROW(make_specimen(std::numeric_limits<double>::quiet_NaN(), 10, 1), std::invalid_argument);
}

}  // namespace
}  // namespace dtflop::probes::centroid
