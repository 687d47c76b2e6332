// The RAII owners and the pattern kernels shared by the GPU probes. (Host-only parts, which
// format messages with fmt, live in gpu_host.cpp: fmt's compile-time format strings do not
// pass nvcc's front end.)
#include "probes/gpu_common.cuh"

namespace dtflop::probes::gpu {

namespace detail {

DeviceBuffer::DeviceBuffer(std::size_t bytes) : bytes_(bytes) {
  DTFLOP_CUDA(cudaMalloc(&p_, bytes));
}
DeviceBuffer::~DeviceBuffer() { cudaFree(p_); }

PinnedBuffer::PinnedBuffer(std::size_t bytes) { DTFLOP_CUDA(cudaMallocHost(&p_, bytes)); }
PinnedBuffer::~PinnedBuffer() { cudaFreeHost(p_); }

Stream::Stream() { DTFLOP_CUDA(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
Stream::~Stream() { cudaStreamDestroy(s_); }
void Stream::sync() const { DTFLOP_CUDA(cudaStreamSynchronize(s_)); }

Event::Event() { DTFLOP_CUDA(cudaEventCreate(&e_)); }
Event::~Event() { cudaEventDestroy(e_); }
void Event::record(const Stream& s) { DTFLOP_CUDA(cudaEventRecord(e_, s.get())); }

double elapsed(const Event& start, const Event& stop) {
  DTFLOP_CUDA(cudaEventSynchronize(stop.get()));
  float ms = 0;
  DTFLOP_CUDA(cudaEventElapsedTime(&ms, start.get(), stop.get()));
  return static_cast<double>(ms) * 1e-3;
}

namespace {

__global__ void fill_pattern_kernel(std::uint32_t* p, std::size_t words, std::uint32_t seed) {
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < words;
       i += static_cast<std::size_t>(gridDim.x) * blockDim.x)
    p[i] = pattern_word(i, seed);
}

__global__ void count_mismatches_kernel(const std::uint32_t* p, std::size_t words,
                                        std::uint32_t seed, unsigned long long* bad) {
  unsigned long long mine = 0;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < words;
       i += static_cast<std::size_t>(gridDim.x) * blockDim.x)
    mine += p[i] != pattern_word(i, seed);
  if (mine) atomicAdd(bad, mine);
}

int grid_for(std::size_t words) {
  int sms = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  const std::size_t want = (words + 255) / 256;
  const std::size_t cap = static_cast<std::size_t>(sms) * 8;
  return static_cast<int>(want < 1 ? 1 : (want < cap ? want : cap));
}

}  // namespace

void fill_pattern_device(std::uint32_t* p, std::size_t words, std::uint32_t seed, const Stream& s) {
  fill_pattern_kernel<<<grid_for(words), 256, 0, s.get()>>>(p, words, seed);
  DTFLOP_CUDA_LAUNCHED();
}

std::uint64_t count_mismatches_device(const std::uint32_t* p, std::size_t words,
                                      std::uint32_t seed, const Stream& s) {
  DeviceBuffer bad(sizeof(unsigned long long));
  DTFLOP_CUDA(cudaMemsetAsync(bad.get(), 0, sizeof(unsigned long long), s.get()));
  count_mismatches_kernel<<<grid_for(words), 256, 0, s.get()>>>(
      p, words, seed, bad.get<unsigned long long>());
  DTFLOP_CUDA_LAUNCHED();
  unsigned long long host = 0;
  DTFLOP_CUDA(cudaMemcpyAsync(&host, bad.get(), sizeof(host), cudaMemcpyDeviceToHost, s.get()));
  s.sync();
  return host;
}

}  // namespace detail

}  // namespace dtflop::probes::gpu
