// cuda-seed: the dissertation's GPU pipeline (seed 5.3.1), kept to reproduce its finding that
// transfers dominate. Every step: the belief, the column and row kernels and the likelihood go
// to the device; the column pass, then the row pass with the multiply by the likelihood, give
// q; q comes back and the CPU sums it; A_c x sum goes to the device; a kernel divides; the
// belief comes back. Host buffers are pageable or pinned (BackendOptions::host_memory).
// Counts: cuda_seed_counts() = eqs. 5.10-5.16 (+1 CPU multiplication by A_c).
#include <cuda_runtime.h>

#include <cmath>
#include <optional>

#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/cuda_fusion.hpp"
#include "workloads/rbe/cuda_memory.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/detail.hpp"

namespace dtflop::rbe::detail {
namespace {

// u = p (x) column kernel (5.3), every tap taken (zero outside the grid): 2 I_x FLOPs a cell.
__global__ void rbe_seed_column(const float* __restrict__ p, const float* __restrict__ kx, int Ix, int cx, int nx,
                                int ny, float* __restrict__ u) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= nx || y >= ny) return;
  const float* row = p + std::size_t(y) * std::size_t(nx);
  float acc = 0.f;
  for (int a = 0; a < Ix; ++a) {
    const int j = x - (a - cx);
    acc = fmaf(kx[a], (j >= 0 && j < nx) ? row[j] : 0.f, acc);
  }
  u[std::size_t(y) * std::size_t(nx) + x] = acc;
}

// q = l x (u (x) row kernel) (5.4, 5.7): 2 I_y + 1 FLOPs a cell.
__global__ void rbe_seed_row_multiply(const float* __restrict__ u, const float* __restrict__ ky, int Iy, int cy,
                                      const float* __restrict__ l, int nx, int ny, float* __restrict__ q) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= nx || y >= ny) return;
  float acc = 0.f;
  for (int b = 0; b < Iy; ++b) {
    const int j = y - (b - cy);
    acc = fmaf(ky[b], (j >= 0 && j < ny) ? u[std::size_t(j) * std::size_t(nx) + x] : 0.f, acc);
  }
  const std::size_t i = std::size_t(y) * std::size_t(nx) + x;
  q[i] = l[i] * acc;
}

// p = q / (A_c sum) (5.6): 1 FLOP a cell.
__global__ void rbe_seed_divide(const float* __restrict__ q, const float* __restrict__ z, std::int64_t n,
                                float* __restrict__ p) {
  const std::int64_t i = std::int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) p[i] = q[i] / *z;
}

class CudaSeed final : public Backend {
 public:
  explicit CudaSeed(const BackendOptions& o) : options_(o) {}

  std::string_view name() const override { return "cuda-seed"; }
  std::string_view description() const override {
    return "the seed's GPU pipeline: belief to the device and back every step, sum on the CPU";
  }
  bool needs_gpu() const override { return true; }
  const BackendOptions& options() const override { return options_; }
  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cuda_seed_counts(s, o.host_memory);
  }
  std::vector<std::string_view> kernel_names() const override {
    return {"rbe_seed_column", "rbe_seed_row_multiply", "rbe_seed_divide"};
  }

  void init(const Problem& problem) override {
    ready_ = false;
    if (const auto why = cuda_unavailable_reason(); !why.empty()) throw DeviceUnavailable("cuda-seed: " + why);
    const auto prior = normalized_prior(problem);
    resolve_prediction(options_, problem.kernel, false, name());
    shape_ = problem.shape();
    grid_ = problem.grid;
    mask_ = problem.mask;
    const auto n = static_cast<std::size_t>(shape_.cells());
    const bool pinned = options_.host_memory == HostMemory::pinned;
    h_p_ = HostArray<float>(n, pinned);
    h_q_ = HostArray<float>(n, pinned);
    h_l_ = HostArray<float>(n, pinned);
    h_kx_ = HostArray<float>(std::size_t(shape_.Ix), pinned);
    h_ky_ = HostArray<float>(std::size_t(shape_.Iy), pinned);
    h_z_ = HostArray<float>(1, pinned);
    d_p_ = DeviceArray<float>(n);
    d_u_ = DeviceArray<float>(n);
    d_q_ = DeviceArray<float>(n);
    d_l_ = DeviceArray<float>(n);
    d_kx_ = DeviceArray<float>(std::size_t(shape_.Ix));
    d_ky_ = DeviceArray<float>(std::size_t(shape_.Iy));
    d_z_ = DeviceArray<float>(1);
    for (std::size_t i = 0; i < n; ++i) h_p_[i] = float(prior[i]);
    for (std::int64_t a = 0; a < shape_.Ix; ++a) h_kx_[std::size_t(a)] = float(problem.kernel.kx()[std::size_t(a)]);
    for (std::int64_t b = 0; b < shape_.Iy; ++b) h_ky_[std::size_t(b)] = float(problem.kernel.ky()[std::size_t(b)]);
    set_likelihood(masked_likelihood(problem.likelihood, mask_, shape_.cells()));
    if (options_.poison) {  // all bits set: a NaN in every float the steps must overwrite
      DTFLOP_CUDA(cudaMemset(d_u_.get(), 0xff, n * sizeof(float)));
      DTFLOP_CUDA(cudaMemset(d_q_.get(), 0xff, n * sizeof(float)));
      DTFLOP_CUDA(cudaMemset(d_p_.get(), 0xff, n * sizeof(float)));
      for (std::size_t i = 0; i < n; ++i) h_q_[i] = std::nanf("");
    }
    if (!stream_) stream_.emplace();
    steps_ = 0;
    failed_ = false;
    ready_ = true;
  }

  RunResult run(std::int64_t steps) override {
    if (steps >= 1) check_ready();
    return run_step_by_step(steps, grid_.cell_area(), [this](double& sum) { return advance(sum); });
  }

  StepTimes step(std::span<const double> likelihood) override {
    check_ready();
    set_likelihood(masked_likelihood(likelihood, mask_, shape_.cells()));
    double sum = 0;
    return advance(sum);
  }

  StepTimes step(const WindowedLikelihood& likelihood) override { return step(expand(likelihood, grid_)); }
  // init() again from the host belief with the new kernel.
  void set_kernel(const MotionKernel& kernel) override {
    Problem p;
    p.grid = grid_;
    p.kernel = kernel;
    p.prior = belief();
    p.likelihood.assign(h_l_.get(), h_l_.get() + h_l_.size());
    init(p);  // the mask is already in the prior and the likelihood
  }

  std::vector<double> belief() override {
    check_ready();
    std::vector<double> p(h_p_.size());
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = h_p_[i];
    return p;
  }

  // Belief fusion in the seed's manner: the belief lives on the host, so it goes to the device
  // with the others, one kernel fuses, the host makes the scale from the sum, a second kernel
  // normalizes and the belief comes back. Counts: cuda_seed_fusion_counts(), cuda_seed_wire_counts().
  CostCounts fusion_counts(const Shape& s, FusionRule rule, std::int64_t platforms,
                           const BackendOptions& o) const override {
    return cuda_seed_fusion_counts(s.cells(), rule, platforms, counted_gpu_sms(o));
  }
  CostCounts wire_counts(const Shape& s, const BackendOptions&) const override { return cuda_seed_wire_counts(s.cells()); }

  // The belief lives on the host: the summary from belief() there. Counts:
  // host_summary_counts(float32).
  Summary summarize(const Footprint& f, std::span<const Point> at) override {
    check_footprint(f, at);
    const std::vector<double> b = belief();
    return host_summary(grid_, b, f, at);
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions&) const override {
    return host_summary_counts(g, f, at, BeliefCopy::float32);
  }

  std::vector<float> wire_belief() override {
    check_ready();
    return std::vector<float>(h_p_.get(), h_p_.get() + h_p_.size());
  }

  void fuse(FusionRule rule, std::span<const std::span<const float>> others, std::size_t position) override {
    check_ready();
    check_others(others, position, shape_.cells(), name());
    const cudaStream_t st = stream_->get();
    to_device(d_p_, h_p_);
    const double S = fusion_.fuse(rule, d_p_.get(), nullptr, 0.0, position, d_q_.get(), shape_.nx, shape_.ny,
                                  shape_.nx, others, st);
    check_fusion_sum(S, others.size() + 1, rule, name());  // h_p_ is untouched
    const float scale = static_cast<float>(1.0 / (grid_.cell_area() * S));
    launch_fusion_scale(d_q_.get(), shape_.nx, shape_.ny, shape_.nx, nullptr, 0.0, scale, d_p_.get(), st);
    to_host(h_p_, d_p_);
    stream_->sync();
  }

 private:
  void check_ready() const {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
  }
  void set_likelihood(const std::vector<double>& l) {
    for (std::size_t i = 0; i < l.size(); ++i) h_l_[i] = float(l[i]);
  }
  template <class T>
  void to_device(const DeviceArray<T>& d, const HostArray<T>& h) {
    DTFLOP_CUDA(cudaMemcpyAsync(d.get(), h.get(), h.size() * sizeof(T), cudaMemcpyHostToDevice, stream_->get()));
  }
  template <class T>
  void to_host(const HostArray<T>& h, const DeviceArray<T>& d) {
    DTFLOP_CUDA(cudaMemcpyAsync(h.get(), d.get(), h.size() * sizeof(T), cudaMemcpyDeviceToHost, stream_->get()));
  }

  StepTimes advance(double& sum) {
    const cudaStream_t s = stream_->get();
    const int nx = int(shape_.nx), ny = int(shape_.ny);
    const std::int64_t n = shape_.cells();
    const dim3 block(32, 8), grid(unsigned((nx + 31) / 32), unsigned((ny + 7) / 8));
    StepTimes t;
    double c0 = seconds_now();
    const double start = c0;
    auto lap = [&](StepPart c) {
      stream_->sync();
      const double c1 = seconds_now();
      t.part(c) += c1 - c0;
      c0 = c1;
    };
    {
      Range r("rbe/to_device");
      to_device(d_p_, h_p_);    // belief            n_g
      to_device(d_kx_, h_kx_);  // column kernel     I_x
      to_device(d_ky_, h_ky_);  // row kernel        I_y
      to_device(d_l_, h_l_);    // likelihood        n_g
      lap(StepPart::to_device);
    }
    {
      Range r("rbe/predict");
      rbe_seed_column<<<grid, block, 0, s>>>(d_p_.get(), d_kx_.get(), int(shape_.Ix), int(kernel_centre(shape_.Ix)),
                                             nx, ny, d_u_.get());
      DTFLOP_CUDA_LAUNCHED();
      rbe_seed_row_multiply<<<grid, block, 0, s>>>(d_u_.get(), d_ky_.get(), int(shape_.Iy),
                                                   int(kernel_centre(shape_.Iy)), d_l_.get(), nx, ny, d_q_.get());
      DTFLOP_CUDA_LAUNCHED();
      lap(StepPart::predict);
    }
    {
      Range r("rbe/to_host");
      to_host(h_q_, d_q_);  // q  n_g
      lap(StepPart::to_host);
    }
    {
      Range r("rbe/host_sum");
      sum = 0;
      for (std::int64_t i = 0; i < n; ++i) sum += h_q_[std::size_t(i)];  // n_g additions on the CPU
      h_z_[0] = float(grid_.cell_area() * sum);
      lap(StepPart::host_sum);
    }
    if (!(sum > 0 && std::isfinite(sum)) || !(h_z_[0] > 0 && std::isfinite(h_z_[0]))) {
      failed_ = true;
      check_sum(std::isfinite(h_z_[0]) ? sum : HUGE_VAL * 0.0, steps_, name());
    }
    {
      Range r("rbe/to_device");
      to_device(d_z_, h_z_);  // A_c x sum  1
      lap(StepPart::to_device);
    }
    {
      Range r("rbe/normalize");
      rbe_seed_divide<<<unsigned((n + 255) / 256), 256, 0, s>>>(d_q_.get(), d_z_.get(), n, d_p_.get());
      DTFLOP_CUDA_LAUNCHED();
      lap(StepPart::normalize);
    }
    {
      Range r("rbe/to_host");
      to_host(h_p_, d_p_);  // belief  n_g
      lap(StepPart::to_host);
    }
    t.total = c0 - start;
    ++steps_;
    return t;
  }

  BackendOptions options_;
  Shape shape_;
  Grid grid_;
  std::vector<std::uint8_t> mask_;
  HostArray<float> h_p_, h_q_, h_l_, h_kx_, h_ky_, h_z_;
  DeviceArray<float> d_p_, d_u_, d_q_, d_l_, d_kx_, d_ky_, d_z_;
  std::optional<Stream> stream_;
  DeviceFusion fusion_;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cuda_seed(const BackendOptions& options) { return std::make_unique<CudaSeed>(options); }

}  // namespace dtflop::rbe::detail
