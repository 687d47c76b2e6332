// The CUPTI profiler on a real device: copies of known size and memory kind, and a backend's
// declared counts against the copies and kernels CUPTI sees. Skips without a GPU.
#include <cuda_runtime.h>

#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <fmt/format.h>

#include "calibrate/measure.hpp"
#include "calibrate/profiler.hpp"
#include "calibrate/timeline.hpp"
#include "workloads/workload.hpp"
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
  // The range's records go with it, for a timeline: the same three copies, the same device time.
  const TimelineSummary t = summarize_timeline(a.records, a.begin_ns, a.end_ns);
  EXPECT_EQ(t.device_operations, 3);
  EXPECT_NEAR(t.device_busy_seconds, a.busy_seconds, 1e-9);
  EXPECT_NEAR(t.window_seconds, a.window_seconds, 1e-9);
  EXPECT_EQ(t.gaps, 2);  // three copies, one after another, each waited for by the host
  EXPECT_TRUE(empty.records.empty() || summarize_timeline(empty.records, empty.begin_ns, empty.end_ns).device_operations == 0);
  cudaFree(dev);
  cudaFreeHost(pinned);
}

// Every copy and kernel a GPU backend of any workload declares is seen by CUPTI, and nothing
// else: the default configuration, in each host memory the backend offers.
void check_backend(const workload::Workload& w, const workload::Backend& b, const nlohmann::json& given) {
  const std::string name = fmt::format("{} {} {}", w.name(), b.name(), given.dump());
  const workload::Config config = w.validate(given, b);
  Protocol protocol;
  protocol.settings = with_defaults(MeasureSettings{.repetitions = 2}, w, b);
  protocol.profiler = &profiler();
  const Sample s = measure(w, b, config, protocol, MachineIdentity{}, w.key(b, config), "test");
  EXPECT_EQ(s.source, TimingSource::cupti);
  EXPECT_FALSE(s.detail.contains("counts_mismatch")) << name << ": " << s.detail["counts_mismatch"];
  EXPECT_FALSE(s.detail.contains("work_mismatch")) << name << ": " << s.detail["work_mismatch"];
  const auto& act = s.detail["activity_last_repetition"];
  EXPECT_EQ(act["to_device"][std::string(to_string(s.counts.host_memory))], s.counts.transfers_CG) << name;
  // The device->host copies land in the host memory the counts say (cuda-resident's sums are
  // pinned whatever the grids are), with the sizes they list.
  EXPECT_EQ(act["to_host"][std::string(to_string(s.counts.host_memory))], s.counts.transfers_GC) << name;
  if (!s.counts.copies_GC.empty()) {
    std::int64_t listed = 0;
    for (const CopySize& c : s.counts.copies_GC) listed += c.bytes * c.count;
    EXPECT_EQ(act["to_host"]["bytes"].get<std::int64_t>(), listed) << name;
  }
  ASSERT_NE(s.find(Component::G), nullptr) << name;
  EXPECT_GT(s.find(Component::G)->median, 0) << name;
  EXPECT_LE(s.find(Component::G)->median, s.find(Component::total)->median) << name;
}

TEST(CalibCupti, EveryGpuBackendsCountsMatchWhatCuptiSees) {
  DTFLOP_REQUIRE_GPU();
  int checked = 0;
  for (const workload::Workload* w : workload::all())
    for (const auto& b : w->backends()) {
      if (!b->needs_gpu()) continue;
      const workload::ParamSpec* memory = w->find_param("host-memory");
      if (memory && memory->applies_to(b->name())) {
        for (const auto& m : memory->choices) check_backend(*w, *b, {{"host-memory", m}});
      } else {
        check_backend(*w, *b, nlohmann::json::object());
      }
      ++checked;
    }
  EXPECT_GE(checked, 2);  // rbe's cuda-seed and cuda-resident at least
}

// The DCT cuda backend's uploads from pageable memory are timed by the host: the driver stages
// them, and the host's time in the call (the staging, and the DMA of all but the last chunk, which
// may finish after the call returns) is nearer what dt_CG prices for pageable copies and the
// transfer probe times than CUPTI's device-side records, which hold the staged chunks' DMA alone
// (on a lent H200, 41-45 us in the call for a 530 KB region against 12 us on the device). Pinned uploads
// only queue a copy: their CG is CUPTI's.
TEST(CalibCupti, DctCudaPageableUploadsAreTheHostsTime) {
  DTFLOP_REQUIRE_GPU();
  const workload::Workload* dct = &workload::find("dct");
  const workload::Backend* cuda = &dct->backend("cuda");
  for (const std::string memory : {"pinned", "pageable"}) {
    SCOPED_TRACE(memory);
    const workload::Config config =
        dct->validate({{"size", "1200x900"}, {"dots", 300}, {"points", "16x16"}, {"host-memory", memory}}, *cuda);
    Protocol protocol;
    protocol.settings = with_defaults(MeasureSettings{.repetitions = 3}, *dct, *cuda);
    protocol.profiler = &profiler();
    const Sample s = measure(*dct, *cuda, config, protocol, MachineIdentity{}, dct->key(*cuda, config), "test");
    const auto* cg = s.find(Component::CG);
    ASSERT_NE(cg, nullptr);
    const double device = s.detail["device"]["to_device"].get<double>();
    ASSERT_GT(device, 0);
    if (memory == "pageable") {
      EXPECT_NE(s.timing_note.find("CG: host clock around the phase"), std::string::npos) << s.timing_note;
      EXPECT_GE(cg->median, device);  // the staging, slower than the DMA at this size (1 MB)
    } else {
      EXPECT_NE(s.timing_note.find("CG: CUPTI device-side durations"), std::string::npos) << s.timing_note;
      EXPECT_DOUBLE_EQ(cg->median, device);
    }
  }
}

// cuda-resident's chunked split passes (a kernel taller, or wider, than any tile in shared
// memory: the search-and-rescue team's stretched steps) launch the kernels and copy what its
// counts declare.
TEST(CalibCupti, CudaResidentChunkedPassesMatchWhatCuptiSees) {
  DTFLOP_REQUIRE_GPU();
  const workload::Workload* rbe = &workload::find("rbe");
  const workload::Backend* resident = &rbe->backend("cuda-resident");
  // The default layout with a 1499-row kernel (the y-pass in 3 chunks); layout 1024x1x1 with an
  // 801 x 301 kernel (x-pass in 3 chunks, y-pass in 13).
  check_backend(*rbe, *resident, {{"grid", {200, 1500}}, {"kernel", {9, 1499}}});
  check_backend(*rbe, *resident, {{"grid", {1100, 320}}, {"kernel", {801, 301}}, {"layout", "1024x1x1"}});
}

}  // namespace
}  // namespace dtflop::calib
