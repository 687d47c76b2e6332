// Internal to the gpu_*.cu files: checked CUDA calls, RAII owners, the data pattern the
// probes copy and check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <cuda_runtime.h>

#include "cuda/check.hpp"  // DTFLOP_CUDA, DTFLOP_CUDA_LAUNCHED
#include "probes/gpu.hpp"
#include "probes/gpu_errors.hpp"

namespace dtflop::probes::gpu::detail {


class DeviceBuffer {
 public:
  explicit DeviceBuffer(std::size_t bytes);
  ~DeviceBuffer();
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  template <typename T = void>
  T* get() const { return static_cast<T*>(p_); }
  std::size_t bytes() const { return bytes_; }

 private:
  void* p_ = nullptr;
  std::size_t bytes_ = 0;
};

class PinnedBuffer {
 public:
  explicit PinnedBuffer(std::size_t bytes);
  ~PinnedBuffer();
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  void* get() const { return p_; }

 private:
  void* p_ = nullptr;
};

class Stream {
 public:
  Stream();
  ~Stream();
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }
  void sync() const;

 private:
  cudaStream_t s_ = nullptr;
};

class Event {
 public:
  Event();
  ~Event();
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  void record(const Stream& s);
  cudaEvent_t get() const { return e_; }

 private:
  cudaEvent_t e_ = nullptr;
};

// Seconds between two recorded events (synchronizes on `stop`).
double elapsed(const Event& start, const Event& stop);

// A kernel timed as a workload's kernel runs, queued behind the frame's others: `reps`
// repetitions, each `batch` calls of `launch` back to back behind an untimed one, the events
// around the batch (the host's launch gap is not timed); each repetition's time / batch.
template <class Launch>
std::vector<double> time_queued(const Stream& s, const Launch& launch, int reps, int batch) {
  Event start, stop;
  std::vector<double> seconds;
  for (int i = 0; i < reps; ++i) {
    launch();
    start.record(s);
    for (int b = 0; b < batch; ++b) launch();
    stop.record(s);
    seconds.push_back(elapsed(start, stop) / batch);
  }
  return seconds;
}

// The pattern: word i of a buffer filled with `seed` holds pattern_word(i, seed). A cheap
// integer hash, so stale data from another size or seed never passes a check.
__host__ __device__ inline std::uint32_t pattern_word(std::uint64_t i, std::uint32_t seed) {
  std::uint64_t x = i * 0x9E3779B97F4A7C15ull + seed;
  x ^= x >> 31;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 29;
  return static_cast<std::uint32_t>(x);
}

// Fills `words` 32-bit words of device memory with the pattern (asynchronous on `s`).
void fill_pattern_device(std::uint32_t* p, std::size_t words, std::uint32_t seed, const Stream& s);
// Number of words of device memory that differ from the pattern (synchronizes on `s`).
std::uint64_t count_mismatches_device(const std::uint32_t* p, std::size_t words,
                                      std::uint32_t seed, const Stream& s);

}  // namespace dtflop::probes::gpu::detail
