// Backends of the grid-based RBE and their registry.
//
// A backend runs RBE steps (prediction by convolution with the motion kernel, correction by the
// likelihood, normalization by A_c times the sum, seed eqs. 4.10-4.12 / 5.3-5.7) on one kind of
// hardware, declares the exact cost counts of a step beside its code, and reports the host-clock
// time of each step's components. The registry is one explicit list (backends() in
// backend.cpp): adding a backend is adding its files and one line there.
//
// What a caller (the CLI, calibrate/, tune/) does:
//   auto b = rbe::make_backend("cuda-resident", options);  // throws InputError if unknown/invalid
//                                                           // (no device needed to make one)
//   b->init(problem);                                       // prior belief, kernel, likelihood
//   rbe::RunResult r = b->run(1000);                        // steps, timed
//   r.median().total, r.median().part(StepPart::predict), b->step_counts(shape, options) ...
//   std::vector<double> belief = b->belief();               // normalized density, float64
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "model/cost_counts.hpp"
#include "cuda/error.hpp"
#include "model/errors.hpp"
#include "workloads/rbe/counts.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/grid.hpp"
#include "workloads/rbe/motion.hpp"

namespace dtflop::rbe {

// ---- Errors -----------------------------------------------------------------------------

// A correction whose sum is zero or not finite: the likelihood is zero wherever the belief has
// mass (or a value overflowed). The backend's belief is left in an error state: belief() and
// run() throw until init() is called again. Never a silent NaN.
class NumericalError : public std::runtime_error {
 public:
  NumericalError(std::int64_t step, const std::string& what)
      : std::runtime_error(what), step_(step) {}
  std::int64_t step() const { return step_; }  // zero-based step of the run that failed
 private:
  std::int64_t step_;
};

// A CUDA backend asked for where no CUDA device can be used (or dtflop was built without
// CUDA). An InputError: the CLI prints it on one line and exits non-zero.
using DeviceUnavailable = cuda::Unavailable;

// Empty when a CUDA device is usable; otherwise one line saying why not and what to do.
std::string cuda_unavailable_reason();

// ---- Options ------------------------------------------------------------------------------

// Multiprocessors assumed when no GPU tells: an H100 or H200 SXM (132).
inline constexpr int kDefaultGpuSms = 132;

// How cuda-resident lays out its work; the tuner searches this space. A block is
// block_x x block_y threads; each thread computes cells_per_thread consecutive cells along y,
// so one block covers a tile of block_x x (block_y * cells_per_thread) cells.
// Invalid layouts are rejected by resident_plan() (backend_counts.hpp) with a message, never
// by a crash.
// The default, 32x8x16, was the best single layout over the three target configurations on the
// H200 (docs/PERFORMANCE.md); the tuner searches the rest.
struct Layout {
  int block_x = 32;
  int block_y = 8;
  int cells_per_thread = 16;
  // fused: one kernel per step (x-pass and y-pass through a shared-memory tile with halo,
  //        multiplied by the likelihood, block-reduced);
  // split: two kernels (x-pass to device memory, then y-pass + correction), for kernels whose
  //        tile would not fit in shared memory;
  // automatic: fused when its tile fits, else split.
  enum class Passes { automatic, fused, split } passes = Passes::automatic;
  bool operator==(const Layout&) const = default;
};
// "32x8" or "32x8x4" (block_x x block_y [x cells_per_thread]), optionally followed by
// ":fused" or ":split". Throws InputError naming the text.
Layout parse_layout(std::string_view text);
std::string to_string(const Layout& layout);

// How a backend computes the prediction step: the convolution with the motion model.
enum class Convolution {
  separable,  // two 1D passes (5.3-5.4); needs a separable kernel
  full,       // the conventional 2D convolution (4.10), any kernel
};

struct BackendOptions {
  HostMemory host_memory = HostMemory::pageable;  // cuda-seed: host buffers pageable or pinned
  int threads = 0;                                // cpu-par: 0 = every hardware thread
  Layout layout;                                  // cuda-resident
  // cuda-resident: multiprocessors (SMs) of the GPU the counts are for; its `waves` and N_G
  // count whole rounds of blocks on them (backend_counts.hpp). 0: the GPU of this machine when
  // there is one, else kDefaultGpuSms. `dtflop predict` sets it from the profile's identity.
  int gpu_sms = 0;
  // The prediction to use; empty: separable when the kernel is separable, else full.
  std::optional<Convolution> prediction;
  // cuda-resident: capture the step loop in a CUDA graph (default) or launch kernel by kernel.
  bool graph = true;
  // cuda-bands: the grid in `partitions` horizontal bands (0: one per GPU) over `gpus` GPUs (0:
  // every GPU this process sees). One band per GPU (halos and the sum over NCCL), or every band
  // on one GPU (gpus 1: the same code, copies inside its memory); band_counts.hpp.
  int partitions = 0;
  int gpus = 0;
  // Fill every buffer a step writes with NaN at init, so that a cell a step fails to write
  // shows up as NaN in the belief (tests use it; it costs nothing per step).
  bool poison = false;
};
// The multiprocessors cuda-resident's counts are for with `options`: gpu_sms when set (> 0),
// else this machine's GPU (cuda::device_sms()), else kDefaultGpuSms.
int counted_gpu_sms(const BackendOptions& options);

// ---- Problem ----------------------------------------------------------------------------

// Everything a run needs. `prior` and `likelihood` are grid arrays (see grid.hpp); the prior is
// a density (need not be normalized: init() normalizes it to integrate to one). The same
// likelihood is applied at every step of run(); step(likelihood) applies a new one.
struct Problem {
  Grid grid;
  MotionKernel kernel;
  std::vector<double> prior;
  std::vector<double> likelihood;
  std::vector<std::uint8_t> mask;  // optional target-space mask (grid.hpp); empty = all cells
  Shape shape() const { return {grid.nx(), grid.ny(), kernel.Ix(), kernel.Iy()}; }
};
// Throws InputError naming what is wrong: sizes that disagree, negative or non-finite values,
// a prior with no mass (inside the mask), a kernel larger than the grid.
void validate(const Problem& problem);

// A likelihood that is `outside` on every cell but those of `window` (estimate.hpp), where it takes
// `values`, row by row over the window: value (ix, iy) at [(iy - iy0) * width + (ix - ix0)]. A
// sensor's likelihood is one (1 beyond its reach without a detection, 0 with one): a backend whose
// belief lives on a device sends only the window (Backend::step(const WindowedLikelihood&)).
struct WindowedLikelihood {
  Window window;
  double outside = 1;
  std::vector<double> values;
  double at(std::int64_t ix, std::int64_t iy) const;  // the value of cell (ix, iy)
};
// Throws InputError naming what is wrong: a window not inside the grid, values of another count,
// a negative or non-finite value.
void validate(const WindowedLikelihood& l, const Grid& grid);
// The likelihood as a grid array (validated first).
std::vector<double> expand(const WindowedLikelihood& l, const Grid& grid);
// The product of two (observation fusion, 4.13): outside the product of the outsides, on the
// smallest window holding both windows the product of the values (validated first).
WindowedLikelihood multiply(const WindowedLikelihood& a, const WindowedLikelihood& b, const Grid& grid);

// A reproducible synthetic problem for benchmarks and calibration: unit grid nx x ny, a
// separable Gaussian kernel of size Ix x Iy (sigma = size / 6, slight drift), a random smooth
// prior and a random positive likelihood drawn from `seed`.
Problem synthetic_problem(const Shape& shape, std::uint64_t seed);

// ---- Timing -------------------------------------------------------------------------------

// The parts a step's time is split into, each tied to a term of the DTFLOP model.
enum class StepPart {
  to_device,   // host -> device copies                       (dt_CG)
  to_host,     // device -> host copies                       (dt_GC)
  predict,     // prediction                                  (dt_G/dt_GG on device, dt_C on host)
  correct,     // likelihood x prediction and the sum         (same)
  normalize,   // division by A_c x sum                       (same)
  host_sum,    // the sum taken on the CPU (cuda-seed only)   (dt_C)
  device_step, // a fused device step that is not split further (cuda-resident)
  kCount
};
inline constexpr int kStepPartCount = static_cast<int>(StepPart::kCount);
std::string_view to_string(StepPart c);

// Times of one step (or the mean step of a chunk of steps), in seconds.
struct StepTimes {
  double total = 0;                                // wall time of the step
  std::array<double, kStepPartCount> parts{};     // components measured (0 when not present)
  double part(StepPart c) const { return parts[static_cast<std::size_t>(c)]; }
  double& part(StepPart c) { return parts[static_cast<std::size_t>(c)]; }
};

struct RunResult {
  std::int64_t steps = 0;
  // One sample per timed step; backends that time a chunk of steps at once (a CUDA graph)
  // report one sample per chunk holding the mean step of that chunk.
  std::vector<StepTimes> samples;
  std::int64_t steps_per_sample = 1;
  double wall_seconds = 0;          // the whole run, host clock, setup (graph capture) excluded
  double setup_seconds = 0;         // one-time work of this run (graph capture and instantiation)
  std::vector<double> sums;         // A_c x sum of q per step when the backend returns it
  // Median of each field over the samples (component by component).
  StepTimes median() const;
  // Components that the backend measured (non-zero in some sample).
  std::vector<StepPart> components() const;
};

// ---- Belief fusion -------------------------------------------------------------------------

// How the beliefs of several platforms are fused: the normalized product (seed 5.8-5.9) or the
// log-linear pool prod_i b_i^(1/n), normalized (counts nothing twice; sar/fusion.hpp).
enum class FusionRule { product, loglinear };
std::string_view to_string(FusionRule r);

// ---- Backend ----------------------------------------------------------------------------

class Backend {
 public:
  virtual ~Backend() = default;

  virtual std::string_view name() const = 0;
  virtual std::string_view description() const = 0;
  virtual bool needs_gpu() const = 0;

  // Exact cost counts of one steady-state step of `shape` with `options`, declared beside the
  // backend's code and checked by tests against formulas written out by hand.
  virtual CostCounts step_counts(const Shape& shape, const BackendOptions& options) const = 0;
  // Counts of run(steps): step_counts x steps plus what a run does once (graph launch, the
  // final copy of the sums). The default is step_counts x steps.
  virtual CostCounts run_counts(const Shape& shape, const BackendOptions& options,
                                std::int64_t steps) const {
    return step_counts(shape, options).scaled(steps);
  }
  // Stable names of the device kernels the backend launches (for CUPTI attribution); host
  // backends return none. In a CUDA build, each host-timed component of a step is an NVTX range
  // "rbe/<component>" (cuda-resident's steps run inside a graph: its kernels carry the names).
  virtual std::vector<std::string_view> kernel_names() const { return {}; }

  // Allocates, uploads and normalizes the prior. Throws InputError for an invalid problem or
  // one this backend cannot run (e.g. a full kernel on a separable-only backend), and
  // DeviceUnavailable without a device.
  virtual void init(const Problem& problem) = 0;
  // `steps` steps with the problem's likelihood, timed. Throws NumericalError on a zero sum.
  virtual RunResult run(std::int64_t steps) = 0;
  // One step with a new likelihood (a grid array; the mask is applied to it). Returns its times.
  virtual StepTimes step(std::span<const double> likelihood) = 0;
  // The same step with a windowed likelihood: the same belief as step(expand(l, grid)), to the
  // bit. cuda-resident sends only the window to the device (and resets the cells of the previous
  // window, or the whole grid when `outside` changed, there); the others expand it. Throws
  // InputError for an invalid likelihood (validate).
  virtual StepTimes step(const WindowedLikelihood& likelihood) = 0;
  // Replaces the motion kernel (a step of another length) and keeps the belief. cuda-resident
  // keeps it on the device (only what depends on the kernel is made again); the others init()
  // again from belief() (float32 backends round it once more). Throws InputError for a kernel
  // this backend cannot run (the backend then needs init()).
  virtual void set_kernel(const MotionKernel& kernel) = 0;
  // The normalized belief (density: sum x A_c = 1) as float64, n_x n_y values.
  virtual std::vector<double> belief() = 0;
  // The options the backend was made with.
  virtual const BackendOptions& options() const = 0;

  // Belief fusion (seed 5.8-5.9, and the log-linear pool) on the backend's own hardware, where
  // its belief lives (fusion_counts.hpp declares the exact counts of both, docs/sar.md):
  // The belief as it travels to the other platforms: float32, normalized (sum x A_c = 1), n_g
  // values, made where the belief lives (cuda-resident: on the device, then one copy back).
  virtual std::vector<float> wire_belief() = 0;
  // Replaces the belief by its fusion with `others` (the other platforms' wire beliefs, n_g
  // values each) by `rule`. The own belief enters as its wire belief would (the same float32
  // values, made on the fly) at `position` of the m = others + 1 beliefs, the others in their
  // order around it: every platform that fuses the same beliefs in the same order on the same
  // backend computes the same fused belief. Throws NumericalError when the fusion is zero or
  // not finite everywhere (the beliefs do not overlap): the belief is then left as it was;
  // InputError for a wrong size or position.
  virtual void fuse(FusionRule rule, std::span<const std::span<const float>> others, std::size_t position) = 0;
  // Exact counts of fuse() with `platforms` - 1 others and of wire_belief(), on `shape`'s grid.
  virtual CostCounts fusion_counts(const Shape& shape, FusionRule rule, std::int64_t platforms,
                                   const BackendOptions& options) const = 0;
  virtual CostCounts wire_counts(const Shape& shape, const BackendOptions& options) const = 0;

  // What the estimate and a search control read, computed where the belief lives
  // (summary_counts.hpp declares the exact counts): the estimate of the belief (estimate.hpp;
  // step, time and detected left at their defaults) and, for each point of `at`, the expected
  // detection under footprint `f` (footprint_sums). The CPU backends and cuda-seed compute it on
  // the host from their belief; cuda-resident on the device, bringing back only these numbers.
  // Matches estimate(grid, belief()) and footprint_sums(grid, belief(), f, at) up to the order of
  // the sums. Throws InputError for a bad footprint or point.
  virtual Summary summarize(const Footprint& f, std::span<const Point> at) = 0;
  virtual CostCounts summary_counts(const Grid& grid, const Footprint& f, std::span<const Point> at,
                                    const BackendOptions& options) const = 0;
};

// ---- Registry ---------------------------------------------------------------------------

struct BackendInfo {
  std::string name;         // "cpu-seq", "cpu-par", "cuda-bands", "cuda-seed", "cuda-resident"
  std::string description;
  bool needs_gpu = false;
  // Makes the backend (no device needed: init() needs it). Throws InputError for options the
  // backend rejects (e.g. an invalid layout).
  std::function<std::unique_ptr<Backend>(const BackendOptions&)> make;
};
// Every backend, sorted by name. CUDA backends are listed in every build; where dtflop was
// built without CUDA their init() throws DeviceUnavailable saying so.
const std::vector<BackendInfo>& backends();
// Throws InputError naming the known backends when `name` is unknown.
std::unique_ptr<Backend> make_backend(std::string_view name, const BackendOptions& options = {});
// The exact counts of one step of a backend, without a device.
CostCounts step_counts(std::string_view backend, const Shape& shape, const BackendOptions& options = {});

}  // namespace dtflop::rbe
