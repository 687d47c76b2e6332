#include "workloads/dct/workload.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <thread>
#include <tuple>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/dct/analysis.hpp"

namespace dtflop::dct {

namespace wl = ::dtflop::workload;
using nlohmann::json;

namespace {

// ---- Geometry of a configuration ------------------------------------------------------------

constexpr double kMaxPixels = 24'000'000;  // 24 MP, the seed's stills (6000x4000)
constexpr int kMaxPoints = 16384;
// Dots keep an edge-to-edge gap of one radius (centres >= 3 r apart) and stay this far from
// the image's edge beyond their radius: the centroid window (margin 2 + ring 2 px), the motion
// of the deformed frame (<= 0.6 px at 24 MP) and a pixel to spare.
constexpr double kEdge = 8;
// Random dots are thrown until they cover at most this fraction of the pattern area with their
// exclusion discs (diameter 3 r): random sequential adsorption jams at 0.547, and the renderer
// gives up after 200 tries per dot; at 0.35 the plans' dots are placed at the first try.
constexpr double kMaxCover = 0.35;


// Defaults of the parameters added after stores were measured (keyed_at_default = false): what
// every configuration did before they existed.
constexpr std::int64_t kDefaultSupport = 40;
constexpr double kDefaultLevel = 128;
constexpr CudaLayout kDefaultLayout{};

struct Geometry {
  std::int64_t w = 0, h = 0;
  std::int64_t dots = 0;
  double radius = 0;
  std::int64_t nx = 0, ny = 0;
  std::int64_t support = 0;
  double support_radius = 0;  // px; 0: the support is `support` dots
  Interp interp = Interp::mls;
  Weight weight = Weight::cubic_spline;
  ThresholdMethod threshold = ThresholdMethod::otsu;
  double level = kDefaultLevel;
  int bytes_per_pixel = 1;
};

Geometry geometry_of(const wl::Config& c) {
  Geometry g;
  std::tie(g.w, g.h) = wl::get_size2(c, "size");
  g.dots = wl::get_int(c, "dots");
  g.radius = wl::get_real(c, "radius");
  std::tie(g.nx, g.ny) = wl::get_size2(c, "points");
  g.support = wl::get_int(c, "support");
  g.support_radius = wl::get_real(c, "support-radius");
  g.interp = interp_from_string(wl::get_text(c, "interp"));
  g.weight = weight_from_string(wl::get_text(c, "weight"));
  g.threshold = threshold_method_from_string(wl::get_text(c, "threshold"));
  g.level = wl::get_real(c, "threshold-level");
  g.bytes_per_pixel = wl::get_text(c, "bits") == "16" ? 2 : 1;
  return g;
}

CudaLayout layout_of(const wl::Config& c) {
  CudaLayout l;
  if (wl::has(c, "block-pixels")) l.block_pixels = static_cast<int>(wl::get_int(c, "block-pixels"));
  if (wl::has(c, "block-points")) l.block_points = static_cast<int>(wl::get_int(c, "block-points"));
  if (wl::has(c, "block-dots")) l.block_dots = static_cast<int>(wl::get_int(c, "block-dots"));
  return l;
}

// "s40", "r150px", " quartic", " fixed:128": what sets a configuration's fields apart in labels.
std::string support_text(const Geometry& g) {
  return g.support_radius > 0 ? fmt::format("r{:g}px", g.support_radius) : fmt::format("s{}", g.support);
}

double inset(double radius) { return radius + kEdge; }

// The area dots may occupy, px^2 (0 when the edges leave none).
double pattern_area(std::int64_t w, std::int64_t h, double radius) {
  const double aw = static_cast<double>(w) - 1 - 2 * inset(radius), ah = static_cast<double>(h) - 1 - 2 * inset(radius);
  return aw > 0 && ah > 0 ? aw * ah : 0;
}

// How many dots of `radius` the image holds at the covering limit.
std::int64_t capacity(std::int64_t w, std::int64_t h, double radius) {
  const double d = 3 * radius;
  return static_cast<std::int64_t>(std::floor(kMaxCover * pattern_area(w, h, radius) / (std::numbers::pi / 4 * d * d)));
}

std::int64_t physical_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<std::int64_t>(pages) * page : 0;
}

// ---- The contract's backend: one per entry of backend_kinds() --------------------------------

class Run final : public wl::Run {
 public:
  Run(const BackendKind& kind, const wl::Config& c, std::int64_t steps) : kind_(kind), steps_(steps) {
    opt_ = pipeline_options(c, kind.name);
    // Running creates the threads: no more than this machine has (counts may be for another one).
    if (kind.name == "cpu-par") checked_threads(opt_.threads, "dct --threads");
    const Specimen sp = specimen_of(c);
    const cv::Mat reference = sp.reference_image();
    deformed_ = sp.deformed_image();
    pipe_ = kind.make(opt_);
    pipe_->set_reference(reference);
    const auto expected = static_cast<std::size_t>(wl::get_int(c, "dots"));
    if (pipe_->reference_dots().size() != expected)
      throw std::runtime_error(fmt::format("{} found {} of the {} dots rendered in the reference frame; the counts "
                                           "would not be the configuration's (report this configuration)",
                                           kind.name, pipe_->reference_dots().size(), expected));
    // Declared before the first frame.
    shape_ = declared_shape(*pipe_, deformed_);
    frame_counts_ = kind.frame_counts(shape_, opt_);
    counts_ = frame_counts_.scaled(steps_);
    frame_ = deformed_;
    if (opt_.pinned_frames && kind.needs_gpu) {
      frame_ = pipe_->frame_buffer(deformed_.size(), deformed_.type());
      deformed_.copyTo(frame_);
    }
  }

  CostCounts counts() const override { return counts_; }

  wl::PhaseTimes repeat() override {
    wl::PhaseTimes t;
    const auto t0 = std::chrono::steady_clock::now();
    double host = 0, kernels = 0, uploads = 0;
    for (std::int64_t i = 0; i < steps_; ++i) {
      // The last frame times its device stages (its seconds are the ones shown); the others run as
      // a deployment would, without the events (Backend::time_device_stages).
      pipe_->time_device_stages(i + 1 == steps_);
      last_ = pipe_->process(frame_);
      if (kind_.needs_gpu) {
        host += last_.seconds.at("host");
        uploads += last_.seconds.at("host_upload");
      }
    }
    if (kind_.needs_gpu && steps_ > 0) kernels = last_.seconds.at("device_kernels") * static_cast<double>(steps_);
    t.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (kind_.needs_gpu) {
      // Copies and kernels are not bracketed from the host (they interleave on the stream): the
      // protocol takes GC and G from CUPTI; G_events (used where CUPTI is not) is the last frame's
      // kernels between events, times the frames. CG too for pinned frames; pageable uploads are
      // the host's (its time in the upload calls: the driver's staging and the DMA of every chunk
      // but the last, which may finish after the call returns; CUPTI's device-side records of a
      // staged copy hold its DMA alone, and dt_CG prices the whole staged copy, as the probe times
      // it). The frame's own counts say which kind of memory it came from.
      if (last_.counts.host_memory == HostMemory::pageable) t.CG = uploads;
      // C is the host's own work (matching, the component records, the fields' conversion), of
      // which the counts price the matching's steps (match_steps, tree_steps; N_C = 0).
      t.C = host;
      t.G_events = kernels;
    } else {
      t.C = t.wall;  // the whole frame is CPU work
    }
    ran_ = true;
    return t;
  }

  std::string check() override {
    if (!ran_) return "no frame was processed";
    const std::string shape = shape_difference(shape_, last_.shape);
    const std::string counts = counts_difference(frame_counts_, last_.counts);
    if (shape.empty() && counts.empty()) return {};
    return fmt::format("{} frame differs from the declared one: {}{}{}", kind_.name, shape,
                       !shape.empty() && !counts.empty() ? "; " : "", counts);
  }

  json detail() const override {
    json d = {{"reference_dots", pipe_->reference_dots().size()},
              {"points", pipe_->points().size()},
              {"support_entries", shape_.support_entries},
              {"window_pixels", shape_.window_pixels},
              {"components", shape_.components},
              // The rest of the declared shape, for reading a store's costs apart (docs/dct.md).
              {"shape", {{"roi_pixels", shape_.roi_pixels},
                         {"bytes_per_pixel", shape_.bytes_per_pixel},
                         {"foreground_pixels", shape_.foreground_pixels},
                         {"ring_pixels", shape_.ring_pixels},
                         {"weighted_pixels", shape_.weighted_pixels},
                         {"scanned_pixels", shape_.scanned_pixels},
                         {"tree_steps", shape_.tree_steps},
                         {"match_steps", shape_.match_steps}}}};
    if (ran_) {
      std::int64_t valid = 0;
      for (const auto& f : last_.fields) valid += f.status == PointStatus::ok;
      d["frame_dots"] = last_.dots.size();
      d["matched"] = last_.matches.matched;
      d["valid_points"] = valid;
      json sec = json::object();
      for (const auto& [k, v] : last_.seconds) sec[k] = v;
      d["last_frame_seconds"] = sec;
    }
    if (kind_.name == "cpu-par") d["threads"] = cpu_threads(opt_);
    return d;
  }

 private:
  const BackendKind& kind_;
  std::int64_t steps_;
  PipelineOptions opt_;
  std::unique_ptr<Backend> pipe_;
  cv::Mat deformed_, frame_;
  FrameShape shape_;
  CostCounts frame_counts_, counts_;
  FrameOutput last_;
  bool ran_ = false;
};

class ContractBackend final : public wl::Backend {
 public:
  explicit ContractBackend(const BackendKind& k) : wl::Backend({k.name, k.description, k.needs_gpu}), kind_(k) {}

  std::string unavailable() const override {
    const std::string why = kind_.unavailable();
    return why.empty() ? why : fmt::format("the {} backend cannot run here: {}; use cpu-seq or cpu-par", name(), why);
  }

  // `threads` 0 (every hardware thread) means the target's where the counts are for another machine.
  CostCounts counts(const wl::Config& c, const MachineIdentity* target) const override {
    PipelineOptions o = pipeline_options(c, name());
    if (o.threads == 0 && target && target->cpu_threads > 0) o.threads = target->cpu_threads;
    return kind_.frame_counts(estimated_shape(c), o);
  }

  std::unique_ptr<wl::Run> prepare(const wl::Config& c, std::int64_t steps) const override {
    if (steps < 1 || steps > 1'000'000)
      throw InputError(fmt::format("dct --steps {} must lie in 1..1000000 frames per repetition", steps));
    if (const std::string why = unavailable(); !why.empty()) throw wl::DeviceUnavailable(why);
    return std::make_unique<Run>(kind_, c, steps);
  }

  // The largest rms of log error of each backend's probe-only predictions over held-out random:50
  // sets, with the cpu-mls probe (results/dct-calibration/cpu-2026-11-27, the 2-vCPU VM: cpu-seq
  // 0.112, cpu-par 0.144; results/portability/dct-probe-only-2026-11-27, two runs on a lent H100's
  // host and GPU: cpu-seq 0.104 and 0.326, cpu-par 0.126 and 0.202, cuda pinned frames 0.285 and
  // 0.444, pageable 0.653 and 0.665; results/portability/dct-placements-2026-11-27, one held-out
  // store on a lent H100's host against seven quick probes with the placement-sampled latency
  // probes: cpu-seq 0.147..0.345, cpu-par 0.170..0.316; docs/PERFORMANCE.md, "DCT probe-only with
  // the MLS fields' rate" and "Latency probes on several placements"). cuda: with the gpu-centroid
  // probe and one-copy pageable uploads (results/portability/dct-cuda-centroid-probe-2026-11-27,
  // two lends of an H100, each store against its call's quick probes): pinned frames 0.131, 0.139
  // and 0.190, pageable 0.083 (before those, 0.285-0.444 pinned and 0.653-0.665 pageable). The
  // CPU backends with the window routine, striped counts and a frame's fixed cost
  // (results/portability/dct-passes-2026-11-28): the VM cpu-seq 0.089, cpu-par 0.134; four lends
  // of an H100's host 0.130-0.206 and 0.116-0.248, and a fifth whose quick probe ran in a slow
  // spell of the host, 0.438 and 0.553: the largest.
  std::optional<BasisError> probe_only_error() const override {
    static const std::array<std::pair<std::string_view, double>, 3> measured = {
        {{"cpu-seq", 0.44}, {"cpu-par", 0.55}, {"cuda", 0.19}}};
    for (const auto& [backend, sigma] : measured) {
      if (backend != name()) continue;
      BasisError e;
      e.sigma = sigma;
      e.source = fmt::format("measured error of dct {}'s probe-only predictions on the 2-vCPU VM and lent H100 "
                             "machines (docs/PERFORMANCE.md: DCT CPU: one window routine, striped counts, a frame's "
                             "fixed cost on many threads; DCT cuda probe-only with the gpu-centroid probe)",
                             name());
      return e;
    }
    return std::nullopt;
  }
  // cuda's calibrations carried between a lent H100 and a lent H200 (results/portability/
  // h200-2026-11-28: each machine's fit on its own training set, validated on the other's held-out
  // random:50 against that machine's quick probe): pinned frames 0.190 (H200 -> H100) and 0.340
  // (H100 -> H200), pageable 0.216 and 0.133; the host's matching, a third to a half of a frame,
  // runs at a step cost the two hosts share with no probe (docs/model.md 2.6). Far above RBE's GPU
  // backends (kTransferSigma), so declared. The CPU backends: one measurement each with today's
  // code (the 2-vCPU VM's fits carried to the H200's host, 0.106 and 0.254), left to kTransferSigma.
  std::optional<BasisError> transfer_error() const override {
    if (name() != "cuda") return std::nullopt;
    return BasisError{.sigma = 0.34,
                      .source = "measured error of dct cuda's calibrations carried between a lent H100 and a lent H200 "
                                "(docs/PERFORMANCE.md, \"H200 lend (2026-11-28)\")"};
  }

 private:
  const BackendKind& kind_;
};

// ---- Plans ------------------------------------------------------------------------------------

// A portable generator: the same plan from the same seed with every standard library.
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : s_(seed ^ 0x9E3779B97F4A7C15ULL) {}
  std::uint64_t next() {  // splitmix64
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double real(double lo, double hi) { return lo + (hi - lo) * unit(); }
  std::int64_t whole(std::int64_t lo, std::int64_t hi) {
    return lo + static_cast<std::int64_t>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }

 private:
  std::uint64_t s_;
};

std::string size_text(std::int64_t w, std::int64_t h) { return fmt::format("{}x{}", w, h); }

// The points grid NXxNY nearest to `count` points with the image's aspect.
std::pair<std::int64_t, std::int64_t> grid_for(std::int64_t count, std::int64_t w, std::int64_t h) {
  const double aspect = static_cast<double>(w) / static_cast<double>(h);
  const auto ny = std::max<std::int64_t>(1, std::llround(std::sqrt(static_cast<double>(count) / aspect)));
  const auto nx = std::max<std::int64_t>(1, std::llround(static_cast<double>(count) / static_cast<double>(ny)));
  return {std::min<std::int64_t>(nx, 256), std::min<std::int64_t>(ny, 256)};
}

// The simulated open-hole plate of the seed (7.5.1): 369 dots in a 1100x1100 image, radius 9 px.
json seed_plate() {
  return {{"size", "1100x1100"}, {"dots", 369}, {"radius", 9}, {"points", "32x32"}, {"support", 40}};
}

// Image sizes of real stills and the dots real specimens carried (560..1611), growing with the
// image; the dots' radius grows with the image's side.
struct Still {
  std::int64_t w, h;
};
constexpr Still kStills[] = {{1920, 1080}, {2560, 1920}, {3264, 2448}, {4000, 3000}, {4928, 3264}, {6000, 4000}};

class DctWorkload final : public wl::Workload {
 public:
  DctWorkload() {
    using wl::Kind;
    std::vector<std::string> choices_interp = {"mls", "fe"};
    params_ = {
        {"size", Kind::size2, "frame size WxH (up to 24 MP, e.g. 6000x4000)", "1600x1200", 64, 16384, {}, {}, "px"},
        {"dots", Kind::integer, "dots on the specimen (random, edge-to-edge gap >= their radius)", 400, 6, 20000, {},
         {}, "dots"},
        {"radius", Kind::real, "dot radius in the image", 8, 3, 40, {}, {}, "px"},
        {"points", Kind::size2, "interpolation points, a grid NXxNY over the reference dots (seed: 384..2048)",
         "32x32", 1, 256, {}, {}, ""},
        {"support", Kind::integer, "dots per MLS support domain (seed: 10..100; >= 6 for the quadratic basis; or --support-radius)",
         kDefaultSupport, 6,
         1000, {}, {}, "dots"},
        {"interp", Kind::choice, "field interpolation: mls (moving least squares) or fe (linear triangles)", "mls", 0,
         0, choices_interp, {}, ""},
        {"weight", Kind::choice,
         "MLS weight function (FE: of its gradient recovery): cubic spline, quartic or gaussian (truncated, 0.3 "
         "of the support radius)",
         "cubic", 0, 0, {"cubic", "quartic", "gaussian"}, {}, ""},
        {"threshold", Kind::choice,
         "threshold: otsu (from the frame's histogram), fixed (--threshold-level) or adaptive (the mean of 51x51 px "
         "less 10 grey levels; cpu-seq and cpu-par only)",
         "otsu", 0, 0, {"otsu", "fixed", "adaptive"}, {}, ""},
        {"threshold-level", Kind::real, "grey level of --threshold fixed, 8-bit scale (x257 on 16-bit frames)",
         kDefaultLevel, 1, 254, {}, {}, ""},
        {"support-radius", Kind::real,
         "support domain radius in px, instead of --support dots (0: by dots); the dots per support then follow the "
         "dot density (about dots x pi r^2 / pattern area)",
         0, 0, 16384, {}, {}, "px"},
        {"bits", Kind::choice, "bits per pixel of the frames", "8", 0, 0, {"8", "16"}, {}, ""},
        {"threads", Kind::integer, "CPU threads (0: every hardware thread of the machine that runs it, or of --machine's)", 0, 0, 1024, {},
         {"cpu-par"}, ""},
        {"host-memory", Kind::choice,
         "host memory the frames are uploaded from: pinned (a camera's DMA buffer) or pageable", "pinned", 0, 0,
         {"pinned", "pageable"}, {"cuda"}, ""},
        {"block-pixels", Kind::integer,
         "threads per block of the per-pixel kernels (histogram, threshold and labels, union, compress, ids, "
         "statistics); a multiple of 32",
         kDefaultLayout.block_pixels, 32, 1024, {}, {"cuda"}, ""},
        {"block-points", Kind::integer, "threads per block of the MLS / FE field kernel (MLS: a point a thread; FE: a point a warp); a multiple of 32, at most what the kernel's "
         "registers allow on the GPU (768 on an H100: more is refused before a frame)",
         kDefaultLayout.block_points, 32, 1024, {}, {"cuda"}, ""},
        {"block-dots", Kind::integer,
         "threads per block of the centroid kernel (one block per dot, its window's pixels); a multiple of 32",
         kDefaultLayout.block_dots, 32, 1024, {}, {"cuda"}, ""},
        {"specimen-seed", Kind::integer, "seed of the specimen's dot pattern and sensor noise", 1, 0, 2147483647, {}, {}, ""},
    };
    // Added after stores were measured, each defaulting to what those configurations did: their
    // keys leave them out at the default, so old samples keep their keys.
    for (auto& p : params_)
      if (p.name == "weight" || p.name == "threshold" || p.name == "threshold-level" || p.name == "support-radius" ||
          p.name.rfind("block-", 0) == 0)
        p.keyed_at_default = false;
    // The counts price what tells their values apart (a weight function's FLOPs per support dot,
    // a threshold method's bytes and operations per pixel): one bias serves all values, and the
    // tuner does not split its groups by them (docs/tune.md).
    for (auto& p : params_)
      if (p.name == "weight" || p.name == "threshold") p.priced = true;
    for (const auto& k : backend_kinds()) backends_.push_back(std::make_unique<ContractBackend>(k));
  }

  std::string_view name() const override { return "dct"; }
  std::string_view description() const override {
    return "dot centroid tracking: threshold, labelling, centroids, matching and MLS/FE strain fields of one frame";
  }
  std::string_view step_name() const override { return "frame"; }
  const std::vector<wl::ParamSpec>& params() const override { return params_; }
  const std::vector<std::unique_ptr<wl::Backend>>& backends() const override { return backends_; }

  std::string label(const wl::Config& c) const override {
    const Geometry g = geometry_of(c);
    std::string s = fmt::format("{}x{} {}d r{:g} {}x{}p", g.w, g.h, g.dots, g.radius, g.nx, g.ny);
    s += g.interp == Interp::mls ? " " + support_text(g) : g.support_radius > 0 ? " fe " + support_text(g) : " fe";
    if (g.weight != Weight::cubic_spline) s += " " + to_string(g.weight);
    if (g.threshold == ThresholdMethod::adaptive) s += " adaptive";
    if (g.threshold == ThresholdMethod::fixed) s += fmt::format(" fixed:{:g}", g.level);
    if (g.bytes_per_pixel == 2) s += " 16b";
    if (wl::has(c, "host-memory") && wl::get_text(c, "host-memory") == "pageable") s += " pageable";
    if (const CudaLayout l = layout_of(c); wl::has(c, "block-pixels") &&
        (l.block_pixels != kDefaultLayout.block_pixels || l.block_points != kDefaultLayout.block_points ||
         l.block_dots != kDefaultLayout.block_dots))
      s += fmt::format(" b{}/{}/{}", l.block_pixels, l.block_points, l.block_dots);
    return s;
  }

  std::string describe(const wl::Backend& b, const wl::Config& c) const override {
    const Geometry g = geometry_of(c);
    const std::string support = g.support_radius > 0 ? fmt::format(", support radius {:g} px", g.support_radius)
                                : g.interp == Interp::mls ? fmt::format(", {} dots per support", g.support)
                                                          : std::string();
    const std::string weight = g.weight == Weight::cubic_spline ? "" : fmt::format(", {} weight", to_string(g.weight));
    const std::string threshold = g.threshold == ThresholdMethod::otsu ? ""
                                  : g.threshold == ThresholdMethod::adaptive
                                      ? ", adaptive threshold"
                                      : fmt::format(", threshold {:g}", g.level);
    return fmt::format("one {}x{} {}-bit frame of {} dots (radius {:g} px) to {} {} at {}x{} points{}{}{} on {}", g.w,
                       g.h, 8 * g.bytes_per_pixel, g.dots, g.radius, g.interp == Interp::mls ? "MLS" : "FE",
                       "strain fields", g.nx, g.ny, support, weight, threshold, b.name());
  }

  std::vector<std::pair<std::string, std::string>> plan_names() const override {
    return {
        {"seed-support", "the seed's open-hole plate (369 dots, 1024 points, 1100x1100) with 10, 20, ..., 100 dots "
                         "per support domain (10 configurations)"},
        {"seed-points", "the seed's plate with 40 dots per support and 384..2048 points (8 grids)"},
        {"image-sizes", "stills of 2 to 24 MP (1920x1080 .. 6000x4000) with 560..1611 dots growing with the image, "
                        "2048 points, 60 dots per support (6 configurations)"},
        {"image-kinds", "the stills of image-sizes as 16-bit frames (MLS), and as 8-bit and 16-bit frames with few "
                        "dots (150) and FE (18 configurations)"},
    };
  }

  wl::PlanConfigs plan(const std::string& spec, const wl::Backend& b, std::uint64_t seed) const override {
    wl::PlanConfigs p;
    p.name = spec;
    std::vector<json> given;
    if (spec == "seed-support") {
      p.description = plan_names()[0].second;
      for (int s = 10; s <= 100; s += 10) {
        json c = seed_plate();
        c["support"] = s;
        given.push_back(c);
      }
    } else if (spec == "seed-points") {
      p.description = plan_names()[1].second;
      constexpr std::array<std::array<int, 2>, 8> grids = {
          {{24, 16}, {32, 16}, {32, 24}, {32, 32}, {40, 32}, {48, 32}, {56, 32}, {64, 32}}};
      for (const auto& [nx, ny] : grids) {
        json c = seed_plate();
        c["points"] = size_text(nx, ny);
        given.push_back(c);
      }
    } else if (spec == "image-sizes") {
      p.description = plan_names()[2].second;
      const double mp0 = 1920.0 * 1080, mp1 = 6000.0 * 4000;
      for (const Still& s : kStills) {
        const double f = (static_cast<double>(s.w * s.h) - mp0) / (mp1 - mp0);
        given.push_back({{"size", size_text(s.w, s.h)},
                         {"dots", std::llround(560 + f * (1611 - 560))},
                         {"radius", std::round(10 + f * 14)},
                         {"points", "64x32"},
                         {"support", 60}});
      }
    } else if (spec == "image-kinds") {
      // What the other named plans leave out and random plans draw: 16-bit frames, and large
      // frames whose time is their pixels (few dots) with FE's fields.
      p.description = plan_names()[3].second;
      const double mp0 = 1920.0 * 1080, mp1 = 6000.0 * 4000;
      for (const Still& s : kStills) {
        const double f = (static_cast<double>(s.w * s.h) - mp0) / (mp1 - mp0);
        const double radius = std::round(10 + f * 14);
        given.push_back({{"size", size_text(s.w, s.h)},
                         {"dots", std::llround(560 + f * (1611 - 560))},
                         {"radius", radius},
                         {"points", "64x32"},
                         {"support", 60},
                         {"bits", "16"}});
        for (const char* bits : {"8", "16"})
          given.push_back({{"size", size_text(s.w, s.h)},
                           {"dots", 150},
                           {"radius", radius},
                           {"points", "32x32"},
                           {"support", 40},
                           {"interp", "fe"},
                           {"bits", bits}});
      }
    } else if (spec.rfind("random:", 0) == 0) {
      const std::int64_t n = random_plan_size(spec);
      p.description = fmt::format(
          "{} configurations drawn from seed {}: 0.3..24 MP (aspect 1..1.8), 100..1611 dots of radius 4..24 px "
          "(fewer or smaller where the image cannot hold them), 384..2048 points, 10..100 dots per support, "
          "mls (3 in 4) or fe, 8-bit (3 in 4) or 16-bit{}",
          n, seed, b.name() == "cuda" ? ", pinned or pageable frames" : "");
      Draw d(seed);
      for (std::int64_t i = 0; i < n; ++i) given.push_back(draw(d, b));
    } else {
      return plan_from_file(spec, b);
    }
    for (std::size_t i = 0; i < given.size(); ++i) {
      try {
        p.configs.push_back(validate(given[i], b));
      } catch (const InputError& e) {
        throw std::logic_error(fmt::format("dct plan {} configuration {} is invalid (a workload bug): {}", spec, i,
                                           e.what()));
      }
    }
    return p;
  }

  wl::ProtocolDefaults defaults(const wl::Backend& b) const override {
    // A CPU frame takes milliseconds (0.3 MP) to a second (24 MP at one thread): 2 frames a
    // repetition. The device's frames take ~1-10 ms: 10 frames a repetition.
    if (b.needs_gpu()) return {10, 7, 2};
    return {2, 5, 1};
  }

 protected:
  void check(const wl::Config& c, const wl::Backend& b) const override {
    const Geometry g = geometry_of(c);
    const double pixels = static_cast<double>(g.w) * static_cast<double>(g.h);
    if (pixels > kMaxPixels)
      throw InputError(fmt::format("dct --size {}x{} holds {:.1f} MP, more than the 24 MP of the seed's stills; give "
                                   "a smaller image (e.g. 6000x4000)",
                                   g.w, g.h, pixels / 1e6));
    const std::int64_t need = host_bytes(c, b.name()), have = physical_memory();
    if (have > 0 && need > have / 2)
      throw InputError(fmt::format("dct --size {}x{} needs about {:.1f} GB of host memory, more than half of this "
                                   "machine's {:.1f} GB; give a smaller image",
                                   g.w, g.h, static_cast<double>(need) / 1e9, static_cast<double>(have) / 1e9));
    if (pattern_area(g.w, g.h, g.radius) <= 0)
      throw InputError(fmt::format("dct --size {}x{} leaves no room for dots of radius {:g} px (they keep {:g} px from "
                                   "the edge); give a larger image or a smaller --radius",
                                   g.w, g.h, g.radius, inset(g.radius)));
    const std::int64_t cap = capacity(g.w, g.h, g.radius);
    if (g.dots > cap)
      throw InputError(fmt::format("dct --dots {} of radius {:g} px is an image the plan cannot hold: a {}x{} image "
                                   "holds at most {} such dots (centres >= {:g} px apart); give fewer dots, a smaller "
                                   "--radius or a larger --size",
                                   g.dots, g.radius, g.w, g.h, cap, 3 * g.radius));
    if (g.nx * g.ny > kMaxPoints)
      throw InputError(fmt::format("dct --points {}x{} asks for {} points, more than {}; give a coarser grid", g.nx,
                                   g.ny, g.nx * g.ny, kMaxPoints));
    if (g.support_radius > 0 && g.support != kDefaultSupport)
      throw InputError(fmt::format("dct --support {} and --support-radius {:g} both set the support domain; give one "
                                   "(--support-radius replaces --support, which then stays at its default {})",
                                   g.support, g.support_radius, kDefaultSupport));
    if (g.support_radius > 0 && g.support_radius < g.radius)
      throw InputError(fmt::format("dct --support-radius {:g} px is smaller than the dots (radius {:g} px); give a "
                                   "support radius of several dot spacings, or 0 for --support dots",
                                   g.support_radius, g.radius));
    if (g.support_radius == 0 && g.interp == Interp::mls && g.support > g.dots)
      throw InputError(fmt::format("dct --support {} asks for more dots per support domain than the {} dots; give "
                                   "--support <= --dots",
                                   g.support, g.dots));
    if (g.threshold != ThresholdMethod::fixed && g.level != kDefaultLevel)
      throw InputError(fmt::format("dct --threshold-level {:g} applies to --threshold fixed only, not {}; drop it or "
                                   "give --threshold fixed",
                                   g.level, to_string(g.threshold)));
    if (b.name() == "cuda" && g.threshold == ThresholdMethod::adaptive)
      throw InputError("dct --threshold adaptive runs on cpu-seq and cpu-par only; the cuda backend thresholds with "
                       "otsu or fixed: give one of those, or a CPU backend");
    if (wl::has(c, "block-pixels")) {
      const CudaLayout l = layout_of(c);
      for (const auto& [name, v] : {std::pair<const char*, int>{"block-pixels", l.block_pixels},
                                    {"block-points", l.block_points},
                                    {"block-dots", l.block_dots}})
        if (v % 32 != 0)
          throw InputError(fmt::format("dct --{} {} is not a multiple of 32 (a warp); give one of 32, 64, ..., 1024",
                                       name, v));
    }
  }

 private:
  // One random configuration for `b`, within every plan's ranges and the constraints.
  json draw(Draw& d, const wl::Backend& b) const {
    const double mp = std::exp(d.real(std::log(0.3e6), std::log(kMaxPixels)));
    const double aspect = d.real(1.0, 1.8);
    auto even = [](double x) { return 2 * std::max<std::int64_t>(32, std::llround(x / 2)); };
    std::int64_t w = even(std::sqrt(mp * aspect)), h = even(std::sqrt(mp / aspect));
    while (static_cast<double>(w) * static_cast<double>(h) > kMaxPixels) w -= 2;
    std::int64_t dots = d.whole(100, 1611);
    double radius = std::round(d.real(4, 24) * 2) / 2;
    while (radius > 4 && capacity(w, h, radius) < dots) radius -= 0.5;
    dots = std::min(dots, capacity(w, h, radius));
    const auto [nx, ny] = grid_for(d.whole(384, 2048), w, h);
    const bool mls = d.unit() < 0.75;
    json c = {{"size", size_text(w, h)},
              {"dots", dots},
              {"radius", radius},
              {"points", size_text(nx, ny)},
              {"support", std::min<std::int64_t>(d.whole(10, 100), dots)},
              {"interp", mls ? "mls" : "fe"},
              {"bits", d.unit() < 0.75 ? "8" : "16"},
              {"specimen-seed", d.whole(1, 1'000'000)}};
    if (b.name() == "cuda") c["host-memory"] = d.unit() < 0.5 ? "pinned" : "pageable";
    return c;
  }

  std::vector<wl::ParamSpec> params_;
  std::vector<std::unique_ptr<wl::Backend>> backends_;
};

}  // namespace

const wl::Workload& workload() {
  static const DctWorkload w;
  return w;
}

// ---- What a configuration means ----------------------------------------------------------

PipelineOptions pipeline_options(const wl::Config& c, const std::string& backend) {
  const Geometry g = geometry_of(c);
  PipelineOptions o;
  o.interp = g.interp;
  o.mls.weight = g.weight;
  if (g.support_radius > 0) {
    o.mls.support.kind = Support::Kind::radius;
    o.mls.support.radius = g.support_radius;
  } else {
    o.mls.support.kind = Support::Kind::dots;
    o.mls.support.dots = static_cast<int>(g.support);
  }
  o.analysis.method = g.threshold;
  o.analysis.threshold = g.level;
  o.layout = layout_of(c);
  o.points_x = static_cast<int>(g.nx);
  o.points_y = static_cast<int>(g.ny);
  o.threads = backend == "cpu-par" ? static_cast<int>(wl::get_int(c, "threads")) : 1;
  o.pinned_frames = !wl::has(c, "host-memory") || wl::get_text(c, "host-memory") == "pinned";
  return o;
}

Specimen specimen_of(const wl::Config& c) {
  const Geometry g = geometry_of(c);
  const auto seed = static_cast<std::uint64_t>(wl::get_int(c, "specimen-seed"));
  Specimen s;
  s.render.width = static_cast<int>(g.w);
  s.render.height = static_cast<int>(g.h);
  s.render.bit_depth = 8 * g.bytes_per_pixel;
  s.render.noise_sigma = 1;  // a grey level of sensor noise
  s.render.supersample = 4;  // 16 samples per edge pixel: the timing does not need 1e-3 px truth
  s.render.seed = seed;
  validate(s.render);
  const Vec2 centre{0.5 * static_cast<double>(g.w - 1), 0.5 * static_cast<double>(g.h - 1)};
  s.deformation = make_uniform(centre, kStrain, -0.3 * kStrain);
  const double e = inset(g.radius);
  const PatternArea area{e, e, static_cast<double>(g.w) - 1 - e, static_cast<double>(g.h) - 1 - e, {}, 0};
  s.dots = random_pattern(area, g.radius, g.radius, static_cast<int>(g.dots), seed);
  return s;
}

FrameShape estimated_shape(const wl::Config& c) {
  const Geometry g = geometry_of(c);
  FrameShape s = estimate_shape(g.w, g.h, g.bytes_per_pixel, g.dots, g.radius, g.nx * g.ny,
                                g.support_radius > 0 ? 0 : g.support, g.interp);
  if (g.support_radius > 0) {
    // The points spread over the dots' bounding box, which is about the area the dots are
    // thrown into (specimen_of): the expected dots within the radius of each, from the density.
    const double e = inset(g.radius);
    const double x0 = e, y0 = e, x1 = static_cast<double>(g.w) - 1 - e, y1 = static_cast<double>(g.h) - 1 - e;
    if (g.interp == Interp::fe && g.nx >= 3 && g.ny >= 3) {
      // FE: two triangles per dot within the radius, at the grid's inner points (its outer ring
      // lies outside the dots' hull and reads none; counts.cpp, estimate_shape).
      const double density = static_cast<double>(g.dots) / ((x1 - x0) * (y1 - y0));
      double sum = 0;
      for (std::int64_t j = 1; j + 1 < g.ny; ++j)
        for (std::int64_t i = 1; i + 1 < g.nx; ++i) {
          const double x = x0 + (x1 - x0) * static_cast<double>(i) / static_cast<double>(g.nx - 1);
          const double y = y0 + (y1 - y0) * static_cast<double>(j) / static_cast<double>(g.ny - 1);
          sum += std::min(static_cast<double>(g.dots), density * disc_area_inside(x, y, g.support_radius, x0, y0, x1, y1));
        }
      s.support_entries = 2 * std::llround(sum);
    } else {
      s.support_entries = expected_entries_within(g.support_radius, x0, y0, x1, y1, g.nx, g.ny, g.dots);
    }
  }
  s.weight = g.weight;
  s.otsu = g.threshold == ThresholdMethod::otsu;
  s.adaptive = g.threshold == ThresholdMethod::adaptive;
  return s;
}

std::int64_t host_bytes(const wl::Config& c, const std::string& backend) {
  const Geometry g = geometry_of(c);
  const std::int64_t px = g.w * g.h;
  // Rendering: three float planes (dot and hole coverage, the image); frames: reference,
  // deformed [and its pinned copy]; analysis: mask (1 byte) and labels (4 bytes).
  const std::int64_t frames = (backend == "cuda" ? 3 : 2) * g.bytes_per_pixel;
  return px * (12 + frames + 1 + 4);
}

FrameShape declared_shape(const Backend& pipeline, const cv::Mat& frame) {
  const PipelineOptions& o = pipeline.options();
  const AnalysisResult a = analyze(frame, o.analysis, 1);
  AnalysisStats stats = a.stats;
  // The cuda backend does not classify by scanning: it reports no scanned pixels.
  if (pipeline.name() == "cuda") stats.scanned_pixels = 0;
  // Every dot of the frame matched in the first pass (the specimen's deformation is small).
  return pipeline.frame_shape(frame, stats,
                              match_work(static_cast<std::int64_t>(pipeline.reference_positions().size()),
                                         static_cast<std::int64_t>(a.dots.size())));
}

namespace {
void differ(std::string& out, std::string_view what, std::int64_t declared, std::int64_t measured) {
  if (declared == measured) return;
  out += fmt::format("{}{} {} (declared {})", out.empty() ? "" : ", ", what, measured, declared);
}
}  // namespace

std::string shape_difference(const FrameShape& d, const FrameShape& m) {
  std::string out;
  differ(out, "image pixels", d.image_pixels, m.image_pixels);
  differ(out, "bytes per pixel", d.bytes_per_pixel, m.bytes_per_pixel);
  differ(out, "analysed pixels", d.roi_pixels, m.roi_pixels);
  // The CPU backends do not report the foreground (their counts do not use it).
  if (m.foreground_pixels != 0) differ(out, "foreground pixels", d.foreground_pixels, m.foreground_pixels);
  differ(out, "components", d.components, m.components);
  differ(out, "dots", d.dots, m.dots);
  differ(out, "window pixels", d.window_pixels, m.window_pixels);
  differ(out, "ring pixels", d.ring_pixels, m.ring_pixels);
  differ(out, "weighted pixels", d.weighted_pixels, m.weighted_pixels);
  differ(out, "scanned pixels", d.scanned_pixels, m.scanned_pixels);
  differ(out, "margin", d.margin, m.margin);
  differ(out, "points", d.points, m.points);
  differ(out, "support entries", d.support_entries, m.support_entries);
  differ(out, "k-d tree steps", d.tree_steps, m.tree_steps);
  differ(out, "grid matching steps", d.match_steps, m.match_steps);
  if (d.interp != m.interp) out += fmt::format("{}interp {} (declared {})", out.empty() ? "" : ", ", to_string(m.interp), to_string(d.interp));
  if (d.otsu != m.otsu) out += fmt::format("{}otsu {} (declared {})", out.empty() ? "" : ", ", m.otsu, d.otsu);
  if (d.adaptive != m.adaptive)
    out += fmt::format("{}adaptive {} (declared {})", out.empty() ? "" : ", ", m.adaptive, d.adaptive);
  if (d.weight != m.weight)
    out += fmt::format("{}weight {} (declared {})", out.empty() ? "" : ", ", to_string(m.weight), to_string(d.weight));
  return out;
}

std::string counts_difference(const CostCounts& d, const CostCounts& m) {
  std::string out;
  differ(out, "P", d.P, m.P);
  for (const CountField& f : count_fields()) differ(out, f.name, d.*f.member, m.*f.member);
  differ(out, "cpu_threads", d.cpu_threads, m.cpu_threads);
  if (d.precision != m.precision)
    out += fmt::format("{}precision {} (declared {})", out.empty() ? "" : ", ", to_string(m.precision), to_string(d.precision));
  if (d.host_memory != m.host_memory)
    out += fmt::format("{}host memory {} (declared {})", out.empty() ? "" : ", ", to_string(m.host_memory),
                       to_string(d.host_memory));
  if (d.copies_GC != m.copies_GC) out += fmt::format("{}device->host copy sizes", out.empty() ? "" : ", ");
  if (out.empty() && !(d == m)) out = "other counts";
  return out;
}

}  // namespace dtflop::dct
