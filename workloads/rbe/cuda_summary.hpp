// The summary of a belief that lives on the device (Backend::summarize for cuda-resident): the
// estimate's sums and the footprint sums by two reduction kernels, and only those numbers back.
// Exact counts: cuda_resident_summary_counts() (summary_counts.hpp). Internal to workloads/rbe.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <span>

#include "workloads/rbe/cuda_memory.hpp"
#include "workloads/rbe/estimate.hpp"

namespace dtflop::rbe::detail {

class DeviceSummary {
 public:
  // The belief is q / (A_c *denominator): q holds grid.nx() x grid.ny() float32 values, rows `ld`
  // apart, and `denominator` is a device value (the pending normalization). Enqueues the kernels
  // on `stream`, waits for the one copy back and returns the summary. Throws InputError for a bad
  // footprint or point, NumericalError-free: a belief with no mass is an InputError too.
  Summary summarize(const float* q, const double* denominator, const Grid& grid, std::int64_t ld, const Footprint& f,
                    std::span<const Point> at, cudaStream_t stream);

 private:
  DeviceArray<double> out_;
  DeviceArray<unsigned char> points_;
  HostArray<double> host_;
};

}  // namespace dtflop::rbe::detail
