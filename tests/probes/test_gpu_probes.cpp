// The CUDA probes on a real device (skipped without one). The probes check their own data;
// these tests check that they run, validate, and give figures of the right size.
#include <algorithm>
#include <exception>
#include <stdexcept>
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/device.hpp"
#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/probe.hpp"
#include "probes/tile_fill.hpp"
#include "model/stats.hpp"
#include "tests/support/gpu.hpp"

namespace dtflop::probes {
namespace {

TEST(GpuProbes, DeviceIsDescribed) {
  DTFLOP_REQUIRE_GPU();
  const auto d = gpu::device_info();
  ASSERT_TRUE(d.usable) << d.reason;
  EXPECT_FALSE(d.name.empty());
  EXPECT_GT(d.sm_count, 0);
  EXPECT_GT(d.total_bytes, 0);
  EXPECT_FALSE(d.runtime_version.empty());
  EXPECT_FALSE(d.driver_version.empty());
}

TEST(GpuProbes, TransfersMoveTheDataBothWays) {
  DTFLOP_REQUIRE_GPU();
  const std::vector<std::int64_t> sizes = {4096, 1 << 20, 16 << 20};
  const std::vector<int> reps = {5, 5, 3};
  for (auto dir : {gpu::Direction::host_to_device, gpu::Direction::device_to_host})
    for (auto mem : {HostMemory::pinned, HostMemory::pageable}) {
      // time_transfers checks every word of every size and throws ValidationError otherwise.
      const auto t = gpu::time_transfers(dir, mem, sizes, reps, 1);
      ASSERT_EQ(t.size(), sizes.size());
      std::vector<TransferPoint> pts;
      for (std::size_t i = 0; i < t.size(); ++i) {
        ASSERT_EQ(t[i].seconds.size(), static_cast<std::size_t>(reps[i]));
        for (double s : t[i].seconds) EXPECT_GT(s, 0);
        pts.push_back({static_cast<double>(t[i].bytes), summarize(t[i].seconds).median});
      }
      // 16 MiB takes longer than 4 KiB, and the fitted bandwidth is between 100 MB/s and
      // 1 TB/s (PCIe / NVLink-C2C territory).
      EXPECT_GT(pts.back().seconds, pts.front().seconds);
      const auto f = fit_latency_bandwidth(pts);
      EXPECT_GT(f.bandwidth, 1e8);
      EXPECT_LT(f.bandwidth, 1e12);
    }
}

TEST(GpuProbes, BlockingCopiesTakeLongerThanTheCopyAlone) {
  DTFLOP_REQUIRE_GPU();
  for (auto dir : {gpu::Direction::host_to_device, gpu::Direction::device_to_host}) {
    const auto blocking = gpu::time_blocking_copies(dir, 4096, 20);
    const std::vector<std::int64_t> size = {4096};
    const std::vector<int> reps = {20};
    const auto events = gpu::time_transfers(dir, HostMemory::pinned, size, reps, 2);
    ASSERT_EQ(blocking.size(), 20u);
    // The call, the copy and the wait, against the copy as the device's events see it: the
    // blocking call cannot be much faster (allow 20% for clock granularity).
    EXPECT_GT(summarize(blocking).median, 0.8 * summarize(events[0].seconds).median);
  }
}

TEST(GpuProbes, TransferArgumentsAreChecked) {
  DTFLOP_REQUIRE_GPU();
  const std::vector<std::int64_t> odd = {4097};
  const std::vector<int> one = {1};
  EXPECT_THROW(gpu::time_transfers(gpu::Direction::host_to_device, HostMemory::pinned, odd,
                                   one, 0),
               std::invalid_argument);
}

TEST(GpuProbes, DeviceCopiesAreCheckedAndFast) {
  DTFLOP_REQUIRE_GPU();
  const std::int64_t bytes = 64 << 20;
  const auto a = gpu::time_d2d_memcpy(bytes, 5, 1);
  const auto b = gpu::time_copy_kernel(bytes, 5, 1);
  ASSERT_EQ(a.size(), 5u);
  ASSERT_EQ(b.size(), 5u);
  // Read + write of 64 MiB: faster than 10 GB/s on any CUDA GPU.
  EXPECT_GT(2.0 * bytes / summarize(a).median, 1e10);
  EXPECT_GT(2.0 * bytes / summarize(b).median, 1e10);
}

TEST(GpuProbes, AnL2ResidentCopyIsCheckedAndFasterThanDeviceMemory) {
  DTFLOP_REQUIRE_GPU();
  const std::int64_t l2 = gpu::device_info().l2_bytes;
  ASSERT_GT(l2, 1 << 20);
  const std::int64_t small = l2 / 8 / 16 * 16, big = 256 << 20;
  const auto t = gpu::time_l2_copy(small, 16, 5, 1);
  ASSERT_EQ(t.size(), 5u);
  const double in_l2 = 2.0 * small * 16 / summarize(t).median;
  const double device = 2.0 * big / summarize(gpu::time_copy_kernel(big, 5, 1)).median;
  // The L2 serves a working set it holds faster than device memory serves one it cannot.
  EXPECT_GT(in_l2, device) << in_l2 << " B/s in L2, " << device << " B/s from device memory";
  EXPECT_THROW(gpu::time_l2_copy(small + 4, 16, 5, 1), std::invalid_argument);
  EXPECT_THROW(gpu::time_l2_copy(small, 0, 5, 1), std::invalid_argument);
}

TEST(GpuProbes, KernelsOfAGraphCostMicrosecondsOrLess) {
  DTFLOP_REQUIRE_GPU();
  const auto t = gpu::time_graph_launches(200, 3);
  ASSERT_EQ(t.size(), 3u);
  const double g = summarize(t).median;
  EXPECT_GT(g, 1e-8);
  EXPECT_LT(g, 1e-4);
  EXPECT_THROW(gpu::time_graph_launches(0, 3), std::invalid_argument);
}

TEST(GpuProbes, FmaKernelsValidateAndCountFlops) {
  DTFLOP_REQUIRE_GPU();
  for (bool fp64 : {false, true}) {
    const auto t = gpu::time_fma(fp64, 0.002, 3);
    ASSERT_EQ(t.seconds.size(), 3u);
    EXPECT_GT(t.blocks, 0);
    EXPECT_DOUBLE_EQ(t.flops, 2.0 * t.blocks * t.threads_per_block * t.chains *
                                  static_cast<double>(t.steps));
    EXPECT_GT(t.flops / summarize(t.seconds).median, 1e10);
  }
}

TEST(GpuProbes, AcrossRowFmasAreCheckedAndCostMoreThanThePeakRate) {
  DTFLOP_REQUIRE_GPU();
  const auto t = gpu::time_rows(512, 17, 3, 1);  // every cell checked inside (ValidationError)
  ASSERT_EQ(t.seconds.size(), 3u);
  EXPECT_DOUBLE_EQ(t.flops, 2.0 * 512 * 512 * 17);
  const double rows = t.flops / summarize(t.seconds).median;
  const auto f = gpu::time_fma(false, 0.002, 3);
  EXPECT_LT(rows, f.flops / summarize(f.seconds).median);  // K_GR > 1: each tap waits on a load
  EXPECT_THROW(gpu::time_rows(32, 17, 3, 1), std::invalid_argument);
}

TEST(GpuProbes, AlongRowFmasAreCheckedAndCostMoreThanThePeakRateButLessThanAcrossRows) {
  DTFLOP_REQUIRE_GPU();
  // The column pass: every cell checked inside (ValidationError), against its own in-grid taps.
  const auto along = gpu::time_rows(1024, 33, 5, 1, gpu::TapDirection::along_row);
  ASSERT_EQ(along.seconds.size(), 5u);
  EXPECT_DOUBLE_EQ(along.flops, 2.0 * 1024 * 1024 * 33);
  const auto across = gpu::time_rows(1024, 33, 5, 1, gpu::TapDirection::across_rows);
  const auto f = gpu::time_fma(false, 0.002, 3);
  const double rate = along.flops / summarize(along.seconds).median;
  EXPECT_LT(rate, f.flops / summarize(f.seconds).median);  // K_GW > 1: a load beside every FMA
  EXPECT_GT(rate, across.flops / summarize(across.seconds).median);  // the warp's line re-read: K_GW < K_GR
}

TEST(GpuProbes, LaunchOverheadIsMicroseconds) {
  DTFLOP_REQUIRE_GPU();
  const auto t = gpu::time_launches(200, 3);
  ASSERT_EQ(t.per_launch.size(), 3u);
  ASSERT_EQ(t.round_trip.size(), 30u);
  const double l = summarize(t.per_launch).median;
  EXPECT_GT(l, 1e-8);
  EXPECT_LT(l, 1e-3);
  // A launch that waits for its kernel takes at least as long as one in a stream of launches.
  EXPECT_GT(summarize(t.round_trip).median, 0.5 * l);
}

TEST(GpuProbes, RoundsOfBlocksCostMoreWithEveryRound) {
  DTFLOP_REQUIRE_GPU();
  const auto w = gpu::time_waves(20, 3);
  EXPECT_EQ(w.blocks_per_sm, 1);  // each block fills a multiprocessor
  ASSERT_EQ(w.waves, (std::vector<int>{4, 8, 16, 32}));
  ASSERT_EQ(w.seconds.size(), 4u);
  // Every doubling of the rounds takes longer, and a round costs between 0.1 and 100 us.
  for (std::size_t i = 1; i < w.seconds.size(); ++i) EXPECT_GT(w.seconds[i], w.seconds[i - 1]) << w.waves[i];
  EXPECT_GT(w.per_wave, 1e-7);
  EXPECT_LT(w.per_wave, 1e-4);
}

// Tile fills from an L2-resident grid: every block's sum is checked inside (ValidationError); the
// fills grow with the tile, and the bytes really filled per second lie within a factor of ten of
// what this device's copy kernel moves through device memory in the same run (the L2 cache is
// faster than device memory, by a few times, on every CUDA GPU).
TEST(GpuProbes, TileFillsAreCheckedAndRunNearTheDeviceMemoryRate) {
  DTFLOP_REQUIRE_GPU();
  const std::int64_t bytes = 256 << 20;
  const double copy = 2.0 * bytes / summarize(gpu::time_copy_kernel(bytes, 5, 1)).median;  // read + write
  std::vector<bool> ways = {false};
  if (gpu::tma_available()) ways.push_back(true);
  for (bool tma : ways) {
    const auto t = gpu::time_tile_fills(tma, 4, 3, 3);
    EXPECT_EQ(t.tma, tma);
    EXPECT_EQ(t.occ, tiles::kBlocksPerSm) << "shared memory sized for cuda-resident's blocks per multiprocessor";
    EXPECT_EQ(t.blocks, 4 * t.occ * t.sms);
    ASSERT_GE(t.points.size(), 3u);
    std::vector<TransferPoint> pts;
    for (std::size_t i = 0; i < t.points.size(); ++i) {
      const auto& p = t.points[i];
      ASSERT_EQ(p.seconds.size(), 3u);
      EXPECT_EQ(p.filled_bytes, std::int64_t{t.blocks} * p.rows * tiles::kCols * 4);
      EXPECT_EQ(p.counted_bytes, std::int64_t{4} * t.sms * p.rows * tiles::kCols * 4);  // 4 rounds, one tile each
      pts.push_back({static_cast<double>(p.counted_bytes), summarize(p.seconds).median});
    }
    EXPECT_GT(pts.back().seconds, pts.front().seconds) << "a 224-row tile takes longer to fill than a 48-row one";
    const double filled = static_cast<double>(t.points.back().filled_bytes) / pts.back().seconds;
    EXPECT_GT(filled, 0.1 * copy) << tma;
    EXPECT_LT(filled, 10 * copy) << tma;
    const auto f = fit_latency_bandwidth(pts);
    EXPECT_GT(f.bandwidth, 0.01 * copy) << tma;
    EXPECT_LT(f.bandwidth, 10 * copy) << tma;
  }
  EXPECT_THROW(gpu::time_tile_fills(false, 0, 1, 1), std::invalid_argument);
}

// Atomic adds of every block to one address: the sum is checked after every batch and every
// stored word (ValidationError inside). One of them costs more than nothing and less than a kernel
// launch measured in the same run, and at least a quarter of a clock cycle of this device.
TEST(GpuProbes, AtomicsToOneAddressCostLessThanALaunch) {
  DTFLOP_REQUIRE_GPU();
  const std::vector<int> per_sm = {4, 8, 16, 32};
  const auto t = gpu::time_atomics(per_sm, 5, 3);
  const auto d = gpu::device_info();
  ASSERT_EQ(t.blocks.size(), per_sm.size());
  ASSERT_EQ(t.atomic.size(), per_sm.size());
  ASSERT_EQ(t.stored.size(), per_sm.size());
  std::vector<TransferPoint> pts;
  for (std::size_t i = 0; i < per_sm.size(); ++i) {
    EXPECT_EQ(t.blocks[i], per_sm[i] * d.sm_count);
    ASSERT_EQ(t.atomic[i].size(), 3u);
    ASSERT_EQ(t.stored[i].size(), 3u);
    pts.push_back({static_cast<double>(t.blocks[i]), summarize(t.atomic[i]).median});
  }
  EXPECT_GT(pts.back().seconds, pts.front().seconds) << "8 times the blocks, 8 times the atomics";
  const PerEventFit f = fit_per_event(pts);
  const double launch = summarize(gpu::time_launches(200, 3).per_launch).median;
  EXPECT_LT(f.per_event, launch);
  if (d.sm_clock_ghz) {
    EXPECT_GT(f.per_event, 0.25e-9 / *d.sm_clock_ghz);
  }
  const std::vector<int> two = {4, 8};
  EXPECT_THROW(gpu::time_atomics(two, 1, 1), std::invalid_argument);
}

// gpu-mls checks every point against the quadratic field itself; its rate is one thread's: far
// below the device's FMA rate, and at most a few FLOPs a cycle of one thread (< 10^10 FLOP/s); a
// table's kernel takes longer the larger its supports.
TEST(GpuProbes, MlsGivesOneThreadsChainRate) {
  DTFLOP_REQUIRE_GPU();
  ProbeOptions o;
  o.effort = Effort::smoke;
  const auto& all = all_probes();
  const auto it = std::find_if(all.begin(), all.end(), [](const Probe& p) { return p.name == "gpu-mls"; });
  ASSERT_NE(it, all.end());
  const ProbeReport r = it->run(o);
  ASSERT_EQ(r.measurements.size(), 1u);
  const Measurement& m = r.measurements[0];
  ASSERT_EQ(m.param, Param::V_GM);
  EXPECT_GT(m.value, 1e7);
  EXPECT_LT(m.value, 1e10);
  EXPECT_EQ(m.stats.n, 3u);  // the smoke plan's repetitions
  const gpu::MlsTiming timing = [] {
    // 64 points of a 16 x 16 grid of dots, supports of their 8 and 40 nearest (by index distance:
    // the grid's), to see that the time follows the support.
    gpu::MlsDots d;
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        d.reference_xy.insert(d.reference_xy.end(), {10.0 * i + 0.3 * j, 10.0 * j - 0.2 * i});
        d.disp_xy.insert(d.disp_xy.end(), {0.01f * static_cast<float>(i), -0.02f * static_cast<float>(j)});
      }
    std::vector<gpu::MlsTable> tables;
    for (int support : {8, 40}) {
      gpu::MlsTable t;
      t.offsets.push_back(0);
      for (int p = 0; p < 64; ++p) {
        const int ci = 4 + p % 8, cj = 4 + p / 8;
        t.points_xy.insert(t.points_xy.end(), {10.0 * ci + 1, 10.0 * cj + 1});
        std::vector<std::pair<double, int>> near;
        for (int k = 0; k < 256; ++k) {
          const double dx = d.reference_xy[2 * k] - t.points_xy[2 * p], dy = d.reference_xy[2 * k + 1] - t.points_xy[2 * p + 1];
          near.push_back({dx * dx + dy * dy, k});
        }
        std::sort(near.begin(), near.end());
        for (int k = 0; k < support; ++k) t.dots.push_back(near[k].second);
        t.offsets.push_back(static_cast<int>(t.dots.size()));
        t.rho.push_back(static_cast<float>(std::sqrt(near[support].first)));
      }
      tables.push_back(std::move(t));
    }
    return gpu::time_mls(d, tables, 32, 5, 1);
  }();
  ASSERT_EQ(timing.seconds.size(), 2u);
  // The fastest repetitions (another test may share the GPU): 5x the support, at least twice the time.
  const double small = *std::min_element(timing.seconds[0].begin(), timing.seconds[0].end());
  const double large = *std::min_element(timing.seconds[1].begin(), timing.seconds[1].end());
  EXPECT_GT(large, 2 * small) << "40-dot supports should take several times as long as 8-dot ones";
  for (const auto& f : timing.fields[1]) {
    EXPECT_EQ(f.status, kernels::PointStatus::ok);
    EXPECT_EQ(f.support, 40);
  }
}

// gpu-centroid checks every dot's centroid against float64 itself; L_GP is a window pixel's share
// of the blocks' time, side by side: above a clock cycle spread over the whole device (128 SMs a
// few GHz, 1e-13 s) and below one thread's pixel (1e-8 s). A frame of larger dots takes longer.
TEST(GpuProbes, CentroidGivesAWindowPixelsShareOfTheBlocks) {
  DTFLOP_REQUIRE_GPU();
  ProbeOptions o;
  o.effort = Effort::smoke;
  const auto& all = all_probes();
  const auto it = std::find_if(all.begin(), all.end(), [](const Probe& p) { return p.name == "gpu-centroid"; });
  ASSERT_NE(it, all.end());
  const ProbeReport r = it->run(o);
  ASSERT_EQ(r.measurements.size(), 4u);  // the smoke plan's three frames and the fit
  const Measurement& m = r.measurements.back();
  ASSERT_EQ(m.param, Param::L_GP);
  EXPECT_GT(m.value, 1e-13);
  EXPECT_LT(m.value, 1e-8);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(r.measurements[i].stats.n, 3u);  // the smoke plan's repetitions
  // Radius 5 px and 150 dots against radius 20 px and the same dots: 7x the window pixels.
  EXPECT_GT(r.measurements[2].stats.median, 1.5 * r.measurements[0].stats.median);
  // A window outside its image is refused before the device is touched.
  gpu::CentroidFrame f;
  f.width = f.height = 8;
  f.image.assign(64, 0);
  f.labels.assign(64, -1);
  f.windows = {4, 4, 5, 5};
  f.component = {0};
  EXPECT_THROW(gpu::time_centroids({f}, 2, 128, 1, 0), std::invalid_argument);
}

// gpu-frame-pass checks every pass's output against the host's itself; L_GF is a pixel's share of a
// pass over a whole frame: above a clock cycle spread over the whole device (1e-13 s) and below one
// thread's memory round trip (1e-9 s). A frame eight times larger takes longer, every pass.
TEST(GpuProbes, FramePassGivesAPixelsShareOfAPassOverTheFrame) {
  DTFLOP_REQUIRE_GPU();
  ProbeOptions o;
  o.effort = Effort::smoke;
  const auto& all = all_probes();
  const auto it = std::find_if(all.begin(), all.end(), [](const Probe& p) { return p.name == "gpu-frame-pass"; });
  ASSERT_NE(it, all.end());
  const ProbeReport r = it->run(o);
  ASSERT_EQ(r.measurements.size(), 10u);  // three passes over the smoke plan's three frames, and the mean
  const Measurement& m = r.measurements.back();
  ASSERT_EQ(m.param, Param::L_GF);
  EXPECT_GT(m.value, 1e-13);
  EXPECT_LT(m.value, 1e-9);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(r.measurements[3 * k].stats.n, 3u);  // the smoke plan's repetitions
    // 0.25 MP against 2 MP: eight times the pixels.
    EXPECT_GT(r.measurements[3 * k + 2].stats.median, r.measurements[3 * k].stats.median) << r.measurements[3 * k].key;
  }
  // The passes compute what the host does, to the pixel, on a frame whose rows wrap oddly.
  const std::vector<int> rows = {3, 37};
  EXPECT_EQ(gpu::time_frame_passes(1001, rows, 64, 1, 0).mismatches, 0);
  // Sizes and blocks no pass can take are refused before the device is touched.
  EXPECT_THROW(gpu::time_frame_passes(2048, std::vector<int>{}, 256, 1, 0), std::invalid_argument);
  EXPECT_THROW(gpu::time_frame_passes(2048, std::vector<int>{1 << 20}, 256, 1, 0), std::invalid_argument);
  EXPECT_THROW(gpu::time_frame_passes(2048, std::vector<int>{16}, 100, 1, 0), std::invalid_argument);
}

TEST(GpuProbes, EveryGpuProbeRunsAtSmokeEffort) {
  DTFLOP_REQUIRE_GPU();
  ProbeOptions o;
  o.effort = Effort::smoke;
  for (const auto& p : all_probes()) {
    if (!p.needs_gpu) continue;
    ProbeReport r;
    try {
      r = p.run(o);
    } catch (const std::exception& e) {
      ADD_FAILURE() << p.name << " threw: " << e.what();
      continue;
    }
    // gpu-peer needs two GPUs (and NCCL): where this process sees fewer, or the build has no
    // NCCL, it skips, saying why, and measures nothing; with two it runs like the others.
    if (p.name == "gpu-peer" && r.skipped) {
      const int devices = cuda::device_count();
      const bool no_nccl = r.skipped->find("without NCCL") != std::string::npos;
      EXPECT_TRUE(devices < 2 || no_nccl) << "gpu-peer skipped with " << devices << " GPUs: " << *r.skipped;
      if (!no_nccl) {
        EXPECT_NE(r.skipped->find(std::to_string(devices)), std::string::npos) << *r.skipped;
      }
      EXPECT_TRUE(r.measurements.empty()) << p.name;
      continue;
    }
    EXPECT_FALSE(r.skipped.has_value()) << p.name;
    EXPECT_FALSE(r.measurements.empty()) << p.name;
    for (const auto& m : r.measurements)
      EXPECT_TRUE(std::isfinite(m.value) && m.value > 0) << p.name << " " << m.key;
  }
}

}  // namespace
}  // namespace dtflop::probes
