#include "workloads/rbe/backend.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "cuda/device.hpp"

#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/detail.hpp"

namespace dtflop::rbe {

// ---- Device -------------------------------------------------------------------------------

std::string cuda_unavailable_reason() {
  const std::string why = cuda::unavailable_reason();
  return why.empty() ? why : why + "; run a cpu-seq or cpu-par backend, or run on a machine with an NVIDIA GPU and its driver";
}

int counted_gpu_sms(const BackendOptions& o) {
  if (o.gpu_sms > 0) return o.gpu_sms;
  const int here = cuda::device_sms();
  return here > 0 ? here : kDefaultGpuSms;
}

// ---- Layout -------------------------------------------------------------------------------

Layout parse_layout(std::string_view text) {
  const std::string original(text);
  Layout l;
  auto bad = [&](const std::string& why) {
    return InputError(fmt::format("--layout '{}' {}; write BXxBY or BXxBYxC (block dims, cells per "
                                  "thread), optionally :fused or :split, e.g. 32x8x8",
                                  original, why));
  };
  if (auto colon = text.find(':'); colon != std::string_view::npos) {
    const auto mode = text.substr(colon + 1);
    if (mode == "fused") l.passes = Layout::Passes::fused;
    else if (mode == "split") l.passes = Layout::Passes::split;
    else if (mode == "auto") l.passes = Layout::Passes::automatic;
    else throw bad(fmt::format("has an unknown mode '{}' (use fused, split or auto)", mode));
    text = text.substr(0, colon);
  }
  std::vector<int> parts;
  while (true) {
    const auto x = text.find('x');
    const auto piece = text.substr(0, x);
    int v = 0;
    auto [ptr, ec] = std::from_chars(piece.data(), piece.data() + piece.size(), v);
    if (piece.empty() || ec != std::errc() || ptr != piece.data() + piece.size() || v < 1)
      throw bad(fmt::format("has '{}' where a positive integer belongs", piece));
    parts.push_back(v);
    if (x == std::string_view::npos) break;
    text = text.substr(x + 1);
  }
  if (parts.size() < 2 || parts.size() > 3) throw bad("needs two or three numbers");
  l.block_x = parts[0];
  l.block_y = parts[1];
  if (parts.size() == 3) l.cells_per_thread = parts[2];
  return l;
}

std::string to_string(const Layout& l) {
  const char* mode = l.passes == Layout::Passes::fused   ? ":fused"
                     : l.passes == Layout::Passes::split ? ":split"
                                                         : "";
  return fmt::format("{}x{}x{}{}", l.block_x, l.block_y, l.cells_per_thread, mode);
}

// ---- Problem ------------------------------------------------------------------------------

void validate(const Problem& p) {
  if (p.kernel.Ix() < 1 || p.kernel.Iy() < 1)
    throw InputError("the problem has no motion kernel; build one with make_kernel()");
  validate(p.shape());
  const auto n = static_cast<std::size_t>(p.grid.cells());
  if (p.prior.size() != n)
    throw InputError(fmt::format("the prior has {} values, the {}x{} grid {}", p.prior.size(), p.grid.nx(),
                                 p.grid.ny(), n));
  if (p.likelihood.size() != n)
    throw InputError(fmt::format("the likelihood has {} values, the {}x{} grid {}", p.likelihood.size(),
                                 p.grid.nx(), p.grid.ny(), n));
  if (!p.mask.empty() && p.mask.size() != n)
    throw InputError(fmt::format("the mask has {} values, the grid {}", p.mask.size(), n));
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p.prior[i]) || p.prior[i] < 0)
      throw InputError(fmt::format("prior value {} (cell {}, {}) is {}; it must be finite and >= 0", i,
                                   i % p.grid.nx(), i / p.grid.nx(), p.prior[i]));
    if (!std::isfinite(p.likelihood[i]) || p.likelihood[i] < 0)
      throw InputError(fmt::format("likelihood value {} (cell {}, {}) is {}; it must be finite and >= 0", i,
                                   i % p.grid.nx(), i / p.grid.nx(), p.likelihood[i]));
  }
}

Problem synthetic_problem(const Shape& s, std::uint64_t seed) {
  validate(s);
  Problem p;
  p.grid = Grid::unit(s.nx, s.ny);
  GaussianMotion m;
  m.sigma_x = std::max(double(s.Ix) / 6, 0.25);
  m.sigma_y = std::max(double(s.Iy) / 6, 0.25);
  m.mean_x = 0.1 * m.sigma_x;
  m.mean_y = -0.05 * m.sigma_y;
  p.kernel = make_kernel(m, p.grid, s.Ix, s.Iy);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  const auto n = static_cast<std::size_t>(s.cells());
  p.prior.assign(n, 0);
  // A few Gaussian bumps on a small floor: smooth, positive, with structure everywhere.
  struct Bump { double x, y, sx, sy, w; };
  std::vector<Bump> bumps(4);
  for (auto& b : bumps)
    b = {u01(rng) * double(s.nx), u01(rng) * double(s.ny), (0.05 + 0.2 * u01(rng)) * double(s.nx),
         (0.05 + 0.2 * u01(rng)) * double(s.ny), 0.5 + u01(rng)};
  for (std::int64_t iy = 0; iy < s.ny; ++iy)
    for (std::int64_t ix = 0; ix < s.nx; ++ix) {
      double v = 1e-3;
      for (const auto& b : bumps) {
        const double dx = (double(ix) - b.x) / b.sx, dy = (double(iy) - b.y) / b.sy;
        v += b.w * std::exp(-0.5 * (dx * dx + dy * dy));
      }
      p.prior[static_cast<std::size_t>(iy * s.nx + ix)] = v;
    }
  p.likelihood.resize(n);
  for (auto& v : p.likelihood) v = 0.5 + u01(rng);
  return p;
}

// ---- Timing -------------------------------------------------------------------------------

std::string_view to_string(FusionRule r) { return r == FusionRule::product ? "product" : "loglinear"; }

std::string_view to_string(StepPart c) {
  switch (c) {
    case StepPart::to_device: return "to_device";
    case StepPart::to_host: return "to_host";
    case StepPart::predict: return "predict";
    case StepPart::correct: return "correct";
    case StepPart::normalize: return "normalize";
    case StepPart::host_sum: return "host_sum";
    case StepPart::device_step: return "device_step";
    case StepPart::kCount: break;
  }
  return "?";
}

namespace {
double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2) return *mid;
  const double hi = *mid;
  const double lo = *std::max_element(v.begin(), mid);
  return 0.5 * (lo + hi);
}
}  // namespace

StepTimes RunResult::median() const {
  StepTimes m;
  std::vector<double> v(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) v[i] = samples[i].total;
  m.total = median_of(v);
  for (std::size_t c = 0; c < m.parts.size(); ++c) {
    for (std::size_t i = 0; i < samples.size(); ++i) v[i] = samples[i].parts[c];
    m.parts[c] = median_of(v);
  }
  return m;
}

std::vector<StepPart> RunResult::components() const {
  std::vector<StepPart> out;
  for (int c = 0; c < kStepPartCount; ++c)
    for (const auto& s : samples)
      if (s.parts[static_cast<std::size_t>(c)] != 0) {
        out.push_back(static_cast<StepPart>(c));
        break;
      }
  return out;
}

// ---- Registry -----------------------------------------------------------------------------

const std::vector<BackendInfo>& backends() {
  // The one list of backends (sorted by name).
  static const std::vector<BackendInfo> list = {
      {"cpu-par", "float32 on every CPU thread, vectorized two-pass separable prediction", false,
       detail::make_cpu_par},
      {"cpu-seq", "float64 reference on one thread, written for clarity (separable or full 2D)", false,
       detail::make_cpu_seq},
      {"cuda-bands",
       "the grid in horizontal bands over several GPUs (or one): cuda-resident's kernel per band, NCCL halo "
       "exchange overlapped with the inner rows, the sum by an all-reduce",
       true, detail::make_cuda_bands},
      {"cuda-resident",
       "belief stays on the GPU: fused tile kernel, device-side sum, CUDA graph, one scalar per step",
       true, detail::make_cuda_resident},
      {"cuda-seed",
       "the seed's GPU pipeline (5.3.1): belief to the device and back every step, sum on the CPU", true,
       [](const BackendOptions& o) {
         // Refused when the configuration is made, not when it first runs (resolve_prediction).
         if (o.prediction == Convolution::full)
           throw InputError("cuda-seed computes only the separable prediction (5.3-5.4): use --prediction "
                            "separable (or auto), or the full 2D prediction on cpu-seq or cpu-par");
         return detail::make_cuda_seed(o);
       }},
  };
  return list;
}

std::unique_ptr<Backend> make_backend(std::string_view name, const BackendOptions& options) {
  for (const auto& b : backends())
    if (b.name == name) return b.make(options);
  std::string known;
  for (const auto& b : backends()) known += (known.empty() ? "" : ", ") + b.name;
  throw InputError(fmt::format("unknown RBE backend '{}'; use one of {}", name, known));
}

CostCounts step_counts(std::string_view backend, const Shape& shape, const BackendOptions& options) {
  return make_backend(backend, options)->step_counts(shape, options);
}

// ---- Helpers shared by the backends -------------------------------------------------------

double WindowedLikelihood::at(std::int64_t ix, std::int64_t iy) const {
  if (ix < window.ix0 || ix > window.ix1 || iy < window.iy0 || iy > window.iy1) return outside;
  const std::int64_t w = window.ix1 - window.ix0 + 1;
  return values[static_cast<std::size_t>((iy - window.iy0) * w + (ix - window.ix0))];
}

void validate(const WindowedLikelihood& l, const Grid& grid) {
  const Window& w = l.window;
  const bool empty = w.cells() == 0;
  if (!empty && (w.ix0 < 0 || w.iy0 < 0 || w.ix1 >= grid.nx() || w.iy1 >= grid.ny()))
    throw InputError(fmt::format("a likelihood window of cells ({}, {}) .. ({}, {}) is not inside the {}x{} grid; "
                                 "clip it to the grid",
                                 w.ix0, w.iy0, w.ix1, w.iy1, grid.nx(), grid.ny()));
  if (static_cast<std::int64_t>(l.values.size()) != w.cells())
    throw InputError(fmt::format("a likelihood window of {} cells has {} values; give one value per cell", w.cells(),
                                 l.values.size()));
  if (!(l.outside >= 0) || !std::isfinite(l.outside))
    throw InputError(fmt::format("the likelihood outside its window is {}; give a finite value >= 0", l.outside));
  for (std::size_t i = 0; i < l.values.size(); ++i)
    if (!(l.values[i] >= 0) || !std::isfinite(l.values[i]))
      throw InputError(fmt::format("likelihood window value {} is {}; give finite values >= 0", i, l.values[i]));
}

std::vector<double> expand(const WindowedLikelihood& l, const Grid& grid) {
  validate(l, grid);
  std::vector<double> out(static_cast<std::size_t>(grid.cells()), l.outside);
  const Window& w = l.window;
  const std::int64_t width = w.ix1 - w.ix0 + 1;
  for (std::int64_t iy = w.iy0; iy <= w.iy1 && w.cells() > 0; ++iy)
    for (std::int64_t ix = w.ix0; ix <= w.ix1; ++ix)
      out[static_cast<std::size_t>(grid.index(ix, iy))] =
          l.values[static_cast<std::size_t>((iy - w.iy0) * width + (ix - w.ix0))];
  return out;
}

WindowedLikelihood multiply(const WindowedLikelihood& a, const WindowedLikelihood& b, const Grid& grid) {
  validate(a, grid);
  validate(b, grid);
  WindowedLikelihood r;
  r.outside = a.outside * b.outside;
  const bool ea = a.window.cells() == 0, eb = b.window.cells() == 0;
  if (ea && eb) return r;
  const Window& wa = ea ? b.window : a.window;
  const Window& wb = eb ? a.window : b.window;
  r.window = {std::min(wa.ix0, wb.ix0), std::max(wa.ix1, wb.ix1), std::min(wa.iy0, wb.iy0), std::max(wa.iy1, wb.iy1)};
  r.values.reserve(static_cast<std::size_t>(r.window.cells()));
  for (std::int64_t iy = r.window.iy0; iy <= r.window.iy1; ++iy)
    for (std::int64_t ix = r.window.ix0; ix <= r.window.ix1; ++ix) r.values.push_back(a.at(ix, iy) * b.at(ix, iy));
  return r;
}

namespace detail {

std::vector<double> normalized_prior(const Problem& problem) {
  validate(problem);
  std::vector<double> p = problem.prior;
  if (!problem.mask.empty())
    for (std::size_t i = 0; i < p.size(); ++i)
      if (!problem.mask[i]) p[i] = 0;
  double sum = 0;
  for (double v : p) sum += v;
  const double z = sum * problem.grid.cell_area();
  if (!(z > 0) || !std::isfinite(z))
    throw InputError(problem.mask.empty()
                         ? "the prior has no probability mass (all zeros); give a prior with mass somewhere"
                         : "the prior has no probability mass inside the target-space mask; give a prior "
                           "with mass inside the target space");
  for (double& v : p) v /= z;
  return p;
}

std::vector<double> masked_likelihood(std::span<const double> l, std::span<const std::uint8_t> mask,
                                      std::int64_t cells) {
  if (static_cast<std::int64_t>(l.size()) != cells)
    throw InputError(fmt::format("the likelihood has {} values, the grid {}", l.size(), cells));
  std::vector<double> out(l.begin(), l.end());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (!std::isfinite(out[i]) || out[i] < 0)
      throw InputError(fmt::format("likelihood value {} is {}; it must be finite and >= 0", i, out[i]));
    if (!mask.empty() && !mask[i]) out[i] = 0;
  }
  return out;
}

Convolution resolve_prediction(const BackendOptions& o, const MotionKernel& k, bool supports_full,
                              std::string_view backend) {
  const Convolution p = o.prediction.value_or(k.is_separable() ? Convolution::separable : Convolution::full);
  if (p == Convolution::separable && !k.is_separable())
    throw InputError("the separable prediction needs a separable (axis-aligned) motion kernel; this "
                     "kernel is a full 2D one: use the full prediction");
  if (p == Convolution::full && !supports_full)
    throw InputError(fmt::format("{} computes only the separable prediction (5.3-5.4) and needs an "
                                 "axis-aligned motion kernel; run a full 2D kernel on cpu-seq or cpu-par",
                                 backend));
  return p;
}

void check_sum(double sum, std::int64_t step, std::string_view backend) {
  if (sum > 0 && std::isfinite(sum)) return;
  throw NumericalError(
      step, fmt::format("{}: correction at step {} failed: the sum of likelihood x predicted belief is {}. "
                        "The likelihood is zero wherever the belief has mass (an observation where the "
                        "belief says the target cannot be, or a mask that excludes it){}. The belief is "
                        "invalid until init() is called again.",
                        backend, step, std::isfinite(sum) ? "zero" : "not finite",
                        std::isfinite(sum) ? "" : "; or a value overflowed"));
}

void append_segment(RunResult& r, std::int64_t n, std::int64_t chunk,
                    const std::function<double(std::size_t chunk)>& chunk_seconds, std::span<const double> host_sums,
                    double cell_area, std::int64_t first_step, std::string_view backend, bool& failed) {
  const std::int64_t chunks = (n + chunk - 1) / chunk;
  for (std::int64_t c = 0; c < chunks; ++c) {
    const std::int64_t m = std::min(chunk, n - c * chunk);
    StepTimes t;
    t.total = chunk_seconds(std::size_t(c)) / double(m);
    t.part(StepPart::device_step) = t.total;
    r.samples.push_back(t);
  }
  for (std::int64_t k = 0; k < n; ++k) {
    const double S = host_sums[std::size_t(k)];
    if (!(S > 0 && std::isfinite(S))) {
      failed = true;
      check_sum(S, first_step + k, backend);
    }
    r.sums.push_back(S * cell_area);
  }
}

void check_others(std::span<const std::span<const float>> others, std::size_t position, std::int64_t cells,
                  std::string_view backend) {
  if (others.empty()) throw InputError(fmt::format("{}: belief fusion needs at least one other belief", backend));
  if (position > others.size())
    throw InputError(fmt::format("{}: belief fusion: the own belief's position {} is past the {} beliefs", backend,
                                 position, others.size() + 1));
  for (std::size_t p = 0; p < others.size(); ++p)
    if (static_cast<std::int64_t>(others[p].size()) != cells)
      throw InputError(fmt::format("{}: belief fusion: other belief {} has {} cells, the grid {}", backend, p,
                                   others[p].size(), cells));
}

void check_fusion_sum(double sum, std::size_t platforms, FusionRule rule, std::string_view backend) {
  if (sum > 0 && std::isfinite(sum)) return;
  throw NumericalError(0, fmt::format("{}: {} fusion of {} beliefs is {} everywhere (their beliefs do not overlap); "
                                      "the belief is kept as it was: fuse fewer platforms or fuse more often",
                                      backend, to_string(rule), platforms, std::isfinite(sum) ? "zero" : "not finite"));
}

Summary host_summary(const Grid& grid, std::span<const double> belief, const Footprint& f, std::span<const Point> at) {
  check_footprint(f, at);
  Summary r;
  r.estimate = estimate(grid, belief);
  r.footprints = footprint_sums(grid, belief, f, at);
  return r;
}

void throw_not_ready(std::string_view backend, bool failed) {
  if (failed)
    throw NumericalError(-1, fmt::format("{}: the belief is in an error state after a failed correction; "
                                         "call init() again",
                                         backend));
  throw InputError(fmt::format("{}: no problem loaded; call init() first", backend));
}

}  // namespace detail
}  // namespace dtflop::rbe
