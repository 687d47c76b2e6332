// Built instead of the gpu_*.cu files when dtflop is built without CUDA: no device is usable,
// and the GPU probes report why instead of measuring.
#include "probes/gpu.hpp"

namespace dtflop::probes::gpu {

namespace {
[[noreturn]] void no_cuda() {
  throw GpuError("dtflop was built without CUDA (nvcc was not found when it was configured)");
}
}  // namespace

DeviceInfo device_info() {
  DeviceInfo d;
  d.reason = "dtflop was built without CUDA (nvcc was not found when it was configured); "
             "rebuild on a machine with the CUDA toolkit to probe a GPU";
  return d;
}

std::vector<SizeTiming> time_transfers(Direction, HostMemory, std::span<const std::int64_t>,
                                       std::span<const int>, int) {
  no_cuda();
}
std::vector<double> time_blocking_copies(Direction, std::int64_t, int) { no_cuda(); }
std::int64_t fit_device_buffer(std::int64_t, int) { no_cuda(); }
std::vector<double> time_d2d_memcpy(std::int64_t, int, int) { no_cuda(); }
std::vector<double> time_copy_kernel(std::int64_t, int, int) { no_cuda(); }
FmaTiming time_fma(bool, double, int, int) { no_cuda(); }
RowsTiming time_rows(int, int, int, int, TapDirection) { no_cuda(); }
LaunchTiming time_launches(int, int) { no_cuda(); }
std::vector<double> time_graph_launches(int, int) { no_cuda(); }
std::vector<double> time_l2_copy(std::int64_t, int, int, int) { no_cuda(); }
WaveTiming time_waves(int, int) { no_cuda(); }
FillTiming time_tile_fills(bool, int, int, int) { no_cuda(); }
bool tma_available() { return false; }
AtomicTiming time_atomics(std::span<const int>, int, int) { no_cuda(); }
MlsTiming time_mls(const MlsDots&, const std::vector<MlsTable>&, int, int, int) { no_cuda(); }
CentroidTiming time_centroids(const std::vector<CentroidFrame>&, int, int, int, int) { no_cuda(); }
FramePassTiming time_frame_passes(int, std::span<const int>, int, int, int) { no_cuda(); }

}  // namespace dtflop::probes::gpu
