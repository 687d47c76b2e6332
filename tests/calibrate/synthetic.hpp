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

// The seed's GPU pipeline over Test 1 and Test 2 shapes (pageable), as synthetic samples, and
// grids of 330 to 390 cells a side, whose device->host copies (436 to 608 kB) fall between the
// staged bytes and the flat ones of the round profile: without them S_GC_staged and S_GC_flat
// would only show through one combination.
inline std::vector<calib::Sample> seed_pipeline_samples(const MachineProfile& truth, Variant variant,
                                                        double rel_noise, std::uint64_t seed = 7) {
  std::mt19937_64 rng(seed);
  std::vector<calib::Sample> out;
  for (std::int64_t i = 1; i <= 200; i += 7) {
    rbe::Shape s{1000, 1000, i, i};
    out.push_back(synthetic_sample(fmt::format("t1/{}", i), rbe::seed_gpu_counts(s), truth, variant, rel_noise, rng));
  }
  for (std::int64_t k : {16, 32})
    for (std::int64_t n = 100; n <= 1000; n += 100) {
      rbe::Shape s{n, n, k, k};
      out.push_back(synthetic_sample(fmt::format("t2/{}/{}", k, n), rbe::seed_gpu_counts(s), truth, variant,
                                     rel_noise, rng));
    }
  for (std::int64_t n = 330; n <= 390; n += 20) {
    rbe::Shape s{n, n, 24, 24};
    out.push_back(synthetic_sample(fmt::format("flat/{}", n), rbe::seed_gpu_counts(s), truth, variant, rel_noise, rng));
  }
  return out;
}

}  // namespace dtflop::test
