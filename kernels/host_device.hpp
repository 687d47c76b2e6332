// DTFLOP_HD marks the arithmetic kernels/ shares between the host and the device: inlined for
// both where nvcc compiles it, plain inline elsewhere.
#pragma once

#ifdef __CUDACC__
#define DTFLOP_HD __host__ __device__ __forceinline__
#else
#define DTFLOP_HD inline
#endif
