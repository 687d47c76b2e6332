// Held-out validation statistics, worked out by hand; and the CUPTI record aggregation.
#include <gtest/gtest.h>

#include "calibrate/profiler.hpp"
#include "calibrate/validate.hpp"
#include "model/errors.hpp"
#include "tests/calibrate/synthetic.hpp"
#include "tests/support/gpu.hpp"

namespace dtflop::calib {
namespace {

TEST(CalibValidate, ErrorsPerComponentAndGroup) {
  const MachineProfile truth = test::round_profile();
  std::mt19937_64 rng(1);
  CostCounts c;  // pure CPU work: dt_C = N_C / V_C1_fp32 = 1e9 / 100e9 = 10 ms
  c.N_C = 1'000'000'000;
  Sample a = test::synthetic_sample("a", c, truth, Variant::seed, 0.0, rng, "cpu-seq");
  Sample b = a;
  b.key = "b";
  b.backend = "cpu-par";
  // Measured 8 ms and 12.5 ms: relative errors +25% and -20%.
  a.components[Component::total] = summarize(std::vector<double>{8e-3});
  b.components[Component::total] = summarize(std::vector<double>{12.5e-3});
  b.components.erase(Component::C);
  b.steps = 2;  // per-step absolute errors halve
  b.counts = c.scaled(2);
  const std::vector<Sample> samples = {a, b};
  const Validation v = validate(samples, truth, Variant::seed);
  ASSERT_EQ(v.rows.size(), 2u);
  EXPECT_NEAR(v.rows[0].rel(Component::total), 0.25, 1e-12);
  EXPECT_NEAR(v.rows[1].rel(Component::total), (20e-3 - 12.5e-3) / 12.5e-3, 1e-12);

  const ErrorStats& all = v.groups.at("all").at(Component::total);
  EXPECT_EQ(all.n, 2);
  const double e_b = (20e-3 - 12.5e-3) / 12.5e-3;  // +60%
  EXPECT_NEAR(all.mean_rel, (0.25 + e_b) / 2, 1e-12);
  EXPECT_NEAR(all.max_rel, e_b, 1e-12);
  EXPECT_NEAR(all.bias, (0.25 + e_b) / 2, 1e-12);
  EXPECT_EQ(all.worst, "b");
  // Per step: a is off by 2 ms, b by (20 - 12.5) / 2 = 3.75 ms.
  EXPECT_NEAR(all.mean_abs, (2e-3 + 3.75e-3) / 2, 1e-15);
  EXPECT_NEAR(all.max_abs, 3.75e-3, 1e-15);
  // Groups by backend and backend / plan; C only where measured.
  EXPECT_EQ(v.groups.at("cpu-seq").at(Component::total).n, 1);
  EXPECT_EQ(v.groups.at("cpu-par / synthetic").at(Component::total).n, 1);
  EXPECT_EQ(v.groups.at("all").at(Component::C).n, 1);
  EXPECT_NEAR(v.groups.at("all").at(Component::C).mean_rel, 0.0, 1e-12);
}

TEST(CalibValidate, MissingParameterNamesTheSample) {
  MachineProfile m = test::round_profile();
  std::mt19937_64 rng(1);
  const Sample s = test::synthetic_sample("needs-gpu", rbe::seed_gpu_counts({100, 100, 3, 3}), m, Variant::seed, 0, rng);
  m.erase(Param::V_G_fp32);
  try {
    validate({s}, m, Variant::seed);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needs-gpu"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("V_G_fp32"), std::string::npos) << e.what();
  }
}

ActivityRecord copy(ActivityRecord::Direction d, std::uint64_t s, std::uint64_t e, std::uint64_t bytes, bool pageable) {
  ActivityRecord r;
  r.kind = ActivityRecord::Kind::copy;
  r.direction = d;
  r.start = s;
  r.end = e;
  r.bytes = bytes;
  r.pageable = pageable;
  return r;
}

TEST(CalibProfiler, AggregatesTheRecordsInsideTheRange) {
  using D = ActivityRecord::Direction;
  std::vector<ActivityRecord> recs;
  recs.push_back(copy(D::to_device, 1000, 2000, 400, true));
  recs.push_back(copy(D::to_device, 2500, 3000, 100, false));
  recs.push_back(copy(D::to_host, 6000, 7000, 800, true));
  recs.push_back(copy(D::to_host, 50, 90, 8, true));  // before the range: ignored
  ActivityRecord k;
  k.kind = ActivityRecord::Kind::kernel;
  k.name = "pass";
  k.start = 2800;  // overlaps the second copy by 200 ns
  k.end = 5000;
  recs.push_back(k);
  k.start = 9500;  // straddles the end: clipped to 500 ns
  k.end = 10500;
  recs.push_back(k);
  ActivityRecord api;
  api.kind = ActivityRecord::Kind::api;
  api.name = "cudaLaunchKernel_v7000";
  api.start = 2600;
  api.end = 2700;
  recs.push_back(api);
  api.name = "cudaMemcpy_v3020";
  api.start = 900;
  api.end = 2100;
  recs.push_back(api);

  const DeviceActivity a = aggregate(recs, 100, 10000);
  EXPECT_EQ(a.to_device.count, 2);
  EXPECT_EQ(a.to_device.bytes, 500u);
  EXPECT_NEAR(a.to_device.seconds, 1500e-9, 1e-18);
  EXPECT_EQ(a.to_device.pageable, 1);
  EXPECT_EQ(a.to_device.pinned, 1);
  EXPECT_EQ(a.to_host.count, 1);
  EXPECT_EQ(a.to_host.bytes, 800u);
  EXPECT_EQ(a.kernels, 2);
  EXPECT_NEAR(a.kernel_seconds, (2200 + 500) * 1e-9, 1e-18);
  EXPECT_EQ(a.kernel_by_name.at("pass").first, 2);
  EXPECT_EQ(a.launch_calls, 1);
  EXPECT_NEAR(a.launch_api_seconds, 100e-9, 1e-18);
  EXPECT_EQ(a.copy_calls, 1);
  EXPECT_NEAR(a.copy_api_seconds, 1200e-9, 1e-18);
  EXPECT_NEAR(a.window_seconds, 9900e-9, 1e-18);
  // Busy: [1000,2000] + [2500,5000] + [6000,7000] + [9500,10000] = 1000 + 2500 + 1000 + 500.
  EXPECT_NEAR(a.busy_seconds, 5000e-9, 1e-18);
  const auto j = a.to_json();
  EXPECT_EQ(j["to_device"]["bytes"], 500);
  EXPECT_EQ(j["kernel_by_name"]["pass"]["count"], 2);
}

TEST(CalibProfiler, WithoutADeviceThereIsNoProfilerAndAReason) {
  if (test::gpu_unavailable_reason().empty()) GTEST_SKIP() << "a GPU is present; test_calibrate_gpu covers CUPTI";
  const ProfilerOpen p = open_cupti_profiler();
  EXPECT_EQ(p.profiler, nullptr);
  EXPECT_FALSE(p.why_not.empty());
  EXPECT_TRUE(p.why_not.find("CUDA") != std::string::npos || p.why_not.find("device") != std::string::npos)
      << p.why_not;
}

}  // namespace
}  // namespace dtflop::calib
