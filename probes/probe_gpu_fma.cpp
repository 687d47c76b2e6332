// GPU floating-point rate: a kernel of independent FMA chains filling every SM, FP32 and
// FP64; every chain's end value is checked. Compared with SMs x FMA lanes x 2 x clock for
// the architectures whose lane counts are known.
#include <optional>

#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  double target_seconds;
  int reps;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {0.002, 2};
    case Effort::quick: return {0.02, 5};
    case Effort::full: return {0.05, 15};
  }
  return {0.02, 5};
}

// FP32 / FP64 FMA lanes per SM (CUDA C++ Programming Guide, arithmetic throughput table).
std::optional<int> lanes_per_sm(int major, int minor, bool fp64) {
  if (major == 7) return fp64 ? (minor == 0 ? 32 : 2) : 64;  // V100; Turing 7.5
  if (major == 8 && minor == 0) return fp64 ? 32 : 64;       // A100
  if (major == 8) return fp64 ? 2 : 128;                      // 8.6, 8.7, 8.9
  if (major == 9 && minor == 0) return fp64 ? 64 : 128;       // H100, H200
  return std::nullopt;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const auto dev = gpu::device_info();
  const Plan p = plan(o.effort);
  for (bool fp64 : {false, true}) {
    const char* prec = fp64 ? "FP64" : "FP32";
    const auto t = gpu::time_fma(fp64, p.target_seconds, p.reps);
    const std::string key = fp64 ? "fp64" : "fp32";
    r.measurements.push_back(rate_measurement(
        key, fmt::format("GPU {} FMA", prec), "FLOP/s", t.flops, t.seconds,
        fp64 ? Param::V_G_fp64 : Param::V_G_fp32,
        fmt::format("{} blocks x {} threads, {} independent chains x {} FMA steps, events, "
                    "median of {}",
                    t.blocks, t.threads_per_block, t.chains, t.steps, p.reps)));
    const double value = r.measurements.back().value;
    if (auto lanes = lanes_per_sm(dev.cc_major, dev.cc_minor, fp64); lanes && dev.sm_clock_ghz) {
      Measurement m;
      m.key = fmt::format("{}_peak_ratio", key);
      m.label = fmt::format("GPU {} / ({} SMs x {} lanes x 2 x {:.3g} GHz)", prec, dev.sm_count,
                            *lanes, *dev.sm_clock_ghz);
      m.unit = std::string("x");
      m.value = value / (dev.sm_count * *lanes * 2.0 * *dev.sm_clock_ghz * 1e9);
      m.note = "clock: the device's reported peak SM clock (cudaDevAttrClockRate); the clock "
               "under load may be lower";
      r.measurements.push_back(m);
    }
    o.say(fmt::format("  GPU {} FMA: {:.2f} TFLOP/s", prec, value / 1e12));
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_fma) {
  registry.add({"gpu-fma", "GPU FP32/FP64 rate: a kernel of independent FMA chains", true, 50,
                dtflop::probes::run});
}
