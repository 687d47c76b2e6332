// Samples made from a known machine profile, so a fit's answer is known exactly.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calibrate/sample.hpp"
#include "model/predict.hpp"
#include "tests/model/fixtures.hpp"
#include "workloads/rbe/counts.hpp"

namespace dtflop::test {

// A sample whose components are the model's prediction under `truth` and `variant`, each
// multiplied by (1 + noise) with noise ~ N(0, rel_noise) per repetition (5 repetitions).
inline calib::Sample synthetic_sample(const std::string& key, const CostCounts& counts,
                                      const MachineProfile& truth, Variant variant, double rel_noise,
                                      std::mt19937_64& rng, const std::string& backend = "cuda-seed") {
  calib::Sample s;
  s.key = key;
  s.machine = truth.identity;
  s.workload = "rbe";
  s.backend = backend;
  s.plan = "synthetic";
  s.parameters = nlohmann::json::object();  // the defaults: a valid configuration of the backend
  s.counts = counts;
  s.steps = 1;
  s.source = calib::TimingSource::cupti;
  const Prediction p = predict(truth, counts, variant);
  std::normal_distribution<double> n(0.0, rel_noise);
  for (auto c : calib::all_components()) {
    const double v = calib::predicted(p, c);
    if (!(v > 0)) continue;
    std::vector<double> reps;
    for (int r = 0; r < 5; ++r) reps.push_back(v * (1 + (rel_noise > 0 ? n(rng) : 0.0)));
    s.components[c] = summarize(reps);
  }
  return s;
}

// Under the sanitizers the fit tests fit smaller problems. tests/CMakeLists.txt defines
// DTFLOP_TEST_SMALL_FITS for every test where DTFLOP_SANITIZE is on (build-asan, the sanitized
// stage of scripts/test.sh): a fit evaluates the model thousands of times (central differences of
// every residual, each iteration), which the sanitized Debug build does about 15-20 times slower than
// Release, and with the full sample set the fit tests were more than half of the sanitized run.
// The small set goes through the same code (the same counts and parameters to fit, copies in all
// three staging regimes), and the tests assert the same properties of it with the same tolerances;
// the Release run fits the full set.
#ifdef DTFLOP_TEST_SMALL_FITS
inline constexpr bool kSmallFits = true;
#else
inline constexpr bool kSmallFits = false;
#endif

// The seed's GPU pipeline over Test 1 and Test 2 shapes (pageable), as synthetic samples, and
// grids of 330 to 390 cells a side, whose device->host copies (436 to 608 kB) fall between the
// staged bytes and the flat ones of the round profile: without them S_GC_staged and S_GC_flat
// would only show through one combination. 53 samples: Test 1 (a 1000 x 1000 grid) with kernels of
// 1 to 197 cells a side in steps of 7, Test 2 with 16 x 16 and 32 x 32 kernels on grids of 100 to
// 1000 cells a side. `small` (the default where kSmallFits): 20 samples, Test 1 with kernels in steps
// of 35 (1 to 176) and Test 2 with the 16 x 16 kernel only: the kernel sizes are Test 1's to vary;
// Test 2's grids, every one kept, are what pins the device->host copies' staging (with every other
// grid, a fit from half the truth trades B_GC_staged against the staging sizes). Fewer samples do not
// make every fit cheaper: the seed variant, which cannot express the latencies, takes more
// iterations on fewer samples (up to 113 in a fold here, against 69 on the full set), and among the
// subsets tried this one costs least in the cross-validations (about half the full set's work).
inline std::vector<calib::Sample> seed_pipeline_samples(const MachineProfile& truth, Variant variant,
                                                        double rel_noise, std::uint64_t seed = 7,
                                                        bool small = kSmallFits) {
  std::mt19937_64 rng(seed);
  std::vector<calib::Sample> out;
  for (std::int64_t i = 1; i <= 200; i += small ? 35 : 7) {
    rbe::Shape s{1000, 1000, i, i};
    out.push_back(synthetic_sample(fmt::format("t1/{}", i), rbe::seed_gpu_counts(s), truth, variant, rel_noise, rng));
  }
  for (std::int64_t k : {16, 32}) {
    if (small && k == 32) continue;
    for (std::int64_t n = 100; n <= 1000; n += 100) {
      rbe::Shape s{n, n, k, k};
      out.push_back(synthetic_sample(fmt::format("t2/{}/{}", k, n), rbe::seed_gpu_counts(s), truth, variant,
                                     rel_noise, rng));
    }
  }
  for (std::int64_t n = 330; n <= 390; n += 20) {
    rbe::Shape s{n, n, 24, 24};
    out.push_back(synthetic_sample(fmt::format("flat/{}", n), rbe::seed_gpu_counts(s), truth, variant, rel_noise, rng));
  }
  return out;
}

}  // namespace dtflop::test
