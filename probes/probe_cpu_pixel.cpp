// Host scalar pixel work (L_pixel): the cost of one step of a scalar loop over pixels on one
// thread, the work an image analysis does pixel by pixel and branch by branch (a histogram's
// count, a window pixel classified, a label of its neighbourhood read) that no FLOP rate or
// bandwidth prices. Measured with the two loop shapes the DCT workload counts as pixel_steps
// (docs/model.md 2.6): a 256-bin histogram of an 8-bit frame (one step a pixel), and the
// classification of the windows around labelled discs, where every background window pixel
// reads the labels of its 5 x 5 neighbourhood through a bounds-checked accessor (one step a
// window pixel and one a label read). The time of a repetition over its steps gives L_pixel.
// A floor, as cpu-tree's L_tree is: the workload's labelling does more per pixel, which a fit
// finds (docs/PERFORMANCE.md).
#include <array>
#include <chrono>
#include <cstdint>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

constexpr int kSide = 1024;    // frame side, px: a 1 MP frame, its labels (4 MiB) beyond the L2
constexpr int kDiscs = 400;    // labelled discs
constexpr int kRadius = 8;     // their radius, px
constexpr int kMargin = 2;     // the neighbourhood's half-width: 5 x 5 labels
constexpr int kGrow = kMargin + 2;  // a window is a disc's box grown by the margin and a 2 px ring

struct Frame {
  std::vector<std::uint8_t> image;
  std::vector<std::int32_t> labels;  // 0: background, k: disc k
  std::vector<std::array<int, 2>> centres;
};

// Discs on a jittered grid (they never touch: 48 px apart, 17 px across), a noisy background.
Frame make_frame() {
  Frame f;
  f.image.resize(static_cast<std::size_t>(kSide) * kSide);
  f.labels.assign(f.image.size(), 0);
  std::mt19937_64 rng(20261124);
  std::uniform_int_distribution<int> grey(180, 220), jitter(-6, 6);
  for (auto& v : f.image) v = static_cast<std::uint8_t>(grey(rng));
  const int per_row = 20, pitch = kSide / per_row;
  for (int k = 0; k < kDiscs; ++k) {
    const int cx = (k % per_row) * pitch + pitch / 2 + jitter(rng), cy = (k / per_row) * pitch + pitch / 2 + jitter(rng);
    f.centres.push_back({cx, cy});
    for (int y = cy - kRadius; y <= cy + kRadius; ++y)
      for (int x = cx - kRadius; x <= cx + kRadius; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= kRadius * kRadius) {
          const std::size_t i = static_cast<std::size_t>(y) * kSide + x;
          f.labels[i] = k + 1;
          f.image[i] = 40;
        }
  }
  return f;
}

struct Steps {
  std::int64_t steps = 0;     // pixels visited + labels read
  std::int64_t counted = 0;   // histogram total
  std::int64_t classes[3] = {0, 0, 0};  // own, ring, ignored: must add up to the window pixels
};

// One repetition: the histogram, then every disc's window classified as the workload does.
Steps pass(const Frame& f) {
  Steps s;
  std::array<std::int64_t, 256> hist{};
  for (std::uint8_t v : f.image) ++hist[v];
  for (std::int64_t h : hist) s.counted += h;
  s.steps += static_cast<std::int64_t>(f.image.size());
  auto label = [&](int x, int y) -> int {
    if (x < 0 || y < 0 || x >= kSide || y >= kSide) return -1;
    const int l = f.labels[static_cast<std::size_t>(y) * kSide + x];
    return l == 0 ? -1 : l;
  };
  for (int k = 0; k < kDiscs; ++k) {
    const int id = k + 1, cx = f.centres[k][0], cy = f.centres[k][1];
    for (int y = cy - kRadius - kGrow; y <= cy + kRadius + kGrow; ++y)
      for (int x = cx - kRadius - kGrow; x <= cx + kRadius + kGrow; ++x) {
        ++s.steps;
        const int l = label(x, y);
        if (l == id) {
          ++s.classes[0];
          continue;
        }
        if (l != -1) {
          ++s.classes[2];
          continue;
        }
        bool self = false, other = false;
        for (int dy = -kMargin; dy <= kMargin; ++dy)
          for (int dx = -kMargin; dx <= kMargin; ++dx) {
            const int n = label(x + dx, y + dy);
            self |= n == id;
            other |= n != -1 && n != id;
          }
        s.steps += (2 * kMargin + 1) * (2 * kMargin + 1);
        ++s.classes[other ? 2 : self ? 0 : 1];
      }
  }
  return s;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 31 : o.effort == Effort::quick ? 11 : 3;
  const Frame f = make_frame();
  const std::int64_t window = static_cast<std::int64_t>(kDiscs) * (2 * (kRadius + kGrow) + 1) * (2 * (kRadius + kGrow) + 1);
  std::vector<double> per_step;
  std::int64_t steps = 0;
  for (int k = -1; k < reps; ++k) {  // k = -1: warm-up, untimed
    const auto t0 = std::chrono::steady_clock::now();
    const Steps s = pass(f);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The loops ran: every pixel counted once, every window pixel classified once, some of them
    // as ring (the background plane's pixels).
    if (s.counted != static_cast<std::int64_t>(f.image.size()) ||
        s.classes[0] + s.classes[1] + s.classes[2] != window || s.classes[1] == 0)
      throw ValidationError(fmt::format("the pixel loops counted {} of {} pixels and classified {} of {} window pixels",
                                        s.counted, f.image.size(), s.classes[0] + s.classes[1] + s.classes[2], window));
    steps = s.steps;
    if (k >= 0) per_step.push_back(t / static_cast<double>(s.steps));
  }
  r.measurements.push_back(time_measurement(
      "pixel", "one step of scalar pixel work (one thread)", per_step, Param::L_pixel,
      fmt::format("a 256-bin histogram of a {0}x{0} 8-bit frame and the classification of {1} discs' windows "
                  "(5x5 label scans), {2} steps (docs/model.md 2.6); time / steps, median of {3}",
                  kSide, kDiscs, steps, reps)));
  o.say(fmt::format("  pixel step: {:.2f} ns", r.measurements[0].value * 1e9));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_pixel) {
  registry.add({"cpu-pixel", "host scalar pixel work: one step of a histogram or a window's label scan (one thread)",
                false, 28, dtflop::probes::run});
}
