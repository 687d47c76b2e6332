// The CUDA backends in a build without CUDA: listed, with their exact counts, but init()
// throws DeviceUnavailable saying dtflop was built without CUDA.
#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/band_counts.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/detail.hpp"

namespace dtflop::rbe::detail {
namespace {

class CudaUnavailable final : public Backend {
 public:
  CudaUnavailable(const BackendOptions& o, bool resident) : options_(o), resident_(resident) {
    if (resident_) (void)resident_plan({1024, 1024, 1, 1}, o.layout);  // same layout checks as with CUDA
  }
  std::string_view name() const override { return resident_ ? "cuda-resident" : "cuda-seed"; }
  std::string_view description() const override { return "unavailable: dtflop was built without CUDA"; }
  bool needs_gpu() const override { return true; }
  const BackendOptions& options() const override { return options_; }
  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return resident_ ? cuda_resident_counts(s, o.layout, counted_gpu_sms(o)) : cuda_seed_counts(s, o.host_memory);
  }
  CostCounts fusion_counts(const Shape& s, FusionRule rule, std::int64_t platforms,
                           const BackendOptions& o) const override {
    return resident_ ? cuda_resident_fusion_counts(s.cells(), rule, platforms, counted_gpu_sms(o))
                     : cuda_seed_fusion_counts(s.cells(), rule, platforms, counted_gpu_sms(o));
  }
  CostCounts wire_counts(const Shape& s, const BackendOptions& o) const override {
    return resident_ ? cuda_resident_wire_counts(s.cells(), counted_gpu_sms(o)) : cuda_seed_wire_counts(s.cells());
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions& o) const override {
    return resident_ ? cuda_resident_summary_counts(g, f, at, counted_gpu_sms(o))
                     : host_summary_counts(g, f, at, BeliefCopy::float32);
  }
  Summary summarize(const Footprint&, std::span<const Point>) override { fail(); }
  std::vector<float> wire_belief() override { fail(); }
  void fuse(FusionRule, std::span<const std::span<const float>>, std::size_t) override { fail(); }
  void init(const Problem&) override { fail(); }
  RunResult run(std::int64_t) override { fail(); }
  StepTimes step(std::span<const double>) override { fail(); }
  StepTimes step(const WindowedLikelihood&) override { fail(); }
  void set_kernel(const MotionKernel&) override { fail(); }
  std::vector<double> belief() override { fail(); }

 private:
  [[noreturn]] void fail() const {
    throw DeviceUnavailable(std::string(name()) + ": " + cuda_unavailable_reason());
  }
  BackendOptions options_;
  bool resident_;
};

// cuda-bands without CUDA: its counts, and init() says dtflop was built without CUDA.
class CudaBandsUnavailable final : public Backend {
 public:
  explicit CudaBandsUnavailable(const BackendOptions& o) : options_(o) {
    (void)resident_plan({1024, 1024, 1, 1}, o.layout);
    if (o.gpus > 1 && o.partitions > 0) (void)band_placement(o.partitions, o.gpus);
  }
  std::string_view name() const override { return "cuda-bands"; }
  std::string_view description() const override { return "unavailable: dtflop was built without CUDA"; }
  bool needs_gpu() const override { return true; }
  const BackendOptions& options() const override { return options_; }
  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cuda_bands_counts(s, o.layout, counted_gpu_sms(o), band_placement(o));
  }
  CostCounts run_counts(const Shape& s, const BackendOptions& o, std::int64_t steps) const override {
    return cuda_bands_run_counts(s, o.layout, counted_gpu_sms(o), band_placement(o), steps, kBandSegment);
  }
  CostCounts fusion_counts(const Shape&, FusionRule, std::int64_t, const BackendOptions&) const override { fail(); }
  CostCounts wire_counts(const Shape&, const BackendOptions&) const override { fail(); }
  std::vector<float> wire_belief() override { fail(); }
  void fuse(FusionRule, std::span<const std::span<const float>>, std::size_t) override { fail(); }
  void init(const Problem&) override { fail(); }
  RunResult run(std::int64_t) override { fail(); }
  StepTimes step(std::span<const double>) override { fail(); }
  StepTimes step(const WindowedLikelihood&) override { fail(); }
  void set_kernel(const MotionKernel&) override { fail(); }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions&) const override {
    return host_summary_counts(g, f, at, BeliefCopy::float32);
  }
  Summary summarize(const Footprint&, std::span<const Point>) override { fail(); }
  std::vector<double> belief() override { fail(); }

 private:
  [[noreturn]] void fail() const { throw DeviceUnavailable("cuda-bands: " + cuda_unavailable_reason()); }
  BackendOptions options_;
};

}  // namespace

std::unique_ptr<Backend> make_cuda_bands(const BackendOptions& o) { return std::make_unique<CudaBandsUnavailable>(o); }
std::unique_ptr<Backend> make_cuda_seed(const BackendOptions& o) { return std::make_unique<CudaUnavailable>(o, false); }
std::unique_ptr<Backend> make_cuda_resident(const BackendOptions& o) {
  return std::make_unique<CudaUnavailable>(o, true);
}

}  // namespace dtflop::rbe::detail
