// cuda-bands: one grid split into G horizontal bands (band_counts.hpp), each on its own GPU (or
// all on one), each stepped by cuda-resident's fused kernel (resident_sweep.hpp). A band's
// buffers hold its own rows with h_b halo rows above and h_a below (zeros at the grid's edges).
// Step k, per band, on three streams:
//
//   message stream  [wait: the band's edge rows of step k - 1]  halo exchange with the
//                   neighbours (record halo[k])  [wait: the band's step k - 1]  all-reduce of
//                   step k - 1's partial sums -> T_{k-1}   scale kernel (record sum_ready[k])
//   edge stream     [wait sum_ready[k - 1], the neighbours' halo[k - 1], the band's step k - 1,
//                   halo[k]]  edge rows (record edges_done)
//   compute stream  [wait sum_ready[k - 1], the neighbours' halo[k - 1]]  inner rows (no halo
//                   needed)  [wait edges_done]  (record ready)
//
// so step k's halos travel while step k - 1's inner rows are computed (the edge rows of a step
// hold every row a band sends), the edge rows' blocks start before the inner rows' (stream
// priority: nothing else orders them), and no step waits for the all-reduce of the step just
// before it. The message and edge streams have the device's
// greatest priority: their blocks start as soon as a multiprocessor has room, not after the
// inner rows' last block (the first build, with normal-priority messages sent after the whole
// step, left 2 bands on 2 H200s at 1.79x one GPU's step).
//
// Lagged normalization. The fused kernel divides step k's output by A_c E_k (resident_sweep.hpp:
// sum_in); cuda-resident takes E_k = T_{k-1}, the total of the step's input, which here would put
// an all-reduce and two cross-device waits between every two steps. cuda-bands takes
//
//   E_1 = T_0 (a segment's first step: the total of its input is known),
//   E_k = T_{k-2} / (A_c E_{k-1}),  k >= 2,
//
// which needs only the all-reduce of step k - 2. With rho_k the evidence of step k (the mass of
// l * (K * p) for the normalized belief p: cuda-resident's A_c T_k), output k's mass is
// A_c T_k = rho_{k-1} rho_k, two steps' evidence instead of one, bounded however long the run
// (float32 keeps its relative precision at any scale). Each step's evidence comes back exactly as
// rho_k = A_c T_k E_k / T_{k-1}, and the belief as q / (A_c T). The scale kernel
// (rbe_bands_scale) computes E and rho on the device from the all-reduced totals. The inner rows
// of step k also wait for the neighbours' receipt of step k - 1's halos (halo[k - 1]): the buffer
// they overwrite is the one those halos were read from. A single band (G = 1) is cuda-resident's
// step: E_k = T_{k-1}, no messages, no scale kernel.
//
// The messages go through a BandTransport (band_transport.hpp): NCCL between GPUs, copies and a
// reduction kernel where the bands share one GPU; the band, halo and overlap code here is the
// same for both. One process and one host thread drive every GPU:
// every call is asynchronous, NCCL's calls of a step go in one group over all communicators
// (ncclCommInitAll), and the host stays ahead of the devices. No CUDA graph: the steps are
// launched one by one (a graph over several devices and NCCL would be a later refinement).
// The run's sums come back per segment of kBandSegment steps. Counts: band_counts.hpp.
// No fmt here: its compile-time format checks do not compile under nvcc in C++20.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>

#include "cuda/device.hpp"
#include "workloads/rbe/band_counts.hpp"
#include "workloads/rbe/band_transport.hpp"
#include "workloads/rbe/cuda_memory.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/detail.hpp"
#include "workloads/rbe/resident_geometry.hpp"
#include "workloads/rbe/resident_sweep.hpp"

namespace dtflop::rbe::detail {
namespace {

constexpr std::int64_t kChunk = 10;  // steps per timing sample

// The lagged normalization's bookkeeping (header), once T_k = total[k] is there: the evidence of
// output k, rho[k] = T_k E_k / T_{k-1} (k >= 1; times A_c on the host), and the scale of output
// k + 2, E_{k+2} = T_k / (A_c E_{k+1}) (k + 2 <= n). Launched for k = 0..n in a segment of n steps
// (for n = 1, k = 0 has nothing to do).
__global__ void rbe_bands_scale(const double* total, double* scale, double* rho, long long k, long long n,
                                double area) {
  if (threadIdx.x != 0 || blockIdx.x != 0) return;
  const bool evidence = k >= 1, ahead = k + 2 <= n;
  if (!evidence && !ahead) return;
  const double t = total[k];  // read once (band_counts.hpp counts each value read and written)
  if (evidence) rho[k] = t * scale[k] / total[k - 1];
  if (ahead) scale[k + 2] = t / (area * scale[k + 1]);
}

void launch_bands_scale(const double* total, double* scale, double* rho, std::int64_t k, std::int64_t n, double area,
                        cudaStream_t on) {
  rbe_bands_scale<<<1, 32, 0, on>>>(total, scale, rho, static_cast<long long>(k), static_cast<long long>(n), area);
  DTFLOP_CUDA_LAUNCHED();
}

// An event only for ordering (no timing).
class SyncEvent {
 public:
  SyncEvent() { DTFLOP_CUDA(cudaEventCreateWithFlags(&e_, cudaEventDisableTiming)); }
  ~SyncEvent() {
    if (e_) cudaEventDestroy(e_);
  }
  SyncEvent(const SyncEvent&) = delete;
  SyncEvent& operator=(const SyncEvent&) = delete;
  cudaEvent_t get() const { return e_; }

 private:
  cudaEvent_t e_ = nullptr;
};

// What one band holds on its device.
struct BandState {
  int device = 0;
  Band band;
  BandLaunches launches;
  DeviceArray<float> q[2], l;
  // partial[k], total[k] = T_k: output k's sums (k = 1..n of a segment; total[0] its input's);
  // scale[k] = E_k, rho[k] = rho_k / A_c (several bands only).
  DeviceArray<double> partial, total, scale, rho, last;
  std::optional<Stream> compute, comm, edge;
  std::optional<SyncEvent> ready, edges_done, sum_ready[2], halo[2];
  std::unique_ptr<FusedSweep> sweep;
};

class CudaBands final : public Backend {
 public:
  explicit CudaBands(const BackendOptions& o) : options_(o) {
    (void)resident_plan({1024, 1024, 1, 1}, o.layout);  // the layout's own rules
    if (o.partitions < 0 || o.partitions > kMaxPartitions || o.gpus < 0 || o.gpus > kMaxPartitions)
      throw InputError("cuda-bands: --partitions " + std::to_string(o.partitions) + " --gpus " +
                       std::to_string(o.gpus) + "; give 0 to " + std::to_string(kMaxPartitions) + " each");
    if (o.gpus > 1 && o.partitions > 0 && o.partitions != o.gpus) (void)band_placement(o.partitions, o.gpus);
  }
  ~CudaBands() override { release(); }

  std::string_view name() const override { return "cuda-bands"; }
  std::string_view description() const override {
    return "the grid in bands over GPUs: cuda-resident's kernel per band, halos and the sum between them";
  }
  bool needs_gpu() const override { return true; }
  const BackendOptions& options() const override { return options_; }
  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cuda_bands_counts(s, o.layout, counted_gpu_sms(o), band_placement(o));
  }
  CostCounts run_counts(const Shape& s, const BackendOptions& o, std::int64_t steps) const override {
    return cuda_bands_run_counts(s, o.layout, counted_gpu_sms(o), band_placement(o), steps, kBandSegment);
  }
  std::vector<std::string_view> kernel_names() const override { return {"rbe_resident_fused", "rbe_bands_reduce", "rbe_bands_scale"}; }

  void init(const Problem& problem) override {
    ready_ = false;
    if (const auto why = cuda_unavailable_reason(); !why.empty()) throw DeviceUnavailable("cuda-bands: " + why);
    const auto prior = normalized_prior(problem);
    resolve_prediction(options_, problem.kernel, false, name());
    const BandPlacement placement = band_placement(options_);
    const int visible = cuda::device_count();
    if (placement.gpus > visible)
      throw DeviceUnavailable("cuda-bands: " + std::to_string(placement.gpus) + " GPUs asked for, this process sees " +
                              std::to_string(visible) + "; give --gpus " + std::to_string(visible) +
                              " or fewer (--gpus 1 runs every partition on one GPU)");
    if (placement.path == PeerPath::link && !nccl_built())
      (void)make_nccl_transport({});  // throws, saying dtflop was built without NCCL
    options_.partitions = placement.partitions;
    options_.gpus = placement.gpus;
    if (options_.gpu_sms <= 0) DTFLOP_CUDA(cudaDeviceGetAttribute(&options_.gpu_sms, cudaDevAttrMultiProcessorCount, 0));
    shape_ = problem.shape();
    grid_ = problem.grid;
    mask_ = problem.mask;
    plan_ = band_plan(shape_, placement.partitions);
    (void)cuda_bands_counts(shape_, options_.layout, options_.gpu_sms, placement);  // refuses the split passes
    release();

    const std::size_t G = plan_.bands.size(), ld = std::size_t(plan_.ld), nx = std::size_t(shape_.nx);
    const std::size_t hb = std::size_t(plan_.halo_before);
    const auto l = masked_likelihood(problem.likelihood, mask_, shape_.cells());
    std::vector<BandState>(G).swap(bands_);  // (streams and events do not move)
    for (std::size_t b = 0; b < G; ++b) {
      BandState& s = bands_[b];
      s.device = placement.path == PeerPath::link ? int(b) : 0;
      s.band = plan_.bands[b];
      s.launches = band_launches(plan_, b);
      DTFLOP_CUDA(cudaSetDevice(s.device));
      const std::size_t rows = std::size_t(plan_.buffer_rows(b)), n = rows * ld;
      for (auto* a : {&s.q[0], &s.q[1], &s.l}) {
        *a = DeviceArray<float>(n);
        DTFLOP_CUDA(cudaMemset(a->get(), 0, n * sizeof(float)));
      }
      const std::size_t first = std::size_t(s.band.first), own = std::size_t(s.band.rows);
      std::vector<float> p(own * nx), lf(own * nx);
      for (std::size_t i = 0; i < own * nx; ++i) {
        p[i] = float(prior[first * nx + i]);
        lf[i] = float(l[first * nx + i]);
      }
      DTFLOP_CUDA(cudaMemcpy2D(s.q[0].get() + hb * ld, ld * sizeof(float), p.data(), nx * sizeof(float),
                               nx * sizeof(float), own, cudaMemcpyHostToDevice));
      DTFLOP_CUDA(cudaMemcpy2D(s.l.get() + hb * ld, ld * sizeof(float), lf.data(), nx * sizeof(float),
                               nx * sizeof(float), own, cudaMemcpyHostToDevice));
      if (options_.poison) {  // NaN in every row a step or an exchange must write (not the grid edges' halos)
        const bool above = b > 0, below = b + 1 < G;
        const std::size_t top = above ? 0 : hb, bottom = rows - (below ? 0 : std::size_t(plan_.halo_after));
        DTFLOP_CUDA(cudaMemset2D(s.q[1].get() + top * ld, ld * sizeof(float), 0xff, nx * sizeof(float), bottom - top));
        if (above) DTFLOP_CUDA(cudaMemset2D(s.q[0].get(), ld * sizeof(float), 0xff, nx * sizeof(float), hb));
        if (below)
          DTFLOP_CUDA(cudaMemset2D(s.q[0].get() + (hb + own) * ld, ld * sizeof(float), 0xff, nx * sizeof(float),
                                   std::size_t(plan_.halo_after)));
      }
      s.partial = DeviceArray<double>(kBandSegment + 1);
      s.total = DeviceArray<double>(kBandSegment + 1);
      if (G > 1) {
        s.scale = DeviceArray<double>(kBandSegment + 1);
        s.rho = DeviceArray<double>(kBandSegment + 1);
      }
      s.last = DeviceArray<double>(1);
      const double last = 1.0 / grid_.cell_area();  // scale 1: the prior is normalized
      s.last.upload(&last, 1);
      s.compute.emplace();
      s.comm.emplace(Stream::Urgent{});  // a message's blocks start as soon as a multiprocessor has room
      s.edge.emplace(Stream::Urgent{});
      s.ready.emplace();
      s.edges_done.emplace();
      for (auto& e : s.sum_ready) e.emplace();
      for (auto& e : s.halo) e.emplace();
      s.sweep = std::make_unique<FusedSweep>(shape_, options_.layout, std::int64_t(rows), s.q[0].get(), s.q[1].get(),
                                             s.l.get(), problem.kernel.kx(), problem.kernel.ky(), grid_.cell_area());
      DTFLOP_CUDA(cudaDeviceSynchronize());
      DTFLOP_CUDA(cudaEventRecord(s.ready->get(), s.compute->get()));
    }
    // The halo messages of a step reading q[p], for p = 0, 1 (band_counts.hpp: halo_sends).
    const std::size_t ha = std::size_t(plan_.halo_after);
    for (int p = 0; p < 2; ++p) {
      messages_[p].clear();
      for (std::size_t b = 0; b < G; ++b) {
        float* own = bands_[b].q[p].get();
        const std::size_t rows = std::size_t(bands_[b].band.rows);
        if (b > 0 && ha > 0)  // up: its first h_a rows become band b-1's lower halo
          messages_[p].push_back({b, b - 1, own + hb * ld,
                                  bands_[b - 1].q[p].get() + (hb + std::size_t(bands_[b - 1].band.rows)) * ld, ha * ld});
        if (b + 1 < G && hb > 0)  // down: its last h_b rows become band b+1's upper halo
          messages_[p].push_back({b, b + 1, own + rows * ld, bands_[b + 1].q[p].get(), hb * ld});
      }
    }
    if (G > 1) {
      std::vector<BandEnds> ends;
      for (auto& s : bands_)
        ends.push_back({s.device, s.comm->get(), s.ready->get(), (s.launches.edges.empty() ? s.ready : s.edges_done)->get()});
      transport_ = placement.path == PeerPath::link ? make_nccl_transport(std::move(ends))
                                                    : make_device_transport(std::move(ends));
    }
    DTFLOP_CUDA(cudaSetDevice(bands_[0].device));
    timing_.emplace(std::size_t(kBandSegment / kChunk + 2));
    host_sums_ = HostArray<double>(kBandSegment, true);
    sync_all();
    cur_ = 0;
    steps_ = 0;
    failed_ = false;
    ready_ = true;
  }

  RunResult run(std::int64_t steps) override {
    if (steps < 1) throw InputError("a run needs at least one step, got " + std::to_string(steps));
    check_ready();
    RunResult r;
    r.steps = steps;
    r.steps_per_sample = kChunk;
    for (std::int64_t done = 0; done < steps;) {
      const std::int64_t n = std::min(kBandSegment, steps - done);
      const double t0 = seconds_now();
      enqueue(n, true);
      sync_all();
      r.wall_seconds += seconds_now() - t0;
      append_segment(
          r, n, kChunk, [&](std::size_t c) { return timing_->seconds(c, c + 1); },
          std::span<const double>(host_sums_.get(), std::size_t(n)), grid_.cell_area(), steps_, name(), failed_);
      cur_ ^= int(n & 1);
      steps_ += n;
      done += n;
    }
    return r;
  }

  StepTimes step(std::span<const double> likelihood) override {
    check_ready();
    const auto l = masked_likelihood(likelihood, mask_, shape_.cells());
    StepTimes t;
    const double t0 = seconds_now();
    upload_likelihood(l);
    const double t1 = seconds_now();
    enqueue(1, false);
    sync_all();
    const double t2 = seconds_now();
    double S = 0;
    DTFLOP_CUDA(cudaSetDevice(bands_[0].device));
    DTFLOP_CUDA(cudaMemcpy(&S, bands_[0].last.get(), sizeof(double), cudaMemcpyDeviceToHost));
    const double t3 = seconds_now();
    t.part(StepPart::to_device) = t1 - t0;
    t.part(StepPart::device_step) = timing_->seconds(0, 1);
    t.part(StepPart::to_host) = t3 - t2;
    t.total = t3 - t0;
    cur_ ^= 1;
    if (!(S > 0 && std::isfinite(S))) {
      failed_ = true;
      check_sum(S, steps_, name());
    }
    ++steps_;
    return t;
  }

  std::vector<double> belief() override {
    check_ready();
    sync_all();
    const std::size_t nx = std::size_t(shape_.nx), ld = std::size_t(plan_.ld), hb = std::size_t(plan_.halo_before);
    std::vector<float> q(std::size_t(shape_.cells()));
    for (auto& s : bands_) {
      DTFLOP_CUDA(cudaSetDevice(s.device));
      DTFLOP_CUDA(cudaMemcpy2D(q.data() + std::size_t(s.band.first) * nx, nx * sizeof(float),
                               s.q[cur_].get() + hb * ld, ld * sizeof(float), nx * sizeof(float),
                               std::size_t(s.band.rows), cudaMemcpyDeviceToHost));
    }
    double last = 0;
    DTFLOP_CUDA(cudaSetDevice(bands_[0].device));
    DTFLOP_CUDA(cudaMemcpy(&last, bands_[0].last.get(), sizeof(double), cudaMemcpyDeviceToHost));
    const double scale = 1.0 / (grid_.cell_area() * last);
    std::vector<double> p(q.size());
    for (std::size_t i = 0; i < q.size(); ++i) p[i] = double(q[i]) * scale;
    return p;
  }

  // Belief fusion is not built for a grid in bands: the belief would have to be gathered first.
  StepTimes step(const WindowedLikelihood& likelihood) override { return step(expand(likelihood, grid_)); }
  void set_kernel(const MotionKernel&) override { no_fusion(); }  // only the SAR team swaps kernels
  // On the host from the bands read back (as cuda-seed's): the team, which needs it every step,
  // runs on cuda-resident.
  Summary summarize(const Footprint& f, std::span<const Point> at) override {
    check_footprint(f, at);
    const std::vector<double> b = belief();
    return host_summary(grid_, b, f, at);
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions&) const override {
    return host_summary_counts(g, f, at, BeliefCopy::float32);
  }
  std::vector<float> wire_belief() override { no_fusion(); }
  void fuse(FusionRule, std::span<const std::span<const float>>, std::size_t) override { no_fusion(); }
  CostCounts fusion_counts(const Shape&, FusionRule, std::int64_t, const BackendOptions&) const override {
    no_fusion();
  }
  CostCounts wire_counts(const Shape&, const BackendOptions&) const override { no_fusion(); }

 private:
  [[noreturn]] static void no_fusion() {
    throw InputError("cuda-bands does not fuse beliefs or swap kernels (its belief lies in bands over several "
                     "GPUs); run the search-and-rescue team and fusion on cuda-resident");
  }
  void check_ready() const {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
  }

  void sync_all() {
    for (auto& s : bands_) {
      DTFLOP_CUDA(cudaSetDevice(s.device));
      s.compute->sync();
      s.comm->sync();
      s.edge->sync();
    }
  }

  // Frees everything once the devices are idle: the transport (NCCL's communicators) first,
  // then each band's resources on its own device.
  void release() {
    for (auto& s : bands_) {
      if (cudaSetDevice(s.device) != cudaSuccess) (void)cudaGetLastError();
      if (s.compute) (void)cudaStreamSynchronize(s.compute->get());
      if (s.comm) (void)cudaStreamSynchronize(s.comm->get());
      if (s.edge) (void)cudaStreamSynchronize(s.edge->get());
    }
    (void)cudaGetLastError();
    transport_.reset();
    for (auto& s : bands_) {
      if (cudaSetDevice(s.device) != cudaSuccess) (void)cudaGetLastError();
      s.sweep.reset();
      s.ready.reset();
      s.edges_done.reset();
      for (auto& e : s.sum_ready) e.reset();
      for (auto& e : s.halo) e.reset();
      s.compute.reset();
      s.comm.reset();
      s.edge.reset();
      s.q[0] = {};
      s.q[1] = {};
      s.l = {};
      s.partial = {};
      s.total = {};
      s.scale = {};
      s.rho = {};
      s.last = {};
    }
    if (!bands_.empty() && cudaSetDevice(bands_[0].device) != cudaSuccess) (void)cudaGetLastError();
    timing_.reset();
    host_sums_ = {};
    bands_.clear();
  }

  void upload_likelihood(const std::vector<double>& l) {
    const std::size_t nx = std::size_t(shape_.nx), ld = std::size_t(plan_.ld), hb = std::size_t(plan_.halo_before);
    for (auto& s : bands_) {
      const std::size_t first = std::size_t(s.band.first), own = std::size_t(s.band.rows);
      std::vector<float> f(l.begin() + std::ptrdiff_t(first * nx), l.begin() + std::ptrdiff_t((first + own) * nx));
      DTFLOP_CUDA(cudaSetDevice(s.device));
      s.compute->sync();
      DTFLOP_CUDA(cudaMemcpy2D(s.l.get() + hb * ld, ld * sizeof(float), f.data(), nx * sizeof(float),
                               nx * sizeof(float), own, cudaMemcpyHostToDevice));
    }
  }

  // n steps from q[cur_]: the partial sums zeroed, the last total carried in, the steps (a timing
  // event on band 0 after every kChunk), the last all-reduce, the total carried out, and
  // (optionally) band 0's n evidences rho_k / A_c to the host (one band: T_k, the same). Several
  // bands: the streams, events and lagged normalization of the header.
  void enqueue(std::int64_t n, bool sums_back) {
    const std::size_t G = bands_.size();
    const bool many = G > 1;
    const std::int64_t hb = plan_.halo_before;
    for (auto& s : bands_) {
      DTFLOP_CUDA(cudaSetDevice(s.device));
      const cudaStream_t c = s.comm->get();
      DTFLOP_CUDA(cudaStreamWaitEvent(c, s.ready->get(), 0));
      double* acc = many ? s.partial.get() : s.total.get();  // what the kernels add to
      DTFLOP_CUDA(cudaMemsetAsync(acc + 1, 0, std::size_t(n) * sizeof(double), c));
      DTFLOP_CUDA(cudaMemcpyAsync(s.total.get(), s.last.get(), sizeof(double), cudaMemcpyDeviceToDevice, c));
      if (many)  // E_1 = T_0
        DTFLOP_CUDA(cudaMemcpyAsync(s.scale.get() + 1, s.last.get(), sizeof(double), cudaMemcpyDeviceToDevice, c));
      DTFLOP_CUDA(cudaEventRecord(s.sum_ready[1]->get(), c));  // what step 0 waits for
    }
    DTFLOP_CUDA(cudaSetDevice(bands_[0].device));
    DTFLOP_CUDA(cudaEventRecord((*timing_)[0], bands_[0].compute->get()));
    std::size_t e = 1;
    std::vector<double*> partial(G), total(G);
    for (std::int64_t k = 0; k < n; ++k) {
      const int prev = cur_ ^ int(k & 1);
      const std::size_t now = std::size_t(k & 1), before = std::size_t((k + 1) & 1);  // events of k, k - 1
      if (many) {
        // The rows a band sends are its edge rows of step k - 1 (band_launches makes the edge
        // launches cover them), so the exchange goes once those are written, while step k - 1's
        // inner rows still run. The neighbours' rows land in halo rows of the same buffer, which
        // the band's edge rows of step k - 2 read: done before its edges of step k - 1 (one stream).
        for (auto& s : bands_) {
          DTFLOP_CUDA(cudaSetDevice(s.device));
          DTFLOP_CUDA(cudaStreamWaitEvent(s.comm->get(), (s.launches.edges.empty() ? s.ready : s.edges_done)->get(), 0));
        }
        transport_->exchange(messages_[prev]);
        for (auto& s : bands_) {
          DTFLOP_CUDA(cudaSetDevice(s.device));
          DTFLOP_CUDA(cudaEventRecord(s.halo[now]->get(), s.comm->get()));
        }
        if (k > 0) all_reduce(k, partial, total);
        scale(k, n);
      }
      auto launch = [&](BandState& s, const RowRange& r, cudaStream_t on) {
        double* out = (many ? s.partial.get() : s.total.get()) + k + 1;
        const double* in = (many ? s.scale.get() + 1 : s.total.get()) + k;
        s.sweep->launch(prev, hb + r.begin, hb + r.end, in, out, on);
      };
      // Before band b writes its buffer of step k - 1: E_{k+1} is there (sum_ready of k - 1), and
      // its neighbours have received step k - 1's halos, which were read from that buffer (with
      // NCCL the band's own sends ordered that already; a same-device copy runs on the receiver's
      // stream).
      auto wait_inputs = [&](std::size_t b, cudaStream_t on) {
        DTFLOP_CUDA(cudaStreamWaitEvent(on, bands_[b].sum_ready[before]->get(), 0));
        if (!many || k == 0) return;
        for (std::size_t a : {b - 1, b + 1})
          if (a < G) DTFLOP_CUDA(cudaStreamWaitEvent(on, bands_[a].halo[before]->get(), 0));
      };
      for (std::size_t b = 0; b < G; ++b) {  // the edge rows, once step k - 1 is done and their halos are in
        BandState& s = bands_[b];
        if (!many || s.launches.edges.empty()) continue;
        DTFLOP_CUDA(cudaSetDevice(s.device));
        const cudaStream_t on = s.edge->get();
        wait_inputs(b, on);
        DTFLOP_CUDA(cudaStreamWaitEvent(on, s.ready->get(), 0));  // step k - 1 read the rows they overwrite
        DTFLOP_CUDA(cudaStreamWaitEvent(on, s.halo[now]->get(), 0));
        for (const RowRange& r : s.launches.edges) launch(s, r, on);
        DTFLOP_CUDA(cudaEventRecord(s.edges_done->get(), on));
      }
      for (std::size_t b = 0; b < G; ++b) {  // the inner rows, while the halos travel
        BandState& s = bands_[b];
        DTFLOP_CUDA(cudaSetDevice(s.device));
        const cudaStream_t on = s.compute->get();
        if (many || k == 0) wait_inputs(b, on);
        for (const RowRange& r : s.launches.inner) launch(s, r, on);
        if (many && !s.launches.edges.empty()) DTFLOP_CUDA(cudaStreamWaitEvent(on, s.edges_done->get(), 0));
        else if (!many)
          for (const RowRange& r : s.launches.edges) launch(s, r, on);
        DTFLOP_CUDA(cudaEventRecord(s.ready->get(), on));
      }
      if ((k + 1) % kChunk == 0 || k + 1 == n) {
        DTFLOP_CUDA(cudaSetDevice(bands_[0].device));
        DTFLOP_CUDA(cudaEventRecord((*timing_)[e++], bands_[0].compute->get()));
      }
    }
    if (many) {
      all_reduce(n, partial, total);
      scale(n, n);
    }
    for (auto& s : bands_) {
      DTFLOP_CUDA(cudaSetDevice(s.device));
      const cudaStream_t c = s.comm->get();
      if (!many) DTFLOP_CUDA(cudaStreamWaitEvent(c, s.ready->get(), 0));
      DTFLOP_CUDA(cudaMemcpyAsync(s.last.get(), s.total.get() + n, sizeof(double), cudaMemcpyDeviceToDevice, c));
    }
    if (sums_back) {
      BandState& s = bands_[0];
      DTFLOP_CUDA(cudaSetDevice(s.device));
      DTFLOP_CUDA(cudaMemcpyAsync(host_sums_.get(), (many ? s.rho.get() : s.total.get()) + 1,
                                  std::size_t(n) * sizeof(double), cudaMemcpyDeviceToHost, s.comm->get()));
    }
  }

  // On every band's message stream, once T_k is there: rho_k (k >= 1) and E_{k+2} (k + 2 <= n).
  void scale(std::int64_t k, std::int64_t n) {
    for (auto& s : bands_) {
      DTFLOP_CUDA(cudaSetDevice(s.device));
      launch_bands_scale(s.total.get(), s.scale.get(), s.rho.get(), k, n, grid_.cell_area(), s.comm->get());
      DTFLOP_CUDA(cudaEventRecord(s.sum_ready[std::size_t(k & 1)]->get(), s.comm->get()));
    }
  }

  // total[k] = the sum of every band's partial[k], on every band's message stream after its step.
  void all_reduce(std::int64_t k, std::vector<double*>& partial, std::vector<double*>& total) {
    for (std::size_t b = 0; b < bands_.size(); ++b) {
      BandState& s = bands_[b];
      DTFLOP_CUDA(cudaSetDevice(s.device));
      DTFLOP_CUDA(cudaStreamWaitEvent(s.comm->get(), s.ready->get(), 0));  // (the last step's: after the loop)
      partial[b] = s.partial.get() + k;
      total[b] = s.total.get() + k;
    }
    transport_->allreduce(partial, total);
  }

  BackendOptions options_;
  Shape shape_;
  Grid grid_;
  std::vector<std::uint8_t> mask_;
  BandPlan plan_;
  std::vector<BandState> bands_;
  std::vector<HaloMessage> messages_[2];
  std::unique_ptr<BandTransport> transport_;
  std::optional<Events> timing_;
  HostArray<double> host_sums_;
  int cur_ = 0;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cuda_bands(const BackendOptions& options) {
  return std::make_unique<CudaBands>(options);
}

}  // namespace dtflop::rbe::detail
