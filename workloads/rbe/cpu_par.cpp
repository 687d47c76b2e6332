// cpu-par: float32 on every CPU thread (OpenMP), vectorized (AVX2/FMA where the CPU has it,
// chosen at run time). Zero-padded buffers so that every output takes every tap with no
// branch: the x-pass reads a padded copy of each row, the y-pass reads a u buffer with
// I_y - 1 zero rows around the grid. The previous step's normalization 1 / (A_c S) is folded
// into this step's multiply by the likelihood, so the belief is kept unnormalized (q) with its
// scale. Its counts: cpu_par_counts() (backend_counts.cpp).
#include <omp.h>

#include <algorithm>
#include <limits>
#include <thread>

#include <fmt/format.h>

#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/detail.hpp"

namespace dtflop::rbe::detail {
namespace {

#if defined(__x86_64__) && defined(__GNUC__)
#define DTFLOP_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define DTFLOP_VECTOR_CLONES
#endif

// out[x] = sum_a k[a] in[x + a], x in [0, n): `in` holds n + I - 1 values. Blocks of 32
// outputs stay in registers (4 AVX vectors) while the taps stream past.
DTFLOP_VECTOR_CLONES
void correlate_row(const float* __restrict in, const float* __restrict k, std::int64_t I,
                   float* __restrict out, std::int64_t n) {
  constexpr int B = 32;
  std::int64_t x = 0;
  for (; x + B <= n; x += B) {
    float acc[B] = {};
    for (std::int64_t a = 0; a < I; ++a) {
      const float c = k[a];
      const float* s = in + x + a;
      for (int j = 0; j < B; ++j) acc[j] += c * s[j];
    }
    for (int j = 0; j < B; ++j) out[x + j] = acc[j];
  }
  for (; x < n; ++x) {
    float acc = 0;
    for (std::int64_t a = 0; a < I; ++a) acc += k[a] * in[x + a];
    out[x] = acc;
  }
}

// out[x] = sum_b k[b] in[b * pitch + x], x in [0, n): I rows of `in` combined column-wise.
DTFLOP_VECTOR_CLONES
void combine_rows(const float* __restrict in, std::int64_t pitch, const float* __restrict k, std::int64_t I,
                  float* __restrict out, std::int64_t n) {
  constexpr int B = 64;
  std::int64_t x = 0;
  for (; x + B <= n; x += B) {
    float acc[B] = {};
    for (std::int64_t b = 0; b < I; ++b) {
      const float c = k[b];
      const float* s = in + b * pitch + x;
      for (int j = 0; j < B; ++j) acc[j] += c * s[j];
    }
    for (int j = 0; j < B; ++j) out[x + j] = acc[j];
  }
  for (; x < n; ++x) {
    float acc = 0;
    for (std::int64_t b = 0; b < I; ++b) acc += k[b] * in[b * pitch + x];
    out[x] = acc;
  }
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
    return cpu_par_counts(s, o.prediction.value_or(Prediction::separable), threads_);
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
    if (prediction_ == Prediction::separable) {
      kx_.resize(static_cast<std::size_t>(Ix_));
      ky_.resize(static_cast<std::size_t>(Iy_));
      for (std::int64_t a = 0; a < Ix_; ++a) kx_[std::size_t(a)] = float(problem.kernel.kx()[std::size_t(Ix_ - 1 - a)]);
      for (std::int64_t b = 0; b < Iy_; ++b) ky_[std::size_t(b)] = float(problem.kernel.ky()[std::size_t(Iy_ - 1 - b)]);
      upad_.assign(static_cast<std::size_t>((ny_ + Iy_ - 1) * nx_), 0.0f);
      std::fill_n(upad_.begin() + hy_ * nx_, ny_ * nx_, fill);  // the rows the x-pass writes
      rows_.assign(static_cast<std::size_t>(threads_ * row_pitch()), 0.0f);
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

  std::vector<double> belief() override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    std::vector<double> p(q_.size());
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = double(q_[i]) * scale_;
    return p;
  }

  // The prediction alone, on the current belief (for the benchmark against cv::sepFilter2D).
  void predict_only() { predict(); }
  const std::vector<float>& prediction() const { return pred_; }

 private:
  std::int64_t row_pitch() const { return nx_ + Ix_ - 1 + 64; }

  void set_likelihood(const std::vector<double>& l) { l_.assign(l.begin(), l.end()); }

  void predict() {
    const std::int64_t nx = nx_, ny = ny_;
    if (prediction_ == Prediction::separable) {
#pragma omp parallel num_threads(threads_)
      {
        float* row = rows_.data() + omp_get_thread_num() * row_pitch();  // zeros outside [hx, hx + nx)
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ny; ++y) {
          std::copy_n(q_.data() + y * nx, nx, row + hx_);
          correlate_row(row, kx_.data(), Ix_, upad_.data() + (y + hy_) * nx, nx);
        }
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ny; ++y)
          combine_rows(upad_.data() + y * nx, nx, ky_.data(), Iy_, pred_.data() + y * nx, nx);
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
    t.part(Component::predict) = t1 - t0;
    t.part(Component::correct) = t2 - t1;
    t.part(Component::normalize) = t3 - t2;
    t.total = t3 - t0;
    return t;
  }

  BackendOptions options_;
  int threads_ = 1;
  Grid grid_;
  std::vector<std::uint8_t> mask_;
  Prediction prediction_ = Prediction::separable;
  std::int64_t nx_ = 0, ny_ = 0, Ix_ = 0, Iy_ = 0, hx_ = 0, hy_ = 0;
  std::vector<float> q_, l_, pred_, kx_, ky_, kfull_, upad_, rows_, ppad_;
  double scale_ = 1;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_par(const BackendOptions& options) { return std::make_unique<CpuPar>(options); }

}  // namespace dtflop::rbe::detail
