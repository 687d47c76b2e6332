// Host<->device copies timed with events, pinned and pageable host memory.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <new>
#include <string>

#include "probes/gpu_common.cuh"
#include "probes/probe.hpp"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Event;
using detail::PinnedBuffer;
using detail::Stream;

// Pageable host memory: an ordinary page-aligned allocation, every page touched so that the
// first timed copy does not pay for page faults.
struct PageableBuffer {
  explicit PageableBuffer(std::size_t bytes)
      : p(static_cast<std::byte*>(::operator new(bytes, std::align_val_t{4096}))) {
    std::memset(p, 0, bytes);
  }
  ~PageableBuffer() { ::operator delete(p, std::align_val_t{4096}); }
  PageableBuffer(const PageableBuffer&) = delete;
  PageableBuffer& operator=(const PageableBuffer&) = delete;
  std::byte* p;
};

void fill_pattern_host(std::uint32_t* p, std::size_t words, std::uint32_t seed) {
  for (std::size_t i = 0; i < words; ++i) p[i] = detail::pattern_word(i, seed);
}

std::size_t count_mismatches_host(const std::uint32_t* p, std::size_t words, std::uint32_t seed) {
  std::size_t bad = 0;
  for (std::size_t i = 0; i < words; ++i) bad += p[i] != detail::pattern_word(i, seed);
  return bad;
}

}  // namespace

std::vector<SizeTiming> time_transfers(Direction dir, HostMemory mem,
                                       std::span<const std::int64_t> sizes,
                                       std::span<const int> reps, int warmup) {
  if (sizes.empty() || sizes.size() != reps.size())
    throw std::invalid_argument("time_transfers: sizes and reps must be non-empty and match");
  for (std::size_t i = 0; i < sizes.size(); ++i)
    if (sizes[i] <= 0 || sizes[i] % 4 != 0 || reps[i] < 1)
      throw std::invalid_argument("time_transfers: size " + std::to_string(sizes[i]) +
                                  " must be a positive multiple of 4 and reps " +
                                  std::to_string(reps[i]) + " at least 1");
  detail::use_device();
  const auto max_bytes = static_cast<std::size_t>(*std::max_element(sizes.begin(), sizes.end()));

  DeviceBuffer dev(max_bytes);
  std::unique_ptr<PinnedBuffer> pinned;
  std::unique_ptr<PageableBuffer> pageable;
  std::byte* host = nullptr;
  if (mem == HostMemory::pinned) {
    pinned = std::make_unique<PinnedBuffer>(max_bytes);
    host = static_cast<std::byte*>(pinned->get());
  } else {
    pageable = std::make_unique<PageableBuffer>(max_bytes);
    host = pageable->p;
  }
  Stream stream;
  Event start, stop;
  const bool h2d = dir == Direction::host_to_device;
  const cudaMemcpyKind kind = h2d ? cudaMemcpyHostToDevice : cudaMemcpyDeviceToHost;
  void* dst = h2d ? static_cast<void*>(dev.get()) : static_cast<void*>(host);
  const void* src = h2d ? static_cast<const void*>(host) : static_cast<const void*>(dev.get());

  std::vector<SizeTiming> out;
  out.reserve(sizes.size());
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    const auto bytes = static_cast<std::size_t>(sizes[k]);
    const std::size_t words = bytes / 4;
    const auto seed = static_cast<std::uint32_t>(0x5EED0000u + k * 7919u + (h2d ? 1u : 2u));
    // Source holds this size's pattern; destination is poisoned.
    if (h2d) {
      fill_pattern_host(reinterpret_cast<std::uint32_t*>(host), words, seed);
      DTFLOP_CUDA(cudaMemsetAsync(dev.get(), 0xA5, bytes, stream.get()));
    } else {
      detail::fill_pattern_device(dev.get<std::uint32_t>(), words, seed, stream);
      std::memset(host, 0xA5, bytes);
    }
    stream.sync();

    for (int i = 0; i < warmup; ++i)
      DTFLOP_CUDA(cudaMemcpyAsync(dst, src, bytes, kind, stream.get()));
    stream.sync();
    SizeTiming t;
    t.bytes = sizes[k];
    t.seconds.reserve(static_cast<std::size_t>(reps[k]));
    for (int r = 0; r < reps[k]; ++r) {
      start.record(stream);
      DTFLOP_CUDA(cudaMemcpyAsync(dst, src, bytes, kind, stream.get()));
      stop.record(stream);
      t.seconds.push_back(detail::elapsed(start, stop));
    }

    const std::size_t bad =
        h2d ? detail::count_mismatches_device(dev.get<std::uint32_t>(), words, seed, stream)
            : count_mismatches_host(reinterpret_cast<const std::uint32_t*>(host), words, seed);
    if (bad != 0)
      detail::mismatch(h2d ? (mem == HostMemory::pinned ? "host->device pinned copy"
                                                       : "host->device pageable copy")
                           : (mem == HostMemory::pinned ? "device->host pinned copy"
                                                        : "device->host pageable copy"),
                       bytes, bad, words);
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<double> time_blocking_copies(Direction dir, std::int64_t bytes, int reps) {
  if (bytes <= 0 || bytes % 4 != 0 || reps < 1)
    throw std::invalid_argument("time_blocking_copies: bytes must be a positive multiple of 4, reps >= 1");
  detail::use_device();
  const auto n = static_cast<std::size_t>(bytes);
  DeviceBuffer dev(n);
  PinnedBuffer host(n);
  auto* words = static_cast<std::uint32_t*>(host.get());
  const bool h2d = dir == Direction::host_to_device;
  const std::uint32_t seed = h2d ? 0xB10C1u : 0xB10C2u;
  Stream s;
  if (h2d) {
    fill_pattern_host(words, n / 4, seed);
  } else {
    detail::fill_pattern_device(dev.get<std::uint32_t>(), n / 4, seed, s);
    s.sync();
  }
  void* dst = h2d ? dev.get() : host.get();
  const void* src = h2d ? static_cast<const void*>(host.get()) : static_cast<const void*>(dev.get());
  const cudaMemcpyKind kind = h2d ? cudaMemcpyHostToDevice : cudaMemcpyDeviceToHost;
  for (int i = 0; i < 10; ++i) DTFLOP_CUDA(cudaMemcpy(dst, src, n, kind));
  if (h2d)
    DTFLOP_CUDA(cudaMemset(dev.get(), 0xA5, n));
  else
    std::memset(host.get(), 0xA5, n);
  std::vector<double> t;
  t.reserve(static_cast<std::size_t>(reps));
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    DTFLOP_CUDA(cudaMemcpy(dst, src, n, kind));
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  const std::size_t bad = h2d ? detail::count_mismatches_device(dev.get<std::uint32_t>(), n / 4, seed, s)
                              : count_mismatches_host(words, n / 4, seed);
  if (bad != 0)
    detail::mismatch(h2d ? "blocking host->device copy" : "blocking device->host copy", n, bad, n / 4);
  return t;
}

}  // namespace dtflop::probes::gpu
