// The timeline of a traced repetition (calibrate/timeline.hpp) from hand-made records: the
// device's busy and idle stretches worked out by hand, the runtime calls by name, the Trace Event
// Format document, and kernel names as a reader wants them.
#include <gtest/gtest.h>

#include "calibrate/timeline.hpp"

namespace dtflop::calib {
namespace {

ActivityRecord device_record(ActivityRecord::Kind kind, std::uint64_t start, std::uint64_t end, std::string name = {}) {
  ActivityRecord r;
  r.kind = kind;
  r.start = start;
  r.end = end;
  r.name = std::move(name);
  return r;
}

// Range [1000, 20000] ns. Device: a copy [500, 1500] (clipped to [1000, 1500]), kernels [2000, 4000]
// and [3500, 5000] (overlapping: one busy stretch [2000, 5000]), a copy [8000, 9000], a kernel
// [9000, 12000] (touching the copy: no gap), one [25000, 26000] outside the range. Host: two
// launches and a synchronize.
std::vector<ActivityRecord> records() {
  using K = ActivityRecord::Kind;
  std::vector<ActivityRecord> r;
  ActivityRecord up = device_record(K::copy, 500, 1500);
  up.direction = ActivityRecord::Direction::to_device;
  up.bytes = 4096;
  r.push_back(up);
  r.push_back(device_record(K::kernel, 2000, 4000, "_ZN6dtflop3dct3gpu12_GLOBAL__N_17k_unionEPiii"));
  r.push_back(device_record(K::kernel, 3500, 5000, "plain"));
  ActivityRecord down = device_record(K::copy, 8000, 9000);
  down.direction = ActivityRecord::Direction::to_host;
  down.bytes = 8;
  down.pageable = true;
  r.push_back(down);
  r.push_back(device_record(K::kernel, 9000, 12000, "plain"));
  r.push_back(device_record(K::kernel, 25000, 26000, "plain"));
  r.push_back(device_record(K::api, 1200, 1700, "cudaLaunchKernel_v7000"));
  r.push_back(device_record(K::api, 1800, 2100, "cudaLaunchKernel_v7000"));
  r.push_back(device_record(K::api, 5000, 12500, "cudaStreamSynchronize_v3020"));
  return r;
}

TEST(CalibTimeline, BusyAndIdleStretchesOfTheDevice) {
  const TimelineSummary s = summarize_timeline(records(), 1000, 20000);
  EXPECT_NEAR(s.window_seconds, 19000e-9, 1e-18);
  EXPECT_EQ(s.device_operations, 5);  // the one outside the range is left out
  // Busy: [1000, 1500] + [2000, 5000] + [8000, 12000] = 500 + 3000 + 4000.
  EXPECT_NEAR(s.device_busy_seconds, 7500e-9, 1e-18);
  // Idle between them: [1500, 2000] and [5000, 8000].
  EXPECT_EQ(s.gaps, 2);
  EXPECT_NEAR(s.gap_seconds, 3500e-9, 1e-18);
  EXPECT_NEAR(s.gap_median_seconds, 1750e-9, 1e-18);
  EXPECT_NEAR(s.lead_seconds, 0.0, 1e-18);
  EXPECT_NEAR(s.trail_seconds, 8000e-9, 1e-18);
  // Busy, idle, lead and trail fill the window.
  EXPECT_NEAR(s.device_busy_seconds + s.gap_seconds + s.lead_seconds + s.trail_seconds, s.window_seconds, 1e-15);
  ASSERT_EQ(s.api_by_name.size(), 2u);
  EXPECT_EQ(s.api_by_name[0].first, "cudaLaunchKernel_v7000");
  EXPECT_EQ(s.api_by_name[0].second.first, 2);
  EXPECT_NEAR(s.api_by_name[0].second.second, 800e-9, 1e-18);
  EXPECT_EQ(s.api_by_name[1].second.first, 1);
  EXPECT_NEAR(s.api_by_name[1].second.second, 7500e-9, 1e-18);
}

TEST(CalibTimeline, NothingOnTheDeviceIsNoGap) {
  const std::vector<ActivityRecord> host = {device_record(ActivityRecord::Kind::api, 10, 20, "cudaFree")};
  const TimelineSummary s = summarize_timeline(host, 0, 100);
  EXPECT_EQ(s.device_operations, 0);
  EXPECT_EQ(s.gaps, 0);
  EXPECT_EQ(s.device_busy_seconds, 0.0);
  EXPECT_EQ(s.trail_seconds, 0.0);
}

TEST(CalibTimeline, TraceEventFormat) {
  const nlohmann::json t = timeline_json(records(), 1000, 20000, "what ran");
  ASSERT_TRUE(t.contains("traceEvents"));
  int complete = 0, device = 0, host = 0;
  for (const auto& e : t["traceEvents"]) {
    ASSERT_TRUE(e.contains("ph"));
    if (e["ph"] != "X") continue;
    ++complete;
    EXPECT_GE(e["ts"].get<double>(), 0.0);
    EXPECT_GT(e["dur"].get<double>(), 0.0);
    (e["pid"] == 1 ? device : host) += 1;
    if (e["cat"] == "copy" && e["args"]["bytes"] == 4096) {
      EXPECT_EQ(e["name"], "copy host->device");
      EXPECT_DOUBLE_EQ(e["ts"].get<double>(), 0.0);  // clipped to the range's start
      EXPECT_DOUBLE_EQ(e["dur"].get<double>(), 0.5);  // microseconds
      EXPECT_EQ(e["args"]["host_memory"], "pinned");
    }
    if (e["cat"] == "copy" && e["args"]["bytes"] == 8) EXPECT_EQ(e["args"]["host_memory"], "pageable");
  }
  EXPECT_EQ(complete, 8);
  EXPECT_EQ(device, 5);
  EXPECT_EQ(host, 3);
  EXPECT_EQ(t["dtflop_summary"]["what"], "what ran");
  EXPECT_EQ(t["dtflop_summary"]["device_gaps"], 2);
}

TEST(CalibTimeline, KernelNamesAsAReaderWantsThem) {
  EXPECT_EQ(short_kernel_name("_ZN6dtflop3dct3gpu12_GLOBAL__N_17k_unionEPiii"), "k_union");
  // A template kernel in an anonymous namespace, as nvcc mangles it.
  EXPECT_EQ(short_kernel_name("_ZN6dtflop3dct3gpu48_GLOBAL__N__4be9e0a0_15_cuda_kernels_cu_734e952410k_centroidIhEEvPKT_"
                              "PKiiiNS1_3RoiENS1_9CompStatsENS1_9DotParamsENS1_6DotOutE"),
            "k_centroid");
  EXPECT_EQ(short_kernel_name("void ns::(anonymous namespace)::k_stats<int>(int const*, int)"), "k_stats");
  EXPECT_EQ(short_kernel_name("plain"), "plain");
  EXPECT_EQ(short_kernel_name(""), "");
}

}  // namespace
}  // namespace dtflop::calib
