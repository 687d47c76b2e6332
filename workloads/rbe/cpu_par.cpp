// cpu-par: float32 on every CPU thread (OpenMP), vectorized (AVX2/FMA where the CPU has it,
// chosen at run time). Zero-padded buffers so that every output takes every tap with no
// branch: the x-pass reads a padded copy of each row, the y-pass reads a u buffer with
// I_y - 1 zero rows around the grid. The previous step's normalization 1 / (A_c S) is folded
// into this step's multiply by the likelihood, so the belief is kept unnormalized (q) with its
// scale. Its counts: cpu_par_counts() (backend_counts.cpp).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include <fmt/format.h>

#include "kernels/vector_loops.hpp"
#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/detail.hpp"

namespace dtflop::rbe::detail {
namespace {

#if defined(__x86_64__) && defined(__GNUC__)
#define DTFLOP_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define DTFLOP_VECTOR_CLONES
#endif

// Outputs per block of the x-pass and columns per strip of the y-pass (backend_counts.hpp:
// whole blocks are computed, and counted).
constexpr int kXBlock = kCpuParXBlock;
constexpr int kYStrip = kCpuParYStrip;
static_assert(kXBlock == kernels::kWideBlock && kYStrip == kernels::kWideStrip, "the blocks are kernels/'s");
using kernels::combine_block;
using kernels::correlate_block;

// Row r of u, u[x] = sum_a k[a] in[x + a] for every column x of the strips: `in` holds the
// zero-padded input row and kXBlock - 1 readable values after it; u is stored strip by strip
// (strip s holds columns [32 s, 32 s + 32) of every row, rows 32 floats apart, strips `strip`
// floats apart), so each y-pass strip reads one contiguous block. Every block of kXBlock outputs
// is computed whole, so each output costs the same whatever n is (cpu_par_counts() counts the
// FLOPs of whole blocks); a last block that covers one strip only writes its second half to
// `spill`.
DTFLOP_VECTOR_CLONES
void correlate_row(const float* __restrict in, const float* __restrict k, std::int64_t I, float* __restrict u,
                   std::int64_t strip, std::int64_t strips, float* __restrict spill) {
  for (std::int64_t s = 0; s < strips; s += 2) {
    float* hi = s + 1 < strips ? u + (s + 1) * strip : spill;
    correlate_block(in + s * kYStrip, k, I, u + s * strip, hi);
  }
}

// The y-pass for one strip of u (`in`: its rows, kYStrip floats each, output row y reading rows
// y .. y + I - 1) and output rows [y0, y1) of `out` (`pitch` floats a row), columns [x, x + w),
// two rows at a time. The strip's rows are contiguous, so the I rows a pair of outputs reads
// (I x 128 bytes, 25 KiB at I = 200) spread evenly over the L1 cache's sets and stay there from
// one pair to the next: u is read from memory once per strip, whatever the kernel height and
// whatever the grid's width (a row-major u put rows a multiple of 4 KiB apart into the same
// few sets: a 1024-wide grid ran its y-pass at half speed). The last strip of a row is computed
// whole into scratch rows and its first w columns copied out.
DTFLOP_VECTOR_CLONES
void combine_piece(const float* __restrict in, const float* __restrict k, std::int64_t I, float* __restrict out,
                   std::int64_t pitch, std::int64_t y0, std::int64_t y1, std::int64_t x, std::int64_t w) {
  float part0[kYStrip], part1[kYStrip];
  const bool whole = w == kYStrip;
  std::int64_t y = y0;
  for (; y + 2 <= y1; y += 2) {
    float* o0 = out + y * pitch + x;
    float* o1 = o0 + pitch;
    combine_block(in + y * kYStrip, k, I, whole ? o0 : part0, whole ? o1 : part1);
    if (!whole) {
      std::copy_n(part0, w, o0);
      std::copy_n(part1, w, o1);
    }
  }
  if (y < y1) {
    float* o0 = out + y * pitch + x;
    combine_block(in + y * kYStrip, k, I, whole ? o0 : part0, nullptr);
    if (!whole) std::copy_n(part0, w, o0);
  }
}

// How the y-pass is cut into pieces that the threads take one at a time (dynamic schedule): a
// piece is one strip of columns over a band of rows. Whole-height strips when there are enough
// of them to balance the threads (each strip then reads its rows of u once); narrow grids cut
// their strips into bands, each band re-reading the I - 1 rows above its first output row.
struct YPieces {
  std::int64_t strips = 1, bands = 1;
  std::int64_t count() const { return strips * bands; }
};
YPieces y_pieces(std::int64_t nx, std::int64_t ny, int threads) {
  YPieces p;
  p.strips = (nx + kYStrip - 1) / kYStrip;  // as cpu_par_counts() counts them
  const std::int64_t wanted = 8 * std::int64_t{threads};  // pieces enough to even out the threads
  if (threads > 1 && p.strips < wanted) p.bands = std::min(ny, (wanted + p.strips - 1) / p.strips);
  return p;
}

// out[x] = sum_b sum_a k[b Ix + a] in[b pitch + x + a], x in [0, n): the full 2D prediction.
DTFLOP_VECTOR_CLONES
void correlate_2d(const float* __restrict in, std::int64_t pitch, const float* __restrict k, std::int64_t Ix,
                  std::int64_t Iy, float* __restrict out, std::int64_t n) {
  constexpr int B = 32;
  std::int64_t x = 0;
  for (; x + B <= n; x += B) {
    float acc[B] = {};
    for (std::int64_t b = 0; b < Iy; ++b)
      for (std::int64_t a = 0; a < Ix; ++a) {
        const float c = k[b * Ix + a];
        const float* s = in + b * pitch + x + a;
        for (int j = 0; j < B; ++j) acc[j] += c * s[j];
      }
    for (int j = 0; j < B; ++j) out[x + j] = acc[j];
  }
  for (; x < n; ++x) {
    float acc = 0;
    for (std::int64_t b = 0; b < Iy; ++b)
      for (std::int64_t a = 0; a < Ix; ++a) acc += k[b * Ix + a] * in[b * pitch + x + a];
    out[x] = acc;
  }
}

// q = (l s) pred, returns the sum of q (accumulated in float64 per thread).
DTFLOP_VECTOR_CLONES
double correct_range(const float* __restrict l, const float* __restrict pred, float s, float* __restrict q,
                     std::int64_t n) {
  double total = 0;
  constexpr std::int64_t B = 256;
  for (std::int64_t i0 = 0; i0 < n; i0 += B) {
    const std::int64_t i1 = std::min(n, i0 + B);
    float part = 0;
    for (std::int64_t i = i0; i < i1; ++i) {
      const float v = (l[i] * s) * pred[i];
      q[i] = v;
      part += v;
    }
    total += part;
  }
  return total;
}

// Belief fusion over cells [0, n) of one thread's range, in blocks that stay in the L1 cache.
// The m beliefs in order: `beliefs[j]` for j != position, the own q x s (its wire values) at
// `position`; out = b_0 x b_1 x ... (product) or exp(w (log b_0 + log b_1 + ...)) (log-linear; log
// 0 = -inf and exp(-inf) = 0, so a zero stays zero at the same cost). Returns the sum of out, one
// addition per value (in 16 lanes that the compiler vectorizes).
constexpr std::int64_t kFuseBlock = 1024;
constexpr int kFuseLanes = 16;

DTFLOP_INLINE double lane_sum(const float* __restrict v, std::int64_t n) {
  float acc[kFuseLanes] = {};
  std::int64_t i = 0;
  for (; i + kFuseLanes <= n; i += kFuseLanes)
    for (int j = 0; j < kFuseLanes; ++j) acc[j] += v[i + j];
  for (; i < n; ++i) acc[0] += v[i];
  double s = 0;
  for (float a : acc) s += a;
  return s;
}

DTFLOP_VECTOR_CLONES
double fuse_range(FusionRule rule, const float* __restrict q, float s, const float* const* beliefs, std::size_t m,
                  std::size_t position, std::int64_t offset, float w, float* __restrict out, float* __restrict own,
                  std::int64_t n) {
  double total = 0;
  for (std::int64_t b = 0; b < n; b += kFuseBlock) {
    const std::int64_t len = std::min(kFuseBlock, n - b);
    float* __restrict o = out + b;
    for (std::int64_t i = 0; i < len; ++i) own[i] = q[b + i] * s;  // the wire's values
    for (std::size_t j = 0; j < m; ++j) {
      const float* __restrict x = j == position ? own : beliefs[j] + offset + b;
      if (rule == FusionRule::product) {
        if (j == 0) for (std::int64_t i = 0; i < len; ++i) o[i] = x[i];
        else for (std::int64_t i = 0; i < len; ++i) o[i] *= x[i];
      } else {
        if (j == 0) for (std::int64_t i = 0; i < len; ++i) o[i] = std::log(x[i]);
        else for (std::int64_t i = 0; i < len; ++i) o[i] += std::log(x[i]);
      }
    }
    if (rule == FusionRule::loglinear)
      for (std::int64_t i = 0; i < len; ++i) o[i] = std::exp(w * o[i]);
    total += lane_sum(o, len);
  }
  return total;
}

class CpuPar final : public Backend {
 public:
  explicit CpuPar(const BackendOptions& o) : options_(o) {
    if (o.threads < 0) throw InputError(fmt::format("cpu-par: --threads {} must be >= 0 (0 = all)", o.threads));
    threads_ = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }

  std::string_view name() const override { return "cpu-par"; }
  std::string_view description() const override {
    return "float32 on every CPU thread, vectorized two-pass separable prediction";
  }
  bool needs_gpu() const override { return false; }
  const BackendOptions& options() const override { return options_; }
  int threads() const { return threads_; }

  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cpu_par_counts(s, o.prediction.value_or(Convolution::separable), threads_);
  }

  void init(const Problem& problem) override {
    ready_ = false;
    const auto prior = normalized_prior(problem);
    prediction_ = resolve_prediction(options_, problem.kernel, true, name());
    grid_ = problem.grid;
    mask_ = problem.mask;
    nx_ = grid_.nx();
    ny_ = grid_.ny();
    Ix_ = problem.kernel.Ix();
    Iy_ = problem.kernel.Iy();
    hx_ = Ix_ - 1 - kernel_centre(Ix_);
    hy_ = Iy_ - 1 - kernel_centre(Iy_);
    const auto n = static_cast<std::size_t>(grid_.cells());
    q_.assign(prior.begin(), prior.end());
    scale_ = 1;
    set_likelihood(masked_likelihood(problem.likelihood, mask_, grid_.cells()));
    const float fill = options_.poison ? std::numeric_limits<float>::quiet_NaN() : 0.0f;
    pred_.assign(n, fill);
    // Flipped kernels: out[x] = sum_a kf[a] in[x + a] over the zero-padded input.
    if (prediction_ == Convolution::separable) {
      kx_.resize(static_cast<std::size_t>(Ix_));
      ky_.resize(static_cast<std::size_t>(Iy_));
      for (std::int64_t a = 0; a < Ix_; ++a) kx_[std::size_t(a)] = float(problem.kernel.kx()[std::size_t(Ix_ - 1 - a)]);
      for (std::int64_t b = 0; b < Iy_; ++b) ky_[std::size_t(b)] = float(problem.kernel.ky()[std::size_t(Iy_ - 1 - b)]);
      // u strip by strip, each strip with I_y - 1 zero rows around the n_y the x-pass writes.
      pieces_ = y_pieces(nx_, ny_, threads_);
      upad_.assign(static_cast<std::size_t>(pieces_.strips * strip_floats()), 0.0f);
      for (std::int64_t st = 0; st < pieces_.strips; ++st)
        std::fill_n(upad_.begin() + st * strip_floats() + hy_ * kYStrip, ny_ * kYStrip, fill);
      rows_.assign(static_cast<std::size_t>(threads_ * row_pitch()), 0.0f);
      spill_.assign(static_cast<std::size_t>(threads_ * kYStrip), 0.0f);
    } else {
      kfull_.resize(static_cast<std::size_t>(Ix_ * Iy_));
      for (std::int64_t b = 0; b < Iy_; ++b)
        for (std::int64_t a = 0; a < Ix_; ++a)
          kfull_[std::size_t(b * Ix_ + a)] = float(problem.kernel.at(Ix_ - 1 - a, Iy_ - 1 - b));
      ppad_.assign(static_cast<std::size_t>((ny_ + Iy_ - 1) * (nx_ + Ix_ - 1)), 0.0f);
    }
    steps_ = 0;
    failed_ = false;
    ready_ = true;
  }

  RunResult run(std::int64_t steps) override {
    return run_step_by_step(steps, grid_.cell_area(), [this](double& sum) { return advance(sum); });
  }

  StepTimes step(std::span<const double> likelihood) override {
    set_likelihood(masked_likelihood(likelihood, mask_, grid_.cells()));
    double sum = 0;
    return advance(sum);
  }
  StepTimes step(const WindowedLikelihood& likelihood) override { return step(expand(likelihood, grid_)); }
  // init() again from the belief (float32 x the pending scale, as float64) with the new kernel.
  void set_kernel(const MotionKernel& kernel) override {
    Problem p;
    p.grid = grid_;
    p.kernel = kernel;
    p.prior = belief();
    p.likelihood.assign(l_.begin(), l_.end());
    init(p);  // the mask is already in the prior and the likelihood
  }

  std::vector<double> belief() override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    std::vector<double> p(q_.size());
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = double(q_[i]) * scale_;
    return p;
  }

  // Belief fusion on every thread, float32; the normalization is folded into the next step like a
  // step's. Counts: cpu_par_fusion_counts(), cpu_par_wire_counts().
  CostCounts fusion_counts(const Shape& s, FusionRule rule, std::int64_t platforms,
                           const BackendOptions&) const override {
    return cpu_par_fusion_counts(s.cells(), rule, platforms, threads_);
  }
  CostCounts wire_counts(const Shape& s, const BackendOptions&) const override {
    return cpu_par_wire_counts(s.cells(), threads_);
  }

  // The summary on the host from belief() (the float32 values x the pending scale, as float64).
  // Counts: host_summary_counts(float32_scaled).
  Summary summarize(const Footprint& f, std::span<const Point> at) override {
    check_footprint(f, at);
    const std::vector<double> b = belief();
    return host_summary(grid_, b, f, at);
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions&) const override {
    return host_summary_counts(g, f, at, BeliefCopy::float32_scaled);
  }

  std::vector<float> wire_belief() override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    const std::int64_t n = grid_.cells();
    std::vector<float> w(static_cast<std::size_t>(n));
    const float s = static_cast<float>(scale_);
    const float* q = q_.data();
    float* out = w.data();
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t i = 0; i < n; ++i) out[i] = q[i] * s;
    return w;
  }

  void fuse(FusionRule rule, std::span<const std::span<const float>> others, std::size_t position) override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    const std::int64_t n = grid_.cells();
    check_others(others, position, n, name());
    Range range("rbe/fuse");
    const std::size_t m = others.size() + 1;
    std::vector<const float*> ptrs(m, nullptr);
    for (std::size_t j = 0; j < m; ++j)
      if (j != position) ptrs[j] = others[j < position ? j : j - 1].data();
    const float w = 1.0f / static_cast<float>(m);
    const float s = static_cast<float>(scale_);
    // The fused grid goes to pred_ (the next prediction overwrites it whole), so a fusion that
    // fails leaves q_ as it was; each thread scales a block of the own belief into own_.
    own_.resize(static_cast<std::size_t>(threads_ * kFuseBlock));
    double total = 0;
#pragma omp parallel num_threads(threads_) reduction(+ : total)
    {
      const int id = omp_get_thread_num(), nt = omp_get_num_threads();
      const std::int64_t i0 = n * id / nt, i1 = n * (id + 1) / nt;
      total += fuse_range(rule, q_.data() + i0, s, ptrs.data(), m, position, i0, w, pred_.data() + i0,
                          own_.data() + id * kFuseBlock, i1 - i0);
    }
    check_fusion_sum(total, m, rule, name());
    std::swap(q_, pred_);
    scale_ = 1.0 / (grid_.cell_area() * total);  // folded into the next step's correction
  }

  // The prediction alone, on the current belief (for the benchmark against cv::sepFilter2D).
  void predict_only() { predict(); }
  const std::vector<float>& prediction() const { return pred_; }

 private:
  std::int64_t row_pitch() const { return nx_ + Ix_ - 1 + kXBlock; }
  // Floats of one strip of u: kYStrip columns of n_y + I_y - 1 rows.
  std::int64_t strip_floats() const { return (ny_ + Iy_ - 1) * kYStrip; }

  void set_likelihood(const std::vector<double>& l) { l_.assign(l.begin(), l.end()); }

  void predict() {
    const std::int64_t nx = nx_, ny = ny_;
    if (prediction_ == Convolution::separable) {
      // Both loops hand out their work a piece at a time (dynamic schedule), so a thread whose
      // core runs slower for a while (another tenant on a shared host, an interrupt) takes
      // fewer pieces instead of holding up the region's end. Every output is computed the same
      // way in any schedule: the result and the counts do not depend on it.
#pragma omp parallel num_threads(threads_)
      {
        const int id = omp_get_thread_num();
        float* row = rows_.data() + id * row_pitch();  // zeros outside [hx, hx + nx)
        float* spill = spill_.data() + id * kYStrip;
        const std::int64_t sf = strip_floats();
#pragma omp for schedule(dynamic, 4)
        for (std::int64_t y = 0; y < ny; ++y) {
          std::copy_n(q_.data() + y * nx, nx, row + hx_);
          correlate_row(row, kx_.data(), Ix_, upad_.data() + (y + hy_) * kYStrip, sf, pieces_.strips, spill);
        }
        // (the implicit barrier of the loop above: every row of u is written; the loop below
        // ends with no barrier of its own, the region's end is the join)
#pragma omp for schedule(dynamic, 1) nowait
        for (std::int64_t i = 0; i < pieces_.count(); ++i) {
          const std::int64_t strip = i / pieces_.bands, band = i % pieces_.bands;
          const std::int64_t x = strip * kYStrip;
          combine_piece(upad_.data() + strip * sf, ky_.data(), Iy_, pred_.data(), nx, ny * band / pieces_.bands,
                        ny * (band + 1) / pieces_.bands, x, std::min<std::int64_t>(kYStrip, nx - x));
        }
      }
    } else {
      const std::int64_t pw = nx + Ix_ - 1;
#pragma omp parallel num_threads(threads_)
      {
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ny; ++y) std::copy_n(q_.data() + y * nx, nx, ppad_.data() + (y + hy_) * pw + hx_);
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ny; ++y)
          correlate_2d(ppad_.data() + y * pw, pw, kfull_.data(), Ix_, Iy_, pred_.data() + y * nx, nx);
      }
    }
  }

  StepTimes advance(double& sum) {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    StepTimes t;
    const double t0 = seconds_now();
    {
      Range r("rbe/predict");
      predict();
    }
    const double t1 = seconds_now();
    sum = 0;
    {
      Range r("rbe/correct");
      const float s = static_cast<float>(scale_);
      const std::int64_t n = grid_.cells();
      const int T = threads_;
      double total = 0;
#pragma omp parallel num_threads(T) reduction(+ : total)
      {
        const int id = omp_get_thread_num(), nt = omp_get_num_threads();
        const std::int64_t i0 = n * id / nt, i1 = n * (id + 1) / nt;
        total += correct_range(l_.data() + i0, pred_.data() + i0, s, q_.data() + i0, i1 - i0);
      }
      sum = total;
    }
    const double t2 = seconds_now();
    if (!(sum > 0 && std::isfinite(sum))) failed_ = true;
    check_sum(sum, steps_, name());
    scale_ = 1.0 / (grid_.cell_area() * sum);  // folded into the next step's correction
    const double t3 = seconds_now();
    ++steps_;
    t.part(StepPart::predict) = t1 - t0;
    t.part(StepPart::correct) = t2 - t1;
    t.part(StepPart::normalize) = t3 - t2;
    t.total = t3 - t0;
    return t;
  }

  BackendOptions options_;
  int threads_ = 1;
  Grid grid_;
  std::vector<std::uint8_t> mask_;
  Convolution prediction_ = Convolution::separable;
  std::int64_t nx_ = 0, ny_ = 0, Ix_ = 0, Iy_ = 0, hx_ = 0, hy_ = 0;
  std::vector<float> q_, l_, pred_, kx_, ky_, kfull_, upad_, rows_, spill_, ppad_;
  std::vector<float> own_;  // fusion: each thread's block of the own belief as the wire carries it
  YPieces pieces_;  // the y-pass's strips of u and the pieces the threads take
  double scale_ = 1;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_par(const BackendOptions& options) { return std::make_unique<CpuPar>(options); }

}  // namespace dtflop::rbe::detail
