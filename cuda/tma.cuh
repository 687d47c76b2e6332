// The tensor memory accelerator's tile copies (sm_90) as cuda-resident and the gpu-tiles probe
// use them: one thread arms an mbarrier with the bytes to land and starts bulk tensor copies of
// boxes into shared memory; every thread then waits on the barrier's phase 0; one thread ends the
// barrier's life before its shared memory serves anything else. One copy of the PTX for both, so
// that the probe times what the workload runs.
#pragma once

#include <cuda.h>

namespace dtflop::cuda::tma {

__device__ __forceinline__ unsigned smem_addr(const void* p) {
  return static_cast<unsigned>(__cvta_generic_to_shared(p));
}

// One thread: initializes the barrier for one arrival and expects `bytes` to land on it.
__device__ __forceinline__ void arm(unsigned long long* bar, unsigned bytes) {
  const unsigned b = smem_addr(bar);
  asm volatile("mbarrier.init.shared::cta.b64 [%0], 1;\n" ::"r"(b) : "memory");
  asm volatile("fence.mbarrier_init.release.cluster;\n" ::: "memory");
  asm volatile("fence.proxy.async.shared::cta;\n" ::: "memory");
  asm volatile("mbarrier.arrive.expect_tx.shared::cta.b64 _, [%0], %1;\n" ::"r"(b), "r"(bytes) : "memory");
}

// One thread, after arm(): the box of `map` at (x, y) into shared memory at dst, counted on bar.
__device__ __forceinline__ void copy_box(float* dst, const CUtensorMap* map, int x, int y, unsigned long long* bar) {
  asm volatile(
      "cp.async.bulk.tensor.2d.shared::cluster.global.tile.mbarrier::complete_tx::bytes [%0], [%1, {%2, %3}], "
      "[%4];\n" ::"r"(smem_addr(dst)),
      "l"(reinterpret_cast<unsigned long long>(map)), "r"(x), "r"(y), "r"(smem_addr(bar))
      : "memory");
}

// Every thread, after a __syncthreads() that follows arm(): waits until the bytes have landed.
__device__ __forceinline__ void wait(unsigned long long* bar) {
  const unsigned b = smem_addr(bar);
  unsigned done = 0;
  do {
    asm volatile(
        "{\n .reg .pred p;\n mbarrier.try_wait.parity.shared::cta.b64 p, [%1], 0;\n selp.u32 %0, 1, 0, p;\n}\n"
        : "=r"(done)
        : "r"(b)
        : "memory");
  } while (!done);
}

// One thread, after a __syncthreads() that follows every thread's wait(): ends the barrier.
__device__ __forceinline__ void done(unsigned long long* bar) {
  asm volatile("mbarrier.inval.shared::cta.b64 [%0];\n" ::"r"(smem_addr(bar)) : "memory");
}

}  // namespace dtflop::cuda::tma
