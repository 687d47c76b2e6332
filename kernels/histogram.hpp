// The host's 256-bin grey-level histogram (Otsu's threshold): the DCT CPU backends' count, and
// the one the cpu-pixel probe times (L_hist). Header only; the standard library alone.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace dtflop::kernels {

// Four interleaved histograms, added at the end: a background of few grey levels puts equal values
// side by side, and with one histogram each count waits for the store of the one before it. On
// the 2-vCPU VM, rendered 1024x1024 frames: 96% equal neighbours (no sensor noise), one histogram
// 0.96 ns a pixel, four 0.47-0.59; 13.5% (noise 2), 0.56 and 0.35; 7% (noise 4), 0.56 and 0.35-0.37
// (results/portability/dct-pixel-kinds-2026-11-27/histogram-cost.cpp, three runs).
class Histogram256 {
 public:
  // Counts n 8-bit pixels.
  void add(const std::uint8_t* p, std::size_t n) { add_scaled(p, n, 1); }
  // Counts n 16-bit pixels on the 8-bit scale (v / 257).
  void add(const std::uint16_t* p, std::size_t n) { add_scaled(p, n, 257); }
  // The counts of each grey level.
  std::array<std::int64_t, 256> total() const {
    std::array<std::int64_t, 256> out{};
    for (const auto& q : part_)
      for (std::size_t v = 0; v < out.size(); ++v) out[v] += q[v];
    return out;
  }

 private:
  template <class Pix>
  void add_scaled(const Pix* p, std::size_t n, unsigned divisor) {
    std::size_t j = 0;
    for (; j + 4 <= n; j += 4) {
      ++part_[0][p[j] / divisor];
      ++part_[1][p[j + 1] / divisor];
      ++part_[2][p[j + 2] / divisor];
      ++part_[3][p[j + 3] / divisor];
    }
    for (; j < n; ++j) ++part_[0][p[j] / divisor];
  }
  std::array<std::array<std::int64_t, 256>, 4> part_{};
};

// The counts of `rows` rows of `cols` pixels (row r at base + r * stride elements) in `stripes`
// runs of rows, each into its own Histogram256, added at the end: the DCT CPU backends' count on
// several threads, and the cpu-pixel probe's. `parallel_for(n, body)` calls body(s) for every
// stripe s in [0, n), on as many threads as it likes (the callers: OpenCV's parallel_for_).
template <class Pix, class ParallelFor>
std::array<std::int64_t, 256> count_rows(const Pix* base, std::size_t stride, int cols, int rows, int stripes,
                                         ParallelFor&& parallel_for) {
  const int n = stripes < 1 ? 1 : stripes > rows ? (rows < 1 ? 1 : rows) : stripes;
  std::vector<Histogram256> parts(static_cast<std::size_t>(n));
  parallel_for(n, [&](int s) {
    const auto r0 = static_cast<std::int64_t>(rows) * s / n, r1 = static_cast<std::int64_t>(rows) * (s + 1) / n;
    for (std::int64_t r = r0; r < r1; ++r)
      parts[static_cast<std::size_t>(s)].add(base + static_cast<std::size_t>(r) * stride, static_cast<std::size_t>(cols));
  });
  std::array<std::int64_t, 256> out{};
  for (const auto& part : parts) {
    const auto t = part.total();
    for (std::size_t v = 0; v < out.size(); ++v) out[v] += t[v];
  }
  return out;
}

}  // namespace dtflop::kernels
