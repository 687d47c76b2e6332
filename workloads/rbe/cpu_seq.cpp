// cpu-seq: the float64 reference backend, one thread, written for clarity: the separable
// prediction (5.3-5.4) or the conventional 2D convolution (4.10), then the correction in the
// seed's three steps (5.7, sum, 5.6). Its counts: cpu_seq_counts() (backend_counts.cpp).
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/detail.hpp"
#include "workloads/rbe/reference.hpp"

namespace dtflop::rbe::detail {
namespace {

class CpuSeq final : public Backend {
 public:
  explicit CpuSeq(const BackendOptions& o) : options_(o) {}

  std::string_view name() const override { return "cpu-seq"; }
  std::string_view description() const override {
    return "float64 reference on one thread (separable or full 2D prediction)";
  }
  bool needs_gpu() const override { return false; }
  const BackendOptions& options() const override { return options_; }

  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cpu_seq_counts(s, o.prediction.value_or(Convolution::separable));
  }

  void init(const Problem& problem) override {
    ready_ = false;
    p_ = normalized_prior(problem);
    prediction_ = resolve_prediction(options_, problem.kernel, true, name());
    grid_ = problem.grid;
    kernel_ = problem.kernel;
    dense_ = kernel_.dense();
    mask_ = problem.mask;
    l_ = masked_likelihood(problem.likelihood, mask_, grid_.cells());
    const auto n = p_.size();
    const double fill = options_.poison ? std::numeric_limits<double>::quiet_NaN() : 0.0;
    u_.assign(n, fill);
    if (prediction_ == Convolution::separable) work_.assign(2 * n, fill);  // the y-pass's transposes
    else work_.clear();
    pred_.assign(n, fill);
    q_.assign(n, fill);
    steps_ = 0;
    failed_ = false;
    ready_ = true;
  }

  RunResult run(std::int64_t steps) override {
    return run_step_by_step(steps, grid_.cell_area(), [this](double& sum) { return advance(l_, sum); });
  }

  StepTimes step(std::span<const double> likelihood) override {
    const auto l = masked_likelihood(likelihood, mask_, grid_.cells());
    double sum = 0;
    return advance(l, sum);
  }

  StepTimes step(const WindowedLikelihood& likelihood) override { return step(expand(likelihood, grid_)); }

  void set_kernel(const MotionKernel& kernel) override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    Problem p;
    p.grid = grid_;
    p.kernel = kernel;
    p.prior = p_;
    p.likelihood = l_;
    init(p);  // the mask is already in the prior and the likelihood
  }

  std::vector<double> belief() override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    return p_;
  }

  // Belief fusion, float64 on one thread: the conventional sequential fusion the parallel ones
  // are measured against. Counts: cpu_seq_fusion_counts(), cpu_seq_wire_counts().
  CostCounts fusion_counts(const Shape& s, FusionRule rule, std::int64_t platforms,
                           const BackendOptions&) const override {
    return cpu_seq_fusion_counts(s.cells(), rule, platforms);
  }
  CostCounts wire_counts(const Shape& s, const BackendOptions&) const override { return cpu_seq_wire_counts(s.cells()); }

  // The summary from the float64 belief where it is. Counts: host_summary_counts(in_place).
  Summary summarize(const Footprint& f, std::span<const Point> at) override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    return host_summary(grid_, p_, f, at);
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions&) const override {
    return host_summary_counts(g, f, at, BeliefCopy::in_place);
  }

  std::vector<float> wire_belief() override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    return std::vector<float>(p_.begin(), p_.end());
  }

  void fuse(FusionRule rule, std::span<const std::span<const float>> others, std::size_t position) override {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    check_others(others, position, grid_.cells(), name());
    Range range("rbe/fuse");
    const std::size_t n = p_.size(), m = others.size() + 1;
    // Platform j's value of cell i: the own belief as the wire carries it (float32) at `position`.
    auto value = [&](std::size_t j, std::size_t i) {
      return j == position ? double(float(p_[i])) : double(others[j < position ? j : j - 1][i]);
    };
    double sum = 0;
    if (rule == FusionRule::product) {
      for (std::size_t i = 0; i < n; ++i) {
        double v = value(0, i);
        for (std::size_t j = 1; j < m; ++j) v *= value(j, i);
        q_[i] = v;
        sum += v;
      }
    } else {
      const double w = 1.0 / double(m);
      for (std::size_t i = 0; i < n; ++i) {
        double lg = std::log(value(0, i));  // log 0 = -inf, exp(-inf) = 0: a zero stays zero
        for (std::size_t j = 1; j < m; ++j) lg += std::log(value(j, i));
        const double v = std::exp(w * lg);
        q_[i] = v;
        sum += v;
      }
    }
    check_fusion_sum(sum, m, rule, name());
    const double z = sum * grid_.cell_area();
    for (std::size_t i = 0; i < n; ++i) p_[i] = q_[i] / z;
  }

 private:
  StepTimes advance(const std::vector<double>& l, double& sum) {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
    const std::int64_t nx = grid_.nx(), ny = grid_.ny(), n = grid_.cells();
    StepTimes t;
    const double t0 = seconds_now();
    {
      Range range("rbe/predict");
      if (prediction_ == Convolution::separable) {
        reference::pass_x(nx, ny, kernel_.kx().data(), kernel_.Ix(), p_.data(), u_.data());
        reference::pass_y(nx, ny, kernel_.ky().data(), kernel_.Iy(), u_.data(), pred_.data(), work_.data());
      } else {
        reference::convolve_full(nx, ny, dense_.data(), kernel_.Ix(), kernel_.Iy(), p_.data(), pred_.data());
      }
    }
    const double t1 = seconds_now();
    {
      Range range("rbe/correct");
      reference::multiply(n, l.data(), pred_.data(), q_.data());
      sum = reference::sum(n, q_.data());
    }
    const double t2 = seconds_now();
    if (!(sum > 0 && std::isfinite(sum))) failed_ = true;
    check_sum(sum, steps_, name());
    {
      Range range("rbe/normalize");
      reference::normalize(n, q_.data(), grid_.cell_area(), sum, p_.data());
    }
    const double t3 = seconds_now();
    ++steps_;
    t.part(StepPart::predict) = t1 - t0;
    t.part(StepPart::correct) = t2 - t1;
    t.part(StepPart::normalize) = t3 - t2;
    t.total = t3 - t0;
    return t;
  }

  BackendOptions options_;
  Grid grid_;
  MotionKernel kernel_;
  std::vector<double> dense_;
  Convolution prediction_ = Convolution::separable;
  std::vector<std::uint8_t> mask_;
  std::vector<double> p_, l_, u_, pred_, q_, work_;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_seq(const BackendOptions& options) { return std::make_unique<CpuSeq>(options); }

}  // namespace dtflop::rbe::detail
