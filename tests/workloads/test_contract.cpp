// The workload contract, checked the same way for every backend of every registered workload: the
// parameter space validates and fills defaults, the store key is stable and tells configurations
// apart, the counts a backend declares without a device are those a prepared run declares, and
// every backend that can run here is measured through the shared protocol with its declared work
// matching what it did. A workload or backend added later is checked by this file unchanged.
#include <ostream>
#include <algorithm>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "calibrate/machine.hpp"
#include "calibrate/measure.hpp"
#include "model/errors.hpp"
#include "workloads/workload.hpp"

namespace dtflop::workload {
namespace {

// The smallest configuration of a workload a backend runs in a moment: every size parameter at
// the low end of what its constraints accept, found from the defaults.
Config small_config(const Workload& w, const Backend& b) {
  if (w.name() == "rbe") return w.validate({{"grid", "64x48"}, {"kernel", "5x3"}}, b);
  if (w.name() == "dct") return w.validate({{"size", "480x360"}, {"dots", 60}, {"points", "8x8"}, {"support", 12}}, b);
  return w.validate(nlohmann::json::object(), b);
}

struct Case {
  const Workload* workload;
  const Backend* backend;
};
// gtest prints a parameter with this (the failure names the workload and backend, not bytes).
void PrintTo(const Case& c, std::ostream* os) { *os << c.workload->name() << "/" << c.backend->name(); }

std::vector<Case> every_backend() {
  std::vector<Case> out;
  for (const Workload* w : all())
    for (const auto& b : w->backends()) out.push_back({w, b.get()});
  return out;
}

class Contract : public ::testing::TestWithParam<Case> {};

TEST_P(Contract, DefaultsValidateAndTheKeyNamesTheConfiguration) {
  const auto [w, b] = GetParam();
  const Config c = w->validate(nlohmann::json::object(), *b);
  for (const auto& p : w->params()) EXPECT_EQ(c.contains(p.name), p.applies_to(b->name())) << p.name;
  // Validating a valid configuration changes nothing; its key names the workload and the backend.
  EXPECT_EQ(w->validate(c, *b), c);
  const std::string key = w->key(*b, c);
  EXPECT_EQ(key.rfind(fmt::format("{}/{}/", w->name(), b->name()), 0), 0u) << key;
  // Two configurations that differ in one parameter have different keys.
  const Config small = small_config(*w, *b);
  if (small != c) {
    EXPECT_NE(w->key(*b, small), key);
  }
}

// Counts for another machine (predict --machine, tune) are that machine's: a backend on "every hardware
// thread" counts the target's threads, not this machine's; one on a fixed number counts that number.
TEST_P(Contract, CountsForAnotherMachineUseItsThreads) {
  const auto [w, b] = GetParam();
  const Config c = small_config(*w, *b);
  MachineIdentity target;
  target.cpu_threads = 96;
  const CostCounts here = b->counts(c, nullptr), there = b->counts(c, &target);
  const bool all_threads = c.contains("threads") && c.at("threads") == 0;
  // A thread count defaults to every hardware thread, resolved on the machine the counts are for.
  if (c.contains("threads")) EXPECT_TRUE(all_threads) << c.dump();
  if (!all_threads) {
    EXPECT_EQ(there.cpu_threads, here.cpu_threads);
    return;
  }
  EXPECT_EQ(there.cpu_threads, 96);
  EXPECT_EQ(here.cpu_threads, static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  Config four = c;
  four["threads"] = 4;
  EXPECT_EQ(b->counts(w->validate(four, *b), &target).cpu_threads, 4);
}

TEST_P(Contract, UnknownOrForeignParametersAreRefusedWithOneLine) {
  const auto [w, b] = GetParam();
  try {
    (void)w->validate({{"no-such-parameter", 1}}, *b);
    FAIL() << "an unknown parameter was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-parameter"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  for (const auto& p : w->params()) {
    if (p.applies_to(b->name())) continue;
    try {
      (void)w->validate({{p.name, p.fallback}}, *b);
      FAIL() << "--" << p.name << " was accepted on " << b->name();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(b->name()), std::string::npos) << e.what();
    }
  }
}

TEST_P(Contract, PlansHoldValidConfigurationsWithDistinctKeys) {
  const auto [w, b] = GetParam();
  for (const auto& [name, what] : w->plan_names()) {
    const std::string spec = name == "random:N" ? "random:20" : name;
    const PlanConfigs p = w->plan(spec, *b, 7);
    ASSERT_FALSE(p.configs.empty()) << spec;
    EXPECT_FALSE(p.description.empty()) << spec;
    std::set<std::string> keys;
    for (const auto& c : p.configs) {
      EXPECT_EQ(w->validate(c, *b), c) << spec;
      keys.insert(w->key(*b, c));
    }
    if (spec.rfind("random:", 0) != 0) {
      EXPECT_EQ(keys.size(), p.configs.size()) << spec << ": a configuration twice";
    }
    // The same seed gives the same plan.
    EXPECT_EQ(w->plan(spec, *b, 7).configs, p.configs) << spec;
  }
}

// Every backend that can run here: measured by the protocol, its counts declared before it ran are
// what a device-free counts() call gives (times the steps), and what it did matches them.
TEST_P(Contract, MeasuredThroughTheProtocolWithTheCountsItDeclares) {
  const auto [w, b] = GetParam();
  if (const std::string why = b->unavailable(); !why.empty()) GTEST_SKIP() << why;
  const Config c = small_config(*w, *b);
  calib::Protocol protocol = calib::open_protocol(*w, *b, calib::MeasureSettings{.steps = 2, .repetitions = 2, .warmup = 1},
                                                  /*no_cupti=*/false);
  const calib::Sample s =
      calib::measure(*w, *b, c, protocol, calib::this_machine(), w->key(*b, c), "contract-test");
  EXPECT_EQ(s.workload, w->name());
  EXPECT_EQ(s.backend, b->name());
  EXPECT_EQ(s.steps, 2);
  EXPECT_EQ(s.repetitions(), 2);
  ASSERT_NE(s.find(calib::Component::total), nullptr);
  EXPECT_GT(s.find(calib::Component::total)->median, 0);
  EXPECT_FALSE(s.detail.contains("work_mismatch")) << s.detail.dump();
  EXPECT_FALSE(s.detail.contains("counts_mismatch")) << s.detail.dump();
  // The device-free counts of a step describe the same computation as the run's declared counts.
  const CostCounts step = b->counts(c, nullptr);
  EXPECT_GT(s.counts.N_C + s.counts.N_G, 0);
  EXPECT_EQ(s.counts.N_C > 0, step.N_C > 0);
  EXPECT_EQ(s.counts.N_G > 0, step.N_G > 0);
  EXPECT_EQ(s.counts.P, step.P);
  EXPECT_EQ(s.counts.precision, step.precision);
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, Contract, ::testing::ValuesIn(every_backend()),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           std::string n = fmt::format("{}_{}", i.param.workload->name(), i.param.backend->name());
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(Registry, BackendsDeclareTheProbeOnlyErrorMeasuredForThem) {
  // docs/PERFORMANCE.md (Prediction portability; DCT probe-only with the MLS fields' rate) holds
  // the held-out sets behind these figures.
  for (const auto& [workload, backends] :
       {std::pair{"rbe", std::vector<std::string>{"cpu-seq", "cpu-par", "cuda-seed", "cuda-resident"}},
        std::pair{"dct", std::vector<std::string>{"cpu-seq", "cpu-par", "cuda"}}}) {
    for (const std::string& b : backends) {
      const auto e = find(workload).backend(b).probe_only_error();
      ASSERT_TRUE(e.has_value()) << workload << " " << b;
      EXPECT_GT(e->sigma, 0.05) << b;  // no backend predicted within 5% from probes alone
      EXPECT_LT(e->sigma, 1.0) << b;
      EXPECT_NE(e->source.find(b), std::string::npos) << b;
    }
  }
  EXPECT_FALSE(find("rbe").backend("cuda-bands").probe_only_error().has_value());  // peer terms: one pair of GPUs measured
}

TEST(Registry, GpuBackendsDeclareTheMeasuredErrorOfTheirCarriedCalibrationsWhereItIsLarge) {
  // docs/PERFORMANCE.md, "H200 lend (2026-11-28)": the largest rms log error of dct cuda's and rbe
  // cuda-seed's calibrations carried between a lent H100 and H200; the others are left to kTransferSigma.
  const auto e = find("dct").backend("cuda").transfer_error();
  ASSERT_TRUE(e.has_value());
  EXPECT_DOUBLE_EQ(e->sigma, 0.34);
  EXPECT_NE(e->source.find("dct cuda"), std::string::npos);
  for (const char* b : {"cpu-seq", "cpu-par"}) EXPECT_FALSE(find("dct").backend(b).transfer_error().has_value()) << b;
  const auto s = find("rbe").backend("cuda-seed").transfer_error();
  ASSERT_TRUE(s.has_value());
  EXPECT_DOUBLE_EQ(s->sigma, 0.24);
  EXPECT_NE(s->source.find("rbe cuda-seed"), std::string::npos);
  for (const char* b : {"cpu-seq", "cpu-par", "cuda-resident", "cuda-bands"})
    EXPECT_FALSE(find("rbe").backend(b).transfer_error().has_value()) << b;
}

TEST(Registry, FindsEveryWorkloadAndNamesTheKnownOnes) {
  ASSERT_GE(all().size(), 2u);
  for (const Workload* w : all()) EXPECT_EQ(&find(w->name()), w);
  try {
    (void)find("nosuch");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rbe"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dtflop::workload
