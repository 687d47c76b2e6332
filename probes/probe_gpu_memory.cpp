// Device memory bandwidth: a copy kernel (B_GG, what a kernel sees) and cudaMemcpy
// device->device (B_GG_copy), over buffers far larger than the L2 cache, read + write bytes
// counted; and the same copy kernel over buffers that stay in the L2 cache (B_L2: what a kernel
// whose working set fits there sees, e.g. a belief grid of up to a few million cells).
#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  std::int64_t bytes;  // per buffer (source and destination)
  int reps;
  int warmup;
};

Plan plan(Effort e) {
  const std::int64_t mib = 1 << 20;
  switch (e) {
    case Effort::smoke: return {64 * mib, 3, 1};
    case Effort::quick: return {512 * mib, 10, 2};
    case Effort::full: return {2048 * mib, 30, 3};
  }
  return {512 * mib, 10, 2};
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  Plan p = plan(o.effort);
  p.bytes = gpu::fit_device_buffer(p.bytes, 2);
  const double moved = 2.0 * static_cast<double>(p.bytes);  // read + write

  const auto tk = gpu::time_copy_kernel(p.bytes, p.reps, p.warmup);
  r.measurements.push_back(rate_measurement(
      "copy_kernel", "device memory, copy kernel (read + write)", "B/s", moved, tk, Param::B_GG,
      fmt::format("kernel copying {} with 16-byte loads/stores, 2 x bytes counted, events, median "
                  "of {}",
                  size_label(p.bytes), p.reps)));
  const auto tm = gpu::time_d2d_memcpy(p.bytes, p.reps, p.warmup);
  r.measurements.push_back(rate_measurement(
      "d2d_memcpy", "device->device cudaMemcpy (read + write)", "B/s", moved, tm, Param::B_GG_copy,
      fmt::format("cudaMemcpyAsync of {}, 2 x bytes counted, events, median of {}",
                  size_label(p.bytes), p.reps)));
  o.say(fmt::format("  device memory: copy kernel {:.3f} TB/s, cudaMemcpy D2D {:.3f} TB/s",
                    r.measurements[0].value / 1e12, r.measurements[1].value / 1e12));

  // L2-resident: two buffers of an eighth of the L2 each (a quarter of it in all, so that no pass
  // evicts the other's lines), many passes a kernel so that the launch is a small part.
  const gpu::DeviceInfo d = gpu::device_info();
  if (d.l2_bytes < (1 << 20)) {
    o.say("  L2-resident copy: not measured (the device reports no L2 cache size)");
    return r;
  }
  const std::int64_t l2_buffer = d.l2_bytes / 8 / 16 * 16;
  const int passes = o.effort == Effort::smoke ? 8 : 32;
  const auto tl = gpu::time_l2_copy(l2_buffer, passes, p.reps, p.warmup);
  r.measurements.push_back(rate_measurement(
      "copy_kernel_l2", "L2-resident copy kernel (read + write)", "B/s", 2.0 * static_cast<double>(l2_buffer) * passes,
      tl, Param::B_L2,
      fmt::format("kernel copying {} (an eighth of the {} L2) {} times with 16-byte loads bypassing L1, 2 x bytes "
                  "counted, events, median of {}",
                  size_label(l2_buffer), size_label(d.l2_bytes), passes, p.reps)));
  o.say(fmt::format("  L2-resident copy kernel {:.3f} TB/s", r.measurements.back().value / 1e12));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_memory) {
  registry.add({"gpu-memory",
                "device memory bandwidth: copy kernel (B_GG), cudaMemcpy D2D (B_GG_copy), L2-resident copy kernel (B_L2)", true,
                40, dtflop::probes::run});
}
