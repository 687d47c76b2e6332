// K_GR and K_GW: what an FMA costs when its operand is read from device memory by a window's tap,
// relative to one at the probed FP32 rate. The kernels are cuda-seed's two passes (their loops,
// shapes and layouts, docs/model.md 2.2) over a 2048 x 2048 grid with 33 taps: the row pass, each
// tap in another row (K_GR), and the column pass, each tap the next float of the same row (K_GW).
// K = the kernel's time x V_G_fp32 / its FLOPs, with V_G_fp32 from the same FMA kernel as the
// gpu-fma probe, measured here in the same run. Every output cell is checked.
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

struct Pass {
  gpu::TapDirection direction;
  const char* key;    // the rate's key
  const char* label;  // "across rows"
  const char* kernel;
  Param param;
  const char* what;   // the factor's label
};

const Pass kPasses[] = {
    {gpu::TapDirection::across_rows, "across_rows", "across rows", "row pass", Param::K_GR,
     "cost of an across-row FMA / one at the FP32 rate"},
    {gpu::TapDirection::along_row, "along_row", "along a row", "column pass", Param::K_GW,
     "cost of an along-row window FMA / one at the FP32 rate"},
};

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  const auto fma = gpu::time_fma(false, p.fma_seconds, 5);
  const Measurement peak =
      rate_measurement("fp32_reference", "GPU FP32 FMA (reference)", "FLOP/s", fma.flops, fma.seconds, std::nullopt,
                       "the gpu-fma probe's kernel, rerun so K_GR and K_GW are ratios of one run");
  r.measurements.push_back(peak);
  for (const Pass& pass : kPasses) {
    const auto t = gpu::time_rows(p.n, p.taps, p.reps, 3, pass.direction);
    Measurement rate = rate_measurement(
        pass.key, fmt::format("GPU FP32 FMAs reading {0} ({1}x{1} grid, {2} taps)", pass.label, p.n, p.taps), "FLOP/s",
        t.flops, t.seconds, std::nullopt,
        fmt::format("cuda-seed's {}, 32 x 8 threads a block, events, median of {}", pass.kernel, p.reps));
    Measurement k;
    k.key = std::string(info(pass.param).name);
    k.label = pass.what;
    k.unit = "x";
    k.value = peak.value / rate.value;
    k.stats = rate.stats;  // the factor is proportional to the kernel's time: its spread is the kernel's
    k.param = pass.param;
    k.note = fmt::format("{:.4g} FLOP/s {} against {:.4g} FLOP/s", rate.value, pass.label, peak.value);
    o.say(fmt::format("  GPU FMAs {}: {:.2f} TFLOP/s, {} {:.2f}", pass.label, rate.value / 1e12, k.key, k.value));
    r.measurements.push_back(rate);
    r.measurements.push_back(k);
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_rows) {
  registry.add({"gpu-rows",
                "GPU FMAs whose operands a window's taps read from device memory, across rows (K_GR) and along a row "
                "(K_GW): cuda-seed's row and column passes",
                true, 55, dtflop::probes::run});
}
