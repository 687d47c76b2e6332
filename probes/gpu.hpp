// The CUDA side of the probes, callable from plain C++: device identity and the timed
// operations (transfers, device copies, FMA kernels, launches). Implemented in gpu_*.cu
// when dtflop is built with CUDA, and by gpu_none.cpp (every device reported unusable)
// when it is not. All timing is by CUDA events on a dedicated stream; every CUDA call is
// checked, and the last error after each launch.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "cuda/error.hpp"
#include "kernels/point_fields.hpp"  // FieldValue: what the device's MLS points give
#include "model/cost_counts.hpp"  // HostMemory: the model's, pinned or pageable

namespace dtflop::probes::gpu {

// A CUDA call failed; the message names the call, where, and CUDA's error string (the error type
// every CUDA path of dtflop throws: cuda/error.hpp).
using GpuError = cuda::Error;

struct DeviceInfo {
  bool usable = false;
  std::string reason;  // why not, when !usable
  int device = 0;
  std::string name;                 // "NVIDIA H200"
  int sm_count = 0;
  std::int64_t l2_bytes = 0;        // L2 cache
  int cc_major = 0, cc_minor = 0;   // compute capability
  std::int64_t total_bytes = 0;     // device memory
  std::int64_t free_bytes = 0;
  std::optional<double> sm_clock_ghz;  // the device's reported peak SM clock
  std::string driver_version;       // "580.159.04" (from /proc/driver/nvidia), else the API version
  std::string runtime_version;      // CUDA runtime this binary uses, "13.0"
  std::string driver_cuda_version;  // highest CUDA version the driver supports, "13.0"
};

// Device 0 of this process (CUDA_VISIBLE_DEVICES applies). Never throws.
DeviceInfo device_info();

enum class Direction { host_to_device, device_to_host };

struct SizeTiming {
  std::int64_t bytes = 0;
  std::vector<double> seconds;  // one entry per timed copy
};

// Times cudaMemcpyAsync copies of each size (multiples of 4 bytes) between one host buffer
// (pinned: cudaMallocHost; pageable: ordinary, already touched) and one device buffer, both
// as large as the largest size. `reps[i]` timed copies of sizes[i] follow `warmup` untimed
// ones. The destination is poisoned before each size and checked word by word after it;
// a difference throws ValidationError.
std::vector<SizeTiming> time_transfers(Direction dir, HostMemory mem,
                                       std::span<const std::int64_t> sizes,
                                       std::span<const int> reps, int warmup);

// Times blocking cudaMemcpy calls of `bytes` (a multiple of 4) between pinned host memory and
// the device, with the host clock around each call: what a program that copies and waits
// pays per copy, launch and completion included. `reps` timed calls after 10 untimed ones;
// the data is checked.
std::vector<double> time_blocking_copies(Direction dir, std::int64_t bytes, int reps);

// Device buffers are capped to a quarter of the free device memory; this says what a
// request for `bytes` per buffer becomes (rounded down to 1 MiB, at least 1 MiB).
std::int64_t fit_device_buffer(std::int64_t bytes, int buffers);

// Times cudaMemcpyAsync device->device of `bytes` (`reps` copies after `warmup`); checks the
// destination. Returns seconds per copy.
std::vector<double> time_d2d_memcpy(std::int64_t bytes, int reps, int warmup);

// Times a copy kernel (16-byte loads and stores, 4 in flight per thread) over `bytes`;
// checks the destination. Returns seconds per kernel.
std::vector<double> time_copy_kernel(std::int64_t bytes, int reps, int warmup);

// Times a copy kernel whose two buffers of `bytes` each stay in the L2 cache: `passes` sweeps
// over them per kernel (loads that bypass L1), `reps` kernels after `warmup`; checks the
// destination. Returns seconds per kernel (2 x bytes x passes moved).
std::vector<double> time_l2_copy(std::int64_t bytes, int passes, int reps, int warmup);

// Times a CUDA graph of `batch` empty kernels (captured on one stream, instantiated and uploaded
// first): events around each of `reps` graph launches. Returns seconds per kernel.
std::vector<double> time_graph_launches(int batch, int reps);

struct FmaTiming {
  std::vector<double> seconds;  // per kernel
  double flops = 0;             // per kernel: 2 x threads x chains x steps
  int blocks = 0, threads_per_block = 0, chains = 0;
  std::int64_t steps = 0;       // FMA steps per chain per kernel
};

// Times a kernel of independent FMA chains (x = x * a + b; fp32 or fp64) filling every SM,
// sized to run about `target_seconds`; `chains` per thread is 4, 8 (the probe's) or 16.
// Every chain's end value is copied back and compared with its exact expected value
// (ValidationError on any difference).
FmaTiming time_fma(bool fp64, double target_seconds, int reps, int chains = 8);

struct RowsTiming {
  std::vector<double> seconds;  // per kernel
  double flops = 0;             // per kernel: 2 x n x n x taps, every one reading a tap
  int n = 0, taps = 0;
};

// Which way a window's taps read device memory: across rows (cuda-seed's row pass: another row at
// each tap) or along a row (its column pass: the next float of the same row).
enum class TapDirection { across_rows, along_row };

// The cost of FMAs whose operands are read from other rows of device memory (K_GR): a kernel with
// cuda-seed's row pass's shape and layout (32 x 8 threads a block, one output cell a thread,
// acc = fma(k[b], u[(y - b + c) n + x], acc) over `taps` rows, zeros outside the grid) over an
// n x n grid of floats; events, `reps` kernels after `warmup`. u = 1 and k = 0.5 make every
// output exactly half its count of in-grid taps: every cell is checked (ValidationError).
// TapDirection::along_row runs the column pass instead (K_GW): the same with
// u[y n + (x - a + c)] over `taps` neighbours along the row.
RowsTiming time_rows(int n, int taps, int reps, int warmup, TapDirection direction = TapDirection::across_rows);

struct LaunchTiming {
  std::vector<double> per_launch;  // seconds per launch, back to back (events around a batch)
  std::vector<double> round_trip;  // seconds for launch + cudaStreamSynchronize (host clock)
  int batch = 0;
};

// Empty-kernel launch overhead: `reps` batches of `batch` back-to-back launches, and
// 10 x `reps` single launch + synchronize round trips.
LaunchTiming time_launches(int batch, int reps);

struct WaveTiming {
  std::vector<int> waves;                  // rounds of blocks per launch: 4, 8, 16, 32
  std::vector<double> seconds;             // median time of one launch of that many rounds
  double per_wave = 0;                     // least-squares slope: seconds per extra round
  int blocks_per_sm = 0;                   // resident blocks per SM the kernel allows (1)
};

// The fixed cost of a round of thread blocks (L_wave): a kernel whose blocks each take a
// multiprocessor whole (shared memory beyond half an SM's) and do only what every tile kernel
// does once (fill a shared array, a barrier, one global write), launched with 4, 8, 16 and 32
// times as many blocks as there are SMs (fewer rounds run shorter than the launch interval of
// back-to-back launches); events around batches of `batch` launches, median of `reps`. Each
// size is checked first: every block writes its own result into a poisoned buffer.
WaveTiming time_waves(int batch, int reps);

struct FillPoint {
  int rows = 0;                  // tile rows (of tiles::kCols floats)
  std::vector<double> seconds;   // seconds per launch (events around a batch of launches)
  std::int64_t counted_bytes = 0;  // what the model counts (tiles::counted_fill_bytes)
  std::int64_t filled_bytes = 0;   // what the blocks filled: blocks x rows x kCols x 4
};

struct FillTiming {
  bool tma = false;              // filled by the tensor memory accelerator, else 16-byte cp.async
  int blocks = 0;                // per launch: blocks_per_sm_rounds x occ x SMs
  int sms = 0, occ = 0;          // multiprocessors; blocks each runs at once (what the occupancy API says)
  std::vector<FillPoint> points; // one per tile height, smallest first
};

// Shared-memory tile fills (B_GS): kernels of 256-thread blocks that each copy a tile of `rows`
// x 72 floats (cuda-resident's fused input tile with its halo, probes/tile_fill.hpp) from an
// L2-resident 2048 x 2048 grid into shared memory, as cuda-resident does (the tensor memory
// accelerator when `tma` and the device has one, else 16-byte cp.async pieces), wait for it, sum
// it and write the sum. Shared memory is sized so that tiles::kBlocksPerSm blocks run on a
// multiprocessor at once, whatever the tile height; each launch runs `rounds` x occ blocks per
// multiprocessor. `reps` batches of `batch` launches per tile height after 3 untimed; every
// block's sum of every height is checked against the exact one (ValidationError). Throws
// GpuError (`tma` on a device or driver without the accelerator) and std::invalid_argument.
FillTiming time_tile_fills(bool tma, int rounds, int batch, int reps);
// Whether time_tile_fills(true, ...) can run here (compute capability 9 and the driver's
// tensor-map encoder).
bool tma_available();

struct AtomicTiming {
  std::vector<int> blocks;                  // blocks per launch
  std::vector<std::vector<double>> atomic;  // seconds per launch, each block adds to one address
  std::vector<std::vector<double>> stored;  // the same kernel, each block storing its own result
};

// Serialized atomics (L_atomic): a kernel of 256-thread blocks that each reduce their threads'
// values (warp shuffles, then the warp partials) and add the block's float64 sum to one address
// with atomicAdd, as cuda-resident's correcting kernel does; and beside it the same kernel with
// the atomic add replaced by a store of the block's sum to its own word. Launched with each of
// `blocks_per_sm` x SMs blocks; `reps` batches of `batch` launches after 3 untimed. The one sum
// is checked after every batch (it is exact: integer values) and every stored word after the
// last (ValidationError).
AtomicTiming time_atomics(std::span<const int> blocks_per_sm, int batch, int reps);

// One support table of MLS points for the device, as the DCT cuda backend holds one: per point its
// position (x, y), support radius and support dots' indices (compressed rows, `offsets` with
// points + 1 entries); per dot its reference position (x, y) and displacement (x, y).
struct MlsTable {
  std::vector<double> points_xy;
  std::vector<float> rho;
  std::vector<int> offsets, dots;
};
struct MlsDots {
  std::vector<double> reference_xy;
  std::vector<float> disp_xy;
};
struct MlsTiming {
  std::vector<std::vector<double>> seconds;  // [table][repetition]: a launch over all its points
  std::vector<std::vector<kernels::FieldValue<float>>> fields;  // [table][point], of the last launch
};

// One GPU thread's MLS chain (V_GM): the DCT cuda backend's field arithmetic
// (kernels::mls_point_device, cubic-spline weight, 6 dots at least, pivot ratio 1e-5) over each
// table, one point a thread and `block` threads a block, as the backend's field kernel launches
// it; `reps` repetitions of each table after `warmup` launches, each the events around 5 launches
// queued behind an untimed one (the host's launch gap untimed), divided by 5.
MlsTiming time_mls(const MlsDots& dots, const std::vector<MlsTable>& tables, int block, int reps, int warmup);

// One frame of dots for the DCT cuda backend's centroid block (gpu-centroid): an 8-bit image (rows
// of `width` pixels), its labels (-1 background, else the component of the dot the pixel belongs
// to, >= 0) and, a dot each, its window (x0, y0, width, height: inside the image) and component.
struct CentroidFrame {
  int width = 0, height = 0;
  std::vector<std::uint8_t> image;
  std::vector<int> labels;
  std::vector<int> windows;  // 4 a dot
  std::vector<int> component;
};
struct CentroidTiming {
  std::vector<std::vector<double>> seconds;    // [frame][repetition]: one launch over its dots
  std::vector<std::vector<double>> centroids;  // [frame][2 a dot]: x, y, of the last launch
};

// The per-dot pixel classification of the DCT cuda backend (L_GP): its centroid block
// (kernels::centroid_block, kernels/dot_centroid.hpp: the window staged, classified twice, the
// ring's and the weights' sums), one block of `block` threads a dot as the backend launches it,
// bright dots with a background margin of `margin` px; `reps` repetitions of each frame after
// `warmup` launches, each the events around 5 launches queued behind an untimed one (the host's
// launch gap untimed), divided by 5. Throws std::invalid_argument for an inconsistent frame (a
// window outside the image, a size that does not match) before anything is allocated.
CentroidTiming time_centroids(const std::vector<CentroidFrame>& frames, int margin, int block, int reps, int warmup);

// The device's whole-frame passes, a thread a pixel (gpu-frame-pass, L_GF): the three shapes a
// labelling's passes take, each reading what the one before wrote, out of place.
enum class FramePass {
  threshold,   // an 8-bit pixel read, compared, an int label written (its index, or -1)
  neighbours,  // the pixel's label read; a foreground one's left and upper neighbours' too, their least written
  relabel,     // a label read; a foreground one's followed to the label it points to, which is written
};
inline constexpr FramePass kFramePasses[] = {FramePass::threshold, FramePass::neighbours, FramePass::relabel};
struct FramePassTiming {
  std::vector<std::int64_t> pixels;            // [size]
  std::vector<std::vector<double>> seconds[3];  // [pass][size][repetition]: one launch over the frame
  std::int64_t mismatches = 0;                 // output pixels that differ from the host's, every pass and size
};
// Frames of `width` x rows[k] pixels (8-bit, bright dots of radius 5 px every 32 px on a dark
// background, as a labelling's frames are), each pass launched as the DCT cuda backend launches its own (a thread a pixel,
// `block` threads a block, the grid covering the frame); `reps` repetitions after `warmup`
// launches, each the events around 5 launches queued behind an untimed one, divided by 5. Every
// pass's output is compared with the host's over the whole frame. Throws std::invalid_argument for
// a size or block no pass can take before anything is allocated.
FramePassTiming time_frame_passes(int width, std::span<const int> rows, int block, int reps, int warmup);

}  // namespace dtflop::probes::gpu
