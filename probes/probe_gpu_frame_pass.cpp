// L_GF: one pixel of a device pass over a whole frame, a thread a pixel. A labelling on the GPU
// passes over the frame several times (the DCT cuda backend: its threshold, unions, compression,
// the roots' ids, the statistics and Otsu's histogram), each thread reading a few bytes of its pixel
// and neighbours and writing one label: light threads whose issue bounds the pass, not the bytes
// (on a lent H200 2.8-3.9 ps a pixel where those bytes at the copy kernel's bandwidth come to
// 1-1.5 ps; docs/model.md 2.6, lat_GF).
//
// The probe runs the three shapes such a pass takes (probes/gpu_frame_pass.cu: an 8-bit pixel
// thresholded into a label; a label and its left and upper neighbours' read, the least written; a
// label followed to the one it points to), each on frames of 2048-pixel rows from 0.5 to 16 MP with
// bright dots on a dark background (most warps find only background, as in the workload's frames),
// launched as the backend launches its own (a thread a pixel, 256 a block), and fits t = L + pixels
// x C for each; L_GF is the mean of the three slopes (a labelling's passes are of all three kinds).
// Every pass's output is compared with the host's over the whole frame.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

constexpr int kWidth = 2048;
constexpr int kBlock = 256;  // the DCT cuda backend's default threads a block of its per-pixel kernels

struct Plan {
  std::vector<int> rows;
  int reps;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {{128, 512, 1024}, 3};
    case Effort::quick: return {{256, 1024, 4096, 8192}, 7};
    case Effort::full: return {{256, 512, 1024, 2048, 4096, 8192}, 15};
  }
  return {{}, 0};
}

std::string_view pass_name(gpu::FramePass p) {
  switch (p) {
    case gpu::FramePass::threshold: return "threshold";
    case gpu::FramePass::neighbours: return "neighbours";
    case gpu::FramePass::relabel: return "relabel";
  }
  return "?";
}

std::string_view pass_label(gpu::FramePass p) {
  switch (p) {
    case gpu::FramePass::threshold: return "an 8-bit pixel thresholded into an int label";
    case gpu::FramePass::neighbours: return "a label and its left and upper neighbours' read, the least written";
    case gpu::FramePass::relabel: return "a label followed to the one it points to";
  }
  return "?";
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  const gpu::FramePassTiming t = gpu::time_frame_passes(kWidth, p.rows, kBlock, p.reps, 3);
  if (t.mismatches != 0)
    throw std::runtime_error(fmt::format("gpu-frame-pass: {} pixels of the device's passes differ from the host's; "
                                         "the device computes wrongly (run the GPU tests)",
                                         t.mismatches));
  std::array<PerEventFit, 3> fits;
  for (gpu::FramePass pass : gpu::kFramePasses) {
    const int k = static_cast<int>(pass);
    std::vector<TransferPoint> points;
    for (std::size_t i = 0; i < t.pixels.size(); ++i) {
      Measurement m = time_measurement(
          fmt::format("frame_{}_{}MP", pass_name(pass), static_cast<double>(t.pixels[i]) / (1 << 20)),
          fmt::format("{}: a frame of {} x {} pixels", pass_label(pass), kWidth, t.pixels[i] / kWidth),
          t.seconds[k][i], std::nullopt,
          fmt::format("events around a batch of 5 launches behind an untimed one, median of {}", p.reps));
      m.detail = true;
      points.push_back({static_cast<double>(t.pixels[i]), m.stats.median});
      r.measurements.push_back(m);
    }
    fits[static_cast<std::size_t>(k)] = fit_per_event(points);
  }
  // The three kinds' mean: their slopes, fixed costs and half-widths (independent, in quadrature).
  PerEventFit mean;
  double hw2 = 0, fixed_hw2 = 0;
  for (const PerEventFit& f : fits) {
    mean.per_event += f.per_event / 3;
    mean.fixed += f.fixed / 3;
    hw2 += f.per_event_hw95 * f.per_event_hw95;
    fixed_hw2 += f.fixed_hw95 * f.fixed_hw95;
    mean.rms_rel_residual = std::max(mean.rms_rel_residual, f.rms_rel_residual);
  }
  mean.per_event_hw95 = std::sqrt(hw2) / 3;
  mean.fixed_hw95 = std::sqrt(fixed_hw2) / 3;
  const Measurement m = per_event_measurement(
      "frame_pass", "one pixel of a device pass over a whole frame, a thread a pixel (the mean of three kinds)", mean,
      t.seconds[0].back(), Param::L_GF,
      fmt::format("mean of the slopes of fits t = L + pixels x C over {} frames of {}-pixel rows ({:.2g}..{:.2g} MP), "
                  "{} threads a block, of three passes: threshold {:.3g} ps, neighbours {:.3g} ps, relabel {:.3g} ps a "
                  "pixel; every pass's output checked against the host's; worst rms residual {:.1f}%",
                  t.pixels.size(), kWidth, static_cast<double>(t.pixels.front()) * 1e-6,
                  static_cast<double>(t.pixels.back()) * 1e-6, kBlock, fits[0].per_event * 1e12,
                  fits[1].per_event * 1e12, fits[2].per_event * 1e12, 100 * mean.rms_rel_residual));
  r.measurements.push_back(m);
  o.say(fmt::format("  GPU frame passes: {:.3g} ps a pixel (threshold {:.3g}, neighbours {:.3g}, relabel {:.3g})",
                    m.value * 1e12, fits[0].per_event * 1e12, fits[1].per_event * 1e12, fits[2].per_event * 1e12));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_frame_pass) {
  registry.add({"gpu-frame-pass",
                "the device's passes over a whole frame, a thread a pixel: a labelling's threshold, unions and "
                "relabellings (L_GF)",
                true, 56, dtflop::probes::run});
}
