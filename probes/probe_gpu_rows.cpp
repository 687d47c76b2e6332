// K_GR: what an FMA costs when its operand is read from another row of device memory, relative to
// one at the probed FP32 rate. The kernel is cuda-seed's row pass (its loop, shape and layout,
// docs/model.md 2.2) over a 2048 x 2048 grid with 33 taps; K_GR = its time x V_G_fp32 / its
// FLOPs, with V_G_fp32 from the same FMA kernel as the gpu-fma probe, measured here in the same
// run. Every output cell is checked.
#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  int n, taps, reps;
  double fma_seconds;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {256, 9, 3, 0.002};
    case Effort::quick: return {2048, 33, 20, 0.02};
    case Effort::full: return {2048, 33, 50, 0.05};
  }
  return {2048, 33, 20, 0.02};
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  const auto fma = gpu::time_fma(false, p.fma_seconds, 5);
  const Measurement peak =
      rate_measurement("fp32_reference", "GPU FP32 FMA (reference)", "FLOP/s", fma.flops, fma.seconds, std::nullopt,
                       "the gpu-fma probe's kernel, rerun so K_GR is a ratio of one run");
  const auto rows = gpu::time_rows(p.n, p.taps, p.reps, 3);
  Measurement rate = rate_measurement(
      "across_rows", fmt::format("GPU FP32 FMAs reading across rows ({0}x{0} grid, {1} taps)", p.n, p.taps),
      "FLOP/s", rows.flops, rows.seconds, std::nullopt,
      fmt::format("cuda-seed's row pass, 32 x 8 threads a block, events, median of {}", p.reps));
  Measurement k;
  k.key = "K_GR";
  k.label = "cost of an across-row FMA / one at the FP32 rate";
  k.unit = "x";
  k.value = peak.value / rate.value;
  k.stats = rate.stats;  // K_GR is proportional to the kernel's time: its spread is the kernel's
  k.param = Param::K_GR;
  k.note = fmt::format("{:.4g} FLOP/s across rows against {:.4g} FLOP/s", rate.value, peak.value);
  o.say(fmt::format("  GPU across-row FMAs: {:.2f} TFLOP/s, K_GR {:.2f}", rate.value / 1e12, k.value));
  r.measurements.push_back(peak);
  r.measurements.push_back(rate);
  r.measurements.push_back(k);
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_rows) {
  registry.add({"gpu-rows", "GPU FMAs whose operands are read across rows of device memory (K_GR): cuda-seed's row pass",
                true, 55, dtflop::probes::run});
}
