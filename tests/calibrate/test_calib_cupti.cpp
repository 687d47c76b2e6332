// The CUPTI profiler on a real device: copies of known size and memory kind, and a backend's
// declared counts against the copies and kernels CUPTI sees. Skips without a GPU.
#include <cuda_runtime.h>

#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "calibrate/profiler.hpp"
#include "calibrate/rbe_sweep.hpp"
#include "tests/support/gpu.hpp"

namespace dtflop::calib {
namespace {

#define CUDA_OK(call) ASSERT_EQ((call), cudaSuccess) << #call << ": " << cudaGetErrorString(cudaGetLastError())

// One process may hold one CUPTI profiler: the tests share it.
ActivityProfiler& profiler() {
  static ProfilerOpen p = open_cupti_profiler();
  if (!p.profiler) throw std::runtime_error("CUPTI unavailable: " + p.why_not);
  return *p.profiler;
}

TEST(CalibCupti, CopiesAreAttributedByDirectionSizeAndMemoryKind) {
  DTFLOP_REQUIRE_GPU();
  const std::size_t bytes = 3u << 20;
  std::vector<unsigned char> pageable(bytes, 7);
  unsigned char* pinned = nullptr;
  unsigned char* dev = nullptr;
  CUDA_OK(cudaMallocHost(&pinned, bytes));
  CUDA_OK(cudaMalloc(&dev, bytes));
  std::memset(pinned, 3, bytes);

  ActivityProfiler& p = profiler();
  p.begin();
  CUDA_OK(cudaMemcpy(dev, pageable.data(), bytes, cudaMemcpyHostToDevice));
  CUDA_OK(cudaMemcpy(dev, pinned, bytes / 2, cudaMemcpyHostToDevice));
  CUDA_OK(cudaMemcpy(pinned, dev, bytes / 4, cudaMemcpyDeviceToHost));
  const DeviceActivity a = p.end();
  // Nothing outside a range is recorded.
  CUDA_OK(cudaMemcpy(pageable.data(), dev, bytes, cudaMemcpyDeviceToHost));
  p.begin();
  const DeviceActivity empty = p.end();

  EXPECT_EQ(a.to_device.count, 2);
  EXPECT_EQ(a.to_device.bytes, bytes + bytes / 2);
  EXPECT_EQ(a.to_device.pageable, 1);
  EXPECT_EQ(a.to_device.pinned, 1);
  EXPECT_EQ(a.to_host.count, 1);
  EXPECT_EQ(a.to_host.bytes, bytes / 4);
  EXPECT_EQ(a.to_host.pinned, 1);
  EXPECT_GT(a.to_device.seconds, 0);
  EXPECT_LT(a.to_device.seconds + a.to_host.seconds, a.window_seconds);
  EXPECT_GE(a.copy_calls, 3);  // runtime API records of the three cudaMemcpy calls
  EXPECT_EQ(a.dropped_records, 0u);
  EXPECT_EQ(empty.to_host.count, 0);
  EXPECT_EQ(empty.kernels, 0);
  EXPECT_EQ(pageable[0], 3);  // the copies really happened
  cudaFree(dev);
  cudaFreeHost(pinned);
}

// Every copy and kernel a CUDA backend declares is seen by CUPTI, and nothing else.
void check_backend(const std::string& name, HostMemory memory) {
  RbeSweepSettings st;
  st.backend = name;
  st.options.host_memory = memory;
  st = with_defaults(st, true);
  st.repetitions = 2;
  const Plan plan = rbe_plan("seed-test2", st, true);
  const PlanItem& item = plan.items[3];
  const Sample s = measure_rbe(item, st, plan, MachineIdentity{}, &profiler(), "");
  EXPECT_EQ(s.source, TimingSource::cupti);
  EXPECT_FALSE(s.detail.contains("counts_mismatch")) << name << ": " << s.detail["counts_mismatch"];
  const auto& act = s.detail["activity_last_repetition"];
  EXPECT_EQ(act["to_device"][memory == HostMemory::pinned ? "pinned" : "pageable"], s.counts.transfers_CG) << name;
  // The device->host copies land in the host memory the counts say (cuda-resident's sums are
  // pinned whatever the grids are), with the sizes they list.
  EXPECT_EQ(act["to_host"][std::string(to_string(s.counts.host_memory))], s.counts.transfers_GC) << name;
  std::int64_t listed = 0;
  for (const CopySize& c : s.counts.copies_GC) listed += c.bytes * c.count;
  EXPECT_EQ(act["to_host"]["bytes"].get<std::int64_t>(), listed) << name;
  ASSERT_NE(s.find(Component::G), nullptr);
  EXPECT_GT(s.find(Component::G)->median, 0);
  EXPECT_LE(s.find(Component::G)->median, s.find(Component::total)->median);
}

TEST(CalibCupti, CudaSeedCountsMatchWhatCuptiSees) {
  DTFLOP_REQUIRE_GPU();
  check_backend("cuda-seed", HostMemory::pageable);
  check_backend("cuda-seed", HostMemory::pinned);
}

TEST(CalibCupti, CudaResidentCountsMatchWhatCuptiSees) {
  DTFLOP_REQUIRE_GPU();
  check_backend("cuda-resident", HostMemory::pageable);
}

}  // namespace
}  // namespace dtflop::calib
