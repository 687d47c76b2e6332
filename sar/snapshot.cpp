#include "sar/snapshot.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#ifdef DTFLOP_IMAGE_IO
#include <opencv2/imgcodecs.hpp>
#endif

#include "model/errors.hpp"

namespace dtflop::sar {

bool can_write_images() {
#ifdef DTFLOP_IMAGE_IO
  return true;
#else
  return false;
#endif
}

void write_snapshot(const std::string& path, const rbe::Grid& grid, std::span<const double> belief, const Track& raft,
                    const std::vector<Track>& helicopters, int pixels_per_cell) {
#ifndef DTFLOP_IMAGE_IO
  (void)path, (void)grid, (void)belief, (void)raft, (void)helicopters, (void)pixels_per_cell;
  throw InputError("belief snapshots need image I/O: this dtflop was built with DTFLOP_IMAGE_IO=OFF; leave out --snapshots");
#else
  const int s = std::max(1, pixels_per_cell);
  const int w = static_cast<int>(grid.nx()), h = static_cast<int>(grid.ny());
  const double top = *std::max_element(belief.begin(), belief.end());
  cv::Mat grey(h, w, CV_8UC1);
  for (int iy = 0; iy < h; ++iy)
    for (int ix = 0; ix < w; ++ix) {
      // Square-root scaled, so that a spread belief still shows beside its peak.
      const double v = top > 0 ? std::sqrt(belief[static_cast<std::size_t>(grid.index(ix, iy))] / top) : 0.0;
      // y up: row 0 of the image is the top of the area.
      grey.at<unsigned char>(h - 1 - iy, ix) = static_cast<unsigned char>(std::clamp(v, 0.0, 1.0) * 255.0 + 0.5);
    }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_VIRIDIS);
  cv::resize(colour, colour, cv::Size(w * s, h * s), 0, 0, cv::INTER_NEAREST);
  auto px = [&](rbe::Point p) {
    return cv::Point(static_cast<int>((p.x - grid.x_min()) / grid.dx() * s),
                     static_cast<int>((grid.y_max() - p.y) / grid.dy() * s));
  };
  auto draw = [&](const Track& t, const cv::Scalar& c, int radius) {
    for (std::size_t i = 1; i < t.points.size(); ++i) cv::line(colour, px(t.points[i - 1]), px(t.points[i]), c, 1, cv::LINE_AA);
    if (!t.points.empty()) cv::circle(colour, px(t.points.back()), radius, c, 2, cv::LINE_AA);
  };
  const cv::Scalar palette[] = {{0, 0, 255}, {0, 165, 255}, {255, 0, 255}, {0, 255, 255}, {255, 128, 0}, {128, 128, 255}};
  for (std::size_t i = 0; i < helicopters.size(); ++i) draw(helicopters[i], palette[i % 6], 3 + s);
  draw(raft, cv::Scalar(255, 255, 255), 2 + s);
  if (std::filesystem::is_symlink(path) || (std::filesystem::exists(path) && !std::filesystem::is_regular_file(path)))
    throw InputError(fmt::format("snapshot '{}' is not a regular file; give a new name", path));
  if (!cv::imwrite(path, colour)) throw InputError(fmt::format("could not write the snapshot '{}'; check the folder", path));
#endif
}

}  // namespace dtflop::sar
