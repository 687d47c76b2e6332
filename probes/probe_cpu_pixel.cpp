// Host scalar pixel work (L_pixel, L_pixel_all; by kind L_label, L_hist, L_scan and their _all):
// what one step of the DCT CPU backends' image analysis costs on this machine, the work done pixel
// by pixel and branch by branch (a histogram's count, a pixel labelled, a window pixel classified,
// a label of its neighbourhood read) that no FLOP rate or bandwidth prices. The probe runs that
// analysis' own steps on a frame of dark discs, with the libraries the workload uses: a 256-bin
// histogram (one step a pixel), OpenCV's threshold and 8-connected labelling with statistics (one
// step a pixel), and each component's window through the backends' own routine
// (kernels::centroid_window: every window pixel classified, every background one reading the labels
// of its 5 x 5 neighbourhood, the ring's plane and the weighted centroid; one step a window pixel
// and one a label read): the steps the workload counts as pixel_steps (docs/model.md 2.6). The
// time of a pass over its steps gives L_pixel on one thread (cpu-seq: the median over several
// placements of the thread, probes/placements.hpp), and L_pixel_all on every usable CPU
// (cpu-par: OpenCV's threads for the histogram, the threshold and the labelling, the windows
// split between them). The pass's labelling, its histogram (a step a pixel each) and its
// windows' steps are timed apart too: L_label, L_hist, L_scan.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "kernels/dot_centroid.hpp"
#include "kernels/histogram.hpp"
#include "model/stats.hpp"
#include "probes/measure.hpp"
#include "probes/opencv_threads.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

constexpr int kSide = 1024;    // frame side, px: a 1 MP frame, its labels (4 MiB) beyond the L2
constexpr int kSmallSide = 512;  // the second frame of the all-thread passes (a quarter of the pixels and discs)
constexpr int kPitch = 51;     // px between disc centres (20 a row on the 1 MP frame: 400 discs)
constexpr int kRadius = 8;     // their radius, px
constexpr int kMargin = 2;     // the neighbourhood's half-width: 5 x 5 labels
constexpr int kGrow = kMargin + kernels::kRingWidth;  // a window: a disc's box grown by the margin and the ring

struct Frame {
  int side = 0;   // px, square
  int discs = 0;  // labelled discs
  std::vector<std::uint8_t> image;
};

// Discs on a jittered grid (they never touch: 38 px apart or more, 17 px across), a noisy background.
Frame make_frame(int side) {
  Frame f;
  f.side = side;
  const int per_row = side / kPitch;
  f.discs = per_row * per_row;
  f.image.resize(static_cast<std::size_t>(side) * side);
  std::mt19937_64 rng(20261124);
  std::uniform_int_distribution<int> grey(180, 220), jitter(-6, 6);
  for (auto& v : f.image) v = static_cast<std::uint8_t>(grey(rng));
  const int pitch = side / per_row;
  for (int k = 0; k < f.discs; ++k) {
    const int cx = (k % per_row) * pitch + pitch / 2 + jitter(rng), cy = (k / per_row) * pitch + pitch / 2 + jitter(rng);
    for (int y = cy - kRadius; y <= cy + kRadius; ++y)
      for (int x = cx - kRadius; x <= cx + kRadius; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= kRadius * kRadius)
          f.image[static_cast<std::size_t>(y) * side + x] = 40;
  }
  return f;
}

struct Steps {
  std::int64_t steps = 0;     // pixels visited + labels read
  std::int64_t counted = 0;   // histogram total
  std::int64_t components = 0;  // components the labelling found (background apart)
  std::int64_t bad_area = 0;    // of them, with another area than a disc's
  std::int64_t window = 0, ring = 0;  // window pixels classified, and of them ring (the background's)
  std::int64_t off_centre = 0;  // dots not kept, or whose centroid is 0.5 px or more off their disc's centre
  double hist_seconds = 0;      // of the pass, the histogram (a step a pixel)
  double label_seconds = 0;     // of the pass, the threshold and the labelling (a step a pixel)
};

// Buffers kept across passes, as the workload keeps its mask and labels across frames.
struct Buffers {
  cv::Mat mask, labels, stats, centroids;
};

// The pixels of one disc: its area, which every component the labelling finds must have.
std::int64_t disc_area() {
  std::int64_t n = 0;
  for (int y = -kRadius; y <= kRadius; ++y)
    for (int x = -kRadius; x <= kRadius; ++x) n += x * x + y * y <= kRadius * kRadius;
  return n;
}

// One repetition on `threads` threads: the histogram, the threshold and the labelling, then every
// component's window classified as the workload does.
Steps pass(const Frame& f, Buffers& b, int threads) {
  OpenCvThreads scope(threads);
  Steps s;
  const auto h0 = std::chrono::steady_clock::now();
  // The backends' own count: a stripe of rows a thread (one on one thread).
  const auto stripes = [threads](int n, const auto& body) {
    if (threads <= 1) {
      for (int k = 0; k < n; ++k) body(k);
      return;
    }
    cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) { for (int k = r.start; k < r.end; ++k) body(k); }, n);
  };
  const auto hist = kernels::count_rows(f.image.data(), static_cast<std::size_t>(f.side), f.side, f.side, threads, stripes);
  s.hist_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - h0).count();
  for (std::int64_t h : hist) s.counted += h;
  const cv::Mat image(f.side, f.side, CV_8U, const_cast<std::uint8_t*>(f.image.data()));
  const auto t0 = std::chrono::steady_clock::now();
  cv::threshold(image, b.mask, 128, 255, cv::THRESH_BINARY_INV);  // the discs (40) are dark on 180..220
  const int n = cv::connectedComponentsWithStats(b.mask, b.labels, b.stats, b.centroids, 8, CV_32S, cv::CCL_DEFAULT);
  s.label_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.steps += 2 * static_cast<std::int64_t>(f.image.size());  // a histogram step and a labelling step a pixel
  s.components = n - 1;
  const std::int64_t area = disc_area();
  std::vector<Steps> each(static_cast<std::size_t>(std::max(0, n - 1)));
  // Every component's window through the workload's own routine (kernels::centroid_window): the
  // classification with its label scans, the ring's plane and the weighted centroid.
  auto classify = [&](const cv::Range& range) {
    for (int id = range.start; id < range.end; ++id) {
      Steps& e = each[static_cast<std::size_t>(id - 1)];
      if (b.stats.at<int>(id, cv::CC_STAT_AREA) != area) ++e.bad_area;
      const int bx = b.stats.at<int>(id, cv::CC_STAT_LEFT), by = b.stats.at<int>(id, cv::CC_STAT_TOP);
      const int bw = b.stats.at<int>(id, cv::CC_STAT_WIDTH), bh = b.stats.at<int>(id, cv::CC_STAT_HEIGHT);
      const kernels::WindowCentroid c =
          kernels::centroid_window(f.image.data(), static_cast<std::size_t>(f.side), b.labels.ptr<int>(0),
                                   b.labels.step1(), f.side, f.side, id, bx, by, bw, bh, kMargin, true);
      e.steps += c.window + (2 * kMargin + 1) * (2 * kMargin + 1) * c.scanned;  // as the workload counts them
      e.window += c.window;
      e.ring += c.ring;
      // A disc is symmetric about its box's centre, and its centroid there within a fraction of a pixel.
      const double dx = c.x - (bx + 0.5 * (bw - 1)), dy = c.y - (by + 0.5 * (bh - 1));
      e.off_centre += !c.kept || std::abs(dx) >= 0.5 || std::abs(dy) >= 0.5;
    }
  };
  if (threads > 1) cv::parallel_for_(cv::Range(1, n), classify);
  else classify(cv::Range(1, n));
  for (const Steps& e : each) {
    s.steps += e.steps;
    s.bad_area += e.bad_area;
    s.window += e.window;
    s.ring += e.ring;
    s.off_centre += e.off_centre;
  }
  return s;
}

// A pass's time a step, and apart: its labelling's a labelled pixel (OpenCV's threshold and
// 8-connected labelling), its histogram's a count, and the rest's a step (the windows' scans).
struct Passes {
  std::vector<double> per_step, per_label, per_hist, per_scan;
  std::vector<double> label_seconds, hist_seconds, scan_seconds;  // each pass's, whole
  double pixels = 0, scan_steps = 0;                              // a pass's labelled pixels and scan steps
};

// The time of a pass a step on `threads` threads: `reps` timed passes after an untimed one, each
// checked; `steps` is a pass's step count.
Passes time_passes(const Frame& f, int reps, int threads, std::int64_t& steps) {
  const std::int64_t window = static_cast<std::int64_t>(f.discs) * (2 * (kRadius + kGrow) + 1) * (2 * (kRadius + kGrow) + 1);
  Buffers b;
  Passes out;
  for (int k = -1; k < reps; ++k) {  // k = -1: warm-up, untimed
    const auto t0 = std::chrono::steady_clock::now();
    const Steps s = pass(f, b, threads);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The loops ran: every pixel counted once, every disc labelled whole and apart, every window
    // pixel classified once, some of them as ring (the background plane's pixels), and every
    // disc's centroid at its centre.
    if (s.counted != static_cast<std::int64_t>(f.image.size()) || s.components != f.discs || s.bad_area != 0 ||
        s.window != window || s.ring == 0 || s.off_centre != 0)
      throw ValidationError(fmt::format(
          "the pixel loops counted {} of {} pixels, labelled {} of {} discs ({} of another area), classified {} of "
          "{} window pixels ({} ring) and put {} centroids off their disc's centre",
          s.counted, f.image.size(), s.components, f.discs, s.bad_area, s.window, window, s.ring, s.off_centre));
    steps = s.steps;
    if (k >= 0) {
      const auto pixels = static_cast<double>(f.image.size());
      out.per_step.push_back(t / static_cast<double>(s.steps));
      out.per_label.push_back(s.label_seconds / pixels);
      out.per_hist.push_back(s.hist_seconds / pixels);
      out.per_scan.push_back((t - s.label_seconds - s.hist_seconds) / (static_cast<double>(s.steps) - 2 * pixels));
      out.label_seconds.push_back(s.label_seconds);
      out.hist_seconds.push_back(s.hist_seconds);
      out.scan_seconds.push_back(t - s.label_seconds - s.hist_seconds);
      out.pixels = pixels;
      out.scan_steps = static_cast<double>(s.steps) - 2 * pixels;
    }
  }
  return out;
}

// The kinds of step apart: L_label, L_hist, L_scan (and _all). A labelling costs several times a
// histogram's count or a window scan's step, so L_pixel, their average on this frame, is low for
// frames whose pixel work is more labelling than the probe's and high for those with more windows;
// the model prices the kinds apart where the profile has the three (docs/model.md 2.6).
struct Kind {
  const char* key;
  Param one, all;
  const char* label;
  const char* what;
  std::vector<double> Passes::*seconds;  // per step
};
constexpr Kind kKinds[] = {
    {"label", Param::L_label, Param::L_label_all, "a labelled pixel",
     "OpenCV's threshold and 8-connected labelling with statistics a pixel", &Passes::per_label},
    {"hist", Param::L_hist, Param::L_hist_all, "a histogram's count",
     "the 256-bin histogram a pixel (a stripe of rows a thread, as the workload counts it)", &Passes::per_hist},
    {"scan", Param::L_scan, Param::L_scan_all, "a window-scan step",
     "the rest a step: the windows' pixels and the labels their scans read", &Passes::per_scan}};

void add_kinds(ProbeReport& r, bool all_threads, const Passes& per_placement_or_pass, const std::string& how) {
  for (const Kind& kind : kKinds)
    r.measurements.push_back(time_measurement(
        fmt::format("{}{}", kind.key, all_threads ? "_all" : ""),
        fmt::format("{} ({})", kind.label, all_threads ? "all threads" : "one thread"),
        per_placement_or_pass.*kind.seconds, all_threads ? kind.all : kind.one,
        fmt::format("of the pass, {}; {}", kind.what, how)));
}

std::string what(const Frame& f, std::int64_t steps) {
  return fmt::format("a 256-bin histogram of a {0}x{0} 8-bit frame, OpenCV's threshold and 8-connected labelling with "
                     "statistics, and the classification of {1} discs' windows (5x5 label scans), {2} steps "
                     "(docs/model.md 2.6)",
                     f.side, f.discs, steps);
}

// On several threads a pass costs a fixed part (threads woken, the histogram's and the labelling's
// stripes merged, OpenCV's parallel labelling set up) beside its steps, which one frame size cannot
// tell from them: a small frame of many dots would be predicted too fast, a large one too slow. So
// the all-thread passes run on two frames, the second a quarter of the first (its pixels and discs),
// and each kind's figure is the slope of its line through the passes of both (fit_kinds: its steps
// against its seconds, every pass a point); L_pass_all is the passes' time at no pixels and no discs,
// the kinds' intercepts added. Where that comes out below a tenth of the small frame's pass (on the
// 2-vCPU VM it is zero within the noise, tens of microseconds either way), or a line was clamped at
// zero, the large frame's averages stand alone (no L_pass_all): a slope between two noisy sizes is
// noisier than an average, and worth it only where the fixed part is there to be found.
std::optional<KindsFit> fixed_and_slopes(const Passes& large, const Passes& small) {
  std::vector<std::vector<TransferPoint>> kinds(3);
  for (const Passes* p : {&large, &small})
    for (std::size_t i = 0; i < p->label_seconds.size(); ++i) {
      kinds[0].push_back({p->pixels, p->label_seconds[i]});
      kinds[1].push_back({p->pixels, p->hist_seconds[i]});
      kinds[2].push_back({p->scan_steps, p->scan_seconds[i]});
    }
  KindsFit f;
  try {
    f = fit_kinds(kinds);
  } catch (const std::invalid_argument&) {  // too few passes (the smoke plan's), or a time of zero
    return std::nullopt;
  }
  std::vector<double> small_pass;
  for (std::size_t i = 0; i < small.label_seconds.size(); ++i)
    small_pass.push_back(small.label_seconds[i] + small.hist_seconds[i] + small.scan_seconds[i]);
  const bool clamped = std::any_of(f.kinds.begin(), f.kinds.end(), [](const PerEventFit& k) { return k.fixed_clamped; });
  if (clamped || !(f.fixed >= 0.1 * summarize(small_pass).median)) return std::nullopt;
  return f;
}

// L_pixel: one thread, the median over placements (probes/placements.hpp) of each one's median;
// `kinds` gets each placement's median of each kind of step.
Measurement measure_one(const Frame& f, int reps, Effort effort, Passes& kinds) {
  std::int64_t steps = 0;
  const Placed placed = on_placements(latency_placements(effort), [&] {
    const Passes p = time_passes(f, reps, 1, steps);
    kinds.per_label.push_back(summarize(p.per_label).median);
    kinds.per_hist.push_back(summarize(p.per_hist).median);
    kinds.per_scan.push_back(summarize(p.per_scan).median);
    return summarize(p.per_step).median;
  });
  return time_measurement("pixel", "one step of the image analysis' pixel work (one thread)", placed.values,
                          Param::L_pixel,
                          fmt::format("{} on one thread; time / steps, the median over {} of the median of {} each",
                                      what(f, steps), describe_placements(placed.cpus), reps));
}

// L_pixel_all: every usable CPU, the median of the passes.
Measurement measure_all(const Frame& f, int reps, int threads, Passes& passes) {
  std::int64_t steps = 0;
  passes = time_passes(f, reps, threads, steps);
  return time_measurement("pixel_all", fmt::format("one step of the image analysis' pixel work ({} threads)", threads),
                          passes.per_step, Param::L_pixel_all,
                          fmt::format("{} on {} threads; time / steps, median of {}", what(f, steps), threads, reps));
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 11 : o.effort == Effort::quick ? 5 : 2;
  const Frame f = make_frame(kSide);
  Passes kinds;
  r.measurements.push_back(measure_one(f, reps, o.effort, kinds));
  const Stats one = r.measurements[0].stats;  // a copy: the next push_back may move it
  add_kinds(r, false, kinds, "the median over the placements of each one's median");
  std::string all;
  if (const int threads = usable_cpus(); threads > 1) {
    const int all_reps = o.effort == Effort::full ? 31 : o.effort == Effort::quick ? 11 : 3;
    Passes passes;
    r.measurements.push_back(measure_all(f, all_reps, threads, passes));
    all = fmt::format(", {:.2f} ns on {} threads", r.measurements.back().value * 1e9, threads);
    const Frame small = make_frame(kSmallSide);
    std::int64_t small_steps = 0;
    const Passes small_passes = time_passes(small, all_reps, threads, small_steps);
    if (const auto lines = fixed_and_slopes(passes, small_passes)) {
      const std::string how = fmt::format("{} threads, the slope of a line through {} passes of the {}x{} frame and "
                                          "{} of a {}x{} frame of {} discs",
                                          threads, all_reps, kSide, kSide, all_reps, kSmallSide, kSmallSide, small.discs);
      for (std::size_t k = 0; k < std::size(kKinds); ++k)
        r.measurements.push_back(per_event_measurement(
            fmt::format("{}_all", kKinds[k].key), fmt::format("{} (all threads)", kKinds[k].label), lines->kinds[k],
            passes.*kKinds[k].seconds, kKinds[k].all, fmt::format("of the pass, {}; {}", kKinds[k].what, how)));
      Measurement fixed;
      fixed.key = "pass_all";
      fixed.label = fmt::format("a frame's passes' fixed cost ({} threads)", threads);
      fixed.unit = "s";
      fixed.value = lines->fixed;
      fixed.uncertainty = lines->fixed_hw95;
      fixed.param = Param::L_pass_all;
      fixed.note = fmt::format("the passes' time at no pixels and no discs: the intercepts of the kinds' lines added; {}", how);
      r.measurements.push_back(std::move(fixed));
      all += fmt::format(" (a frame's passes {:.1f} us beside their steps)", lines->fixed * 1e6);
    } else {
      add_kinds(r, true, passes,
                fmt::format("{} threads, median of the passes (the passes of a {}x{} frame beside them gave no fixed "
                            "cost of a tenth of its pass or more: the large frame's averages)",
                            threads, kSmallSide, kSmallSide));
    }
  }
  o.say(fmt::format("  pixel step: {:.2f} ns on one thread (placements {:.2f} .. {:.2f} ns){}; by kind, a labelled "
                    "pixel {:.2f} ns, a histogram's count {:.2f} ns, a window-scan step {:.2f} ns",
                    one.median * 1e9, one.min * 1e9, one.max * 1e9, all, summarize(kinds.per_label).median * 1e9,
                    summarize(kinds.per_hist).median * 1e9, summarize(kinds.per_scan).median * 1e9));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_pixel) {
  registry.add({"cpu-pixel",
                "host scalar pixel work: one step of the image analysis' histogram, labelling or window label scans, "
                "and each kind apart (one thread and all), with a frame's fixed cost on all threads",
                false, 28, dtflop::probes::run});
}
