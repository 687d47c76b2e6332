// The term table (model/terms.hpp) against the formulas it replaced, and everything derived
// from it: predict() and required_params() equal a copy of the code before the table over a
// grid of random counts, every variant and several profiles; the docs' table is the code's; the
// fallback to a simpler variant and the fitted profile's chosen variant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/predict.hpp"
#include "model/terms.hpp"
#include "tests/model/fixtures.hpp"

namespace dtflop {
namespace {

// The formulas of predict() and required_params() as they were before the term table
// (model/predict.cpp at ffcf0a6), copied unchanged but for names: the reference the table must
// reproduce.
namespace reference {

bool pinned(const CostCounts& c) { return c.host_memory == HostMemory::pinned; }
Param b_cg(const CostCounts& c) { return pinned(c) ? Param::B_CG_pinned : Param::B_CG_pageable; }
Param b_gc(const CostCounts& c) { return pinned(c) ? Param::B_GC_pinned : Param::B_GC_pageable; }
Param l_cg(const CostCounts& c) { return pinned(c) ? Param::L_CG_pinned : Param::L_CG_pageable; }
Param l_gc(const CostCounts& c) { return pinned(c) ? Param::L_GC_pinned : Param::L_GC_pageable; }
bool fp64(Precision p) { return p == Precision::fp64; }
Param v_c1(Precision p) { return fp64(p) ? Param::V_C1_fp64 : Param::V_C1_fp32; }
Param v_c(Precision p) { return fp64(p) ? Param::V_C_fp64 : Param::V_C_fp32; }
Param v_g(Precision p) { return fp64(p) ? Param::V_G_fp64 : Param::V_G_fp32; }

double scaled_rate(const MachineProfile& m, Param one, Param all, int threads) {
  if (threads <= 1) return m.get(one).value;
  const int hw = std::max(1, m.identity.cpu_threads);
  if (threads >= hw || !m.has(one)) return m.get(all).value;
  return std::min(threads * m.get(one).value, m.get(all).value);
}

std::vector<Param> cpu_params(Param one, Param all, int threads) {
  if (threads <= 1) return {one};
  return {one, all};
}

double cpu_rate_before(const MachineProfile& m, Precision precision, int threads) {
  return scaled_rate(m, v_c1(precision), v_c(precision), threads);
}

double host_bandwidth_before(const MachineProfile& m, int threads) {
  return scaled_rate(m, Param::B_host_1, Param::B_host, threads);
}

// The cache a working set is priced against: the one the probe measured where it did, else the
// size the system reports (docs/model.md 2.4).
std::int64_t llc_before(const MachineProfile& m) {
  return m.identity.cpu_llc_effective_bytes > 0 ? m.identity.cpu_llc_effective_bytes : m.identity.cpu_llc_bytes;
}

double llc_share_missed_before(const MachineProfile& m, const CostCounts& c) {
  if (c.cpu_footprint <= 0 || llc_before(m) <= 0) return 1.0;
  return std::min(1.0, static_cast<double>(c.cpu_footprint) / static_cast<double>(llc_before(m)));
}

double host_seconds_per_byte_before(const MachineProfile& m, const CostCounts& c) {
  const double w = llc_share_missed_before(m, c);
  double s = w / host_bandwidth_before(m, c.cpu_threads);
  if (w < 1.0) s += (1.0 - w) / scaled_rate(m, Param::B_llc_1, Param::B_llc, c.cpu_threads);
  return s;
}

bool has_staging_before(const MachineProfile& m) {
  return m.has(Param::B_GC_staged) && m.has(Param::S_GC_staged) && m.has(Param::S_GC_flat);
}

double staged_copy_seconds_before(const MachineProfile& m, std::int64_t bytes) {
  const double b = static_cast<double>(bytes);
  const double staged = m.get(Param::S_GC_staged).value, flat = m.get(Param::S_GC_flat).value;
  return std::min(b, staged) / m.get(Param::B_GC_staged).value +
         std::max(b - staged - flat, 0.0) / m.get(Param::B_GC_pageable).value;
}

bool models_host_memory(Variant v) { return v == Variant::memory || v == Variant::extended; }
double priced_flops(std::int64_t all, std::int64_t part, double k) {
  return static_cast<double>(all) + (k - 1) * static_cast<double>(part);
}
bool uses_staging(const CostCounts& c, Variant variant, bool staged) {
  return staged && variant != Variant::seed && c.host_memory == HostMemory::pageable && !c.copies_GC.empty();
}

std::vector<Param> required_params_before(const CostCounts& c, Variant variant, std::int64_t profile_llc, bool staged) {
  std::vector<Param> out;
  auto add = [&out](Param p) {
    if (std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
  };
  const bool lat = variant != Variant::seed;
  if (c.N_CG > 0) add(b_cg(c));
  if (c.N_GC > 0) add(b_gc(c));
  if (uses_staging(c, variant, staged))
    for (auto p : {Param::B_GC_staged, Param::S_GC_staged, Param::S_GC_flat}) add(p);
  if (c.N_GG > 0) add(Param::B_GG);
  if (c.N_C > 0)
    for (auto p : cpu_params(v_c1(c.precision), v_c(c.precision), c.cpu_threads)) add(p);
  if (c.N_G > 0) add(v_g(c.precision));
  if (lat && c.transfers_CG > 0) add(l_cg(c));
  if (lat && c.transfers_GC > 0) add(l_gc(c));
  if (lat && c.launches > 0) add(Param::L_launch);
  if (lat && c.waves > 0) add(Param::L_wave);
  if (lat && c.atomics > 0) add(Param::L_atomic);
  if (lat && c.host_waits > 0) add(Param::L_wait);
  if (lat && c.cpu_syncs > 0) add(Param::L_sync);
  if (lat && c.N_GS > 0) add(Param::B_GS);
  if (lat && c.N_GR > 0 && c.N_G > 0) add(Param::K_GR);
  if (models_host_memory(variant) && c.N_CW > 0 && c.N_C > 0) add(Param::K_CW);
  if (models_host_memory(variant) && c.N_CC > 0) {
    for (auto p : cpu_params(Param::B_host_1, Param::B_host, c.cpu_threads)) add(p);
    if (c.cpu_footprint > 0 && c.cpu_footprint < profile_llc)
      for (auto p : cpu_params(Param::B_llc_1, Param::B_llc, c.cpu_threads)) add(p);
  }
  return out;
}

// The validation of the counts and the MissingParameter message are checked elsewhere; here a
// missing parameter throws MissingParameter and inconsistent counts InputError, as before.
Prediction predict_before(const MachineProfile& m, const CostCounts& c, Variant variant) {
  if (c.P <= 0) throw InputError("P");
  if (!c.copies_GC.empty()) {
    std::int64_t bytes = 0, copies = 0;
    for (const CopySize& s : c.copies_GC) bytes += s.bytes * s.count, copies += s.count;
    if (bytes != c.P * c.N_GC || copies != c.transfers_GC) throw InputError("copies_GC");
  }
  if (c.N_GR < 0 || c.N_GR > c.N_G) throw InputError("N_GR");
  if (c.N_CW < 0 || c.N_CW > c.N_C) throw InputError("N_CW");
  const bool staged = uses_staging(c, variant, has_staging_before(m));
  for (auto p : required_params_before(c, variant, llc_before(m), staged))
    if (!m.has(p)) throw MissingParameter(std::string(info(p).name));

  const double P = c.P;
  Prediction r;
  r.variant = variant;
  if (c.N_CG > 0) r.dt_CG = P * static_cast<double>(c.N_CG) / m.get(b_cg(c)).value;
  if (c.N_GC > 0) r.dt_GC = P * static_cast<double>(c.N_GC) / m.get(b_gc(c)).value;
  if (c.N_GG > 0) r.dt_GG = P * static_cast<double>(c.N_GG) / m.get(Param::B_GG).value;
  if (c.N_C > 0)
    r.dt_C = priced_flops(c.N_C, c.N_CW, models_host_memory(variant) && c.N_CW > 0 ? m.get(Param::K_CW).value : 1.0) /
             cpu_rate_before(m, c.precision, c.cpu_threads);
  if (c.N_G > 0)
    r.dt_G = priced_flops(c.N_G, c.N_GR, variant != Variant::seed && c.N_GR > 0 ? m.get(Param::K_GR).value : 1.0) /
             m.get(v_g(c.precision)).value;

  if (variant == Variant::seed) {
    r.total = r.dt_CG + r.dt_GC + r.dt_GG + r.dt_C + r.dt_G;
    return r;
  }
  if (staged) {
    r.dt_GC = 0;
    for (const CopySize& s : c.copies_GC) r.dt_GC += static_cast<double>(s.count) * staged_copy_seconds_before(m, s.bytes);
  }
  if (c.transfers_CG > 0) r.lat_CG = static_cast<double>(c.transfers_CG) * m.get(l_cg(c)).value;
  if (c.transfers_GC > 0) r.lat_GC = static_cast<double>(c.transfers_GC) * m.get(l_gc(c)).value;
  if (c.launches > 0) r.lat_launch = static_cast<double>(c.launches) * m.get(Param::L_launch).value;
  if (c.cpu_syncs > 0) r.lat_sync = static_cast<double>(c.cpu_syncs) * m.get(Param::L_sync).value;
  if (c.waves > 0) r.lat_wave = static_cast<double>(c.waves) * m.get(Param::L_wave).value;
  if (c.atomics > 0) r.lat_atomic = static_cast<double>(c.atomics) * m.get(Param::L_atomic).value;
  if (c.host_waits > 0) r.lat_wait = static_cast<double>(c.host_waits) * m.get(Param::L_wait).value;
  if (c.N_GS > 0) r.dt_GS = P * static_cast<double>(c.N_GS) / m.get(Param::B_GS).value;
  const double device_overheads = r.lat_launch + r.lat_wave + r.lat_atomic + r.dt_GS;
  const double latencies = r.lat_CG + r.lat_GC + r.lat_wait + device_overheads;
  const double host_traffic =
      models_host_memory(variant) && c.N_CC > 0 ? P * static_cast<double>(c.N_CC) * host_seconds_per_byte_before(m, c) : 0;
  if (variant == Variant::latency || variant == Variant::memory) {
    r.dt_C += host_traffic + r.lat_sync;
    r.total = r.dt_CG + r.dt_GC + r.dt_GG + r.dt_C + r.dt_G + latencies;
    return r;
  }
  r.dt_C = std::max(r.dt_C, host_traffic) + r.lat_sync;
  r.total = r.dt_CG + r.dt_GC + std::max(r.dt_GG, r.dt_G) + r.dt_C + latencies;
  return r;
}

// calib::predicted() as it was (calibrate/sample.cpp at ffcf0a6), by the phase it measures.
double predicted(const Prediction& p, Phase c) {
  switch (c) {
    case Phase::CG: return p.dt_CG + p.lat_CG;
    case Phase::GC: return p.dt_GC + p.lat_GC;
    case Phase::G:
      return (p.variant == Variant::extended ? std::max(p.dt_GG, p.dt_G) : p.dt_GG + p.dt_G) +
             (p.lat_launch + p.lat_wave + p.lat_atomic + p.dt_GS);
    case Phase::C: return p.dt_C;
    case Phase::wait: return p.lat_wait;
    case Phase::net: return p.lat_net + p.dt_net;
  }
  return 0;
}

// calibrate/fit.cpp's exercised() as it was, by the phase it measures.
bool exercised(const CostCounts& k, Phase c) {
  switch (c) {
    case Phase::CG: return k.N_CG > 0 || k.transfers_CG > 0;
    case Phase::GC: return k.N_GC > 0 || k.transfers_GC > 0;
    case Phase::G: return k.N_GG > 0 || k.N_G > 0 || k.launches > 0 || k.waves > 0 || k.N_GS > 0 || k.atomics > 0;
    case Phase::C: return k.N_C > 0 || k.N_CC > 0 || k.cpu_syncs > 0;
    case Phase::wait: return k.host_waits > 0;
    case Phase::net: return k.net_messages > 0 || k.net_bytes > 0;
  }
  return false;
}

}  // namespace reference

// ---- Random counts ----------------------------------------------------------------------------

// Counts with every field drawn at random, a third of them zero; sized device->host copies
// (between 40 kB and 2 MB, across the staging figures of the round profile) in half of the
// cases, and inconsistent counts (a part larger than its whole, copies that do not add up) in
// one case of twenty.
CostCounts random_counts(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  auto count = [&](std::int64_t hi) {
    if (u(rng) < 1.0 / 3) return std::int64_t{0};
    return std::uniform_int_distribution<std::int64_t>(1, hi)(rng);
  };
  CostCounts c;
  c.P = std::array{2, 4, 8}[std::uniform_int_distribution<int>(0, 2)(rng)];
  c.precision = u(rng) < 0.5 ? Precision::fp32 : Precision::fp64;
  c.host_memory = u(rng) < 0.5 ? HostMemory::pinned : HostMemory::pageable;
  c.cpu_threads = std::array{1, 1, 2, 4, 7, 8, 16}[std::uniform_int_distribution<int>(0, 6)(rng)];
  c.N_CG = count(50'000'000);
  c.N_GC = count(50'000'000);
  c.N_GG = count(1'000'000'000);
  c.N_C = count(1'000'000'000);
  c.N_G = count(100'000'000'000);
  c.N_GR = c.N_G > 0 && u(rng) < 0.5 ? std::uniform_int_distribution<std::int64_t>(0, c.N_G)(rng) : 0;
  c.N_CW = c.N_C > 0 && u(rng) < 0.5 ? std::uniform_int_distribution<std::int64_t>(0, c.N_C)(rng) : 0;
  c.N_CC = count(1'000'000'000);
  c.N_GS = count(100'000'000);
  c.transfers_CG = count(100);
  c.transfers_GC = count(100);
  c.launches = count(1000);
  c.waves = count(5000);
  c.atomics = count(100'000);
  c.host_waits = count(10);
  c.cpu_syncs = count(1000);
  c.cpu_footprint = u(rng) < 0.5 ? 0 : std::uniform_int_distribution<std::int64_t>(1, 64 << 20)(rng);
  if (u(rng) < 0.5) {  // sized copies: two sizes, in values of P bytes
    const std::int64_t b1 = c.P * std::uniform_int_distribution<std::int64_t>(10'000, 500'000)(rng) / 2;
    const std::int64_t b2 = c.P * std::uniform_int_distribution<std::int64_t>(10'000, 500'000)(rng) / 2;
    const std::int64_t n1 = std::uniform_int_distribution<std::int64_t>(1, 5)(rng), n2 = count(5);
    add_copies(c.copies_GC, b1 - b1 % c.P, n1);
    add_copies(c.copies_GC, b2 - b2 % c.P, n2);
    c.N_GC = 0;
    c.transfers_GC = 0;
    for (const CopySize& s : c.copies_GC) c.N_GC += s.bytes * s.count / c.P, c.transfers_GC += s.count;
  }
  if (u(rng) < 0.05) {
    switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
      case 0: c.N_CW = c.N_C + 1; break;
      case 1: c.N_GR = -1; break;
      default: c.transfers_GC += 1, c.copies_GC.push_back({64, 2}); break;
    }
  }
  return c;
}

MachineProfile h200() { return load_profile(std::filesystem::path(DTFLOP_SOURCE_DIR) / "docs/examples/h200.json"); }

// The profiles of the grid: the round one (no cache size: every byte from memory); with a 32 MiB
// cache and its bandwidths; without the staging figures; with a cache size but no B_llc (some
// predictions lack it); and a probed one (docs/examples/h200.json: no fitted parameters).
std::vector<std::pair<std::string, MachineProfile>> grid_profiles() {
  std::vector<std::pair<std::string, MachineProfile>> out;
  out.emplace_back("round", test::round_profile());
  auto llc = test::round_profile();
  llc.identity.cpu_llc_bytes = 32 << 20;
  llc.set(Param::B_llc_1, {80e9, Provenance::probed, {}, {}, ""});
  llc.set(Param::B_llc, {320e9, Provenance::probed, {}, {}, ""});
  out.emplace_back("round + LLC", llc);
  auto unstaged = test::round_profile();
  unstaged.erase(Param::S_GC_flat);
  out.emplace_back("round, no staging", unstaged);
  auto no_llc_rate = test::round_profile();
  no_llc_rate.identity.cpu_llc_bytes = 16 << 20;
  out.emplace_back("round + LLC size, no B_llc", no_llc_rate);
  // The H200's probe profile, less the all-thread window ratios, which the formulas above predate
  // (they price every thread's window FLOPs by the one-thread K_CW and K_CA).
  auto probed = h200();
  probed.erase(Param::K_CW_all);
  probed.erase(Param::K_CA_all);
  out.emplace_back("h200 probed", probed);
  return out;
}

// |a - b| <= 1e-12 max(|a|, |b|): zeros must be exact.
::testing::AssertionResult same(const char* what, double a, double b) {
  if (std::abs(a - b) <= 1e-12 * std::max(std::abs(a), std::abs(b))) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << fmt::format("{}: {} (terms) vs {} (reference)", what, a, b);
}

std::set<Param> as_set(const std::vector<Param>& v) { return {v.begin(), v.end()}; }

constexpr int kGrid = 3000;  // random counts per profile

TEST(Terms, PredictEqualsTheFormulasItReplaced) {
  int predicted = 0, missing = 0, inconsistent = 0;
  for (const auto& [name, m] : grid_profiles()) {
    std::mt19937_64 rng(20261121);
    for (int i = 0; i < kGrid; ++i) {
      const CostCounts c = random_counts(rng);
      for (Variant v : all_variants()) {
        // Made only for a failing assertion's message (gtest evaluates it only then): made for
        // every case, it took 22 of this test's 25 s under the sanitizers.
        const auto where = [&, &profile = name] {  // (clang 14 captures no structured binding)
          return fmt::format("{}, counts #{}, {}: {}", profile, i, to_string(v), to_json(c).dump());
        };
        Prediction want, got;
        int want_throws = 0, got_throws = 0;  // 0: none, 1: MissingParameter, 2: other InputError
        try {
          want = reference::predict_before(m, c, v);
        } catch (const MissingParameter&) {
          want_throws = 1;
        } catch (const InputError&) {
          want_throws = 2;
        }
        try {
          got = predict(m, c, v);
        } catch (const MissingParameter&) {
          got_throws = 1;
        } catch (const InputError&) {
          got_throws = 2;
        }
        ASSERT_EQ(got_throws, want_throws) << where();
        if (want_throws == 1) ++missing;
        if (want_throws == 2) ++inconsistent;
        if (want_throws) continue;
        ++predicted;
        ASSERT_EQ(got.variant, v);
        for (auto [field, label] : std::initializer_list<std::pair<double Prediction::*, const char*>>{
                 {&Prediction::dt_CG, "dt_CG"},
                 {&Prediction::dt_GC, "dt_GC"},
                 {&Prediction::dt_GG, "dt_GG"},
                 {&Prediction::dt_C, "dt_C"},
                 {&Prediction::dt_G, "dt_G"},
                 {&Prediction::lat_CG, "lat_CG"},
                 {&Prediction::lat_GC, "lat_GC"},
                 {&Prediction::lat_launch, "lat_launch"},
                 {&Prediction::lat_sync, "lat_sync"},
                 {&Prediction::lat_wave, "lat_wave"},
                 {&Prediction::lat_atomic, "lat_atomic"},
                 {&Prediction::lat_wait, "lat_wait"},
                 {&Prediction::dt_GS, "dt_GS"},
                 {&Prediction::total, "total"}})
          ASSERT_TRUE(same(label, got.*field, want.*field)) << where();
        ASSERT_TRUE(same("dt_trans()", got.dt_trans(), want.dt_trans())) << where();
        ASSERT_TRUE(same("device_overheads()", got.device_overheads(),
                         want.lat_launch + want.lat_wave + want.lat_atomic + want.dt_GS))
            << where();
        // The measured components (calib::predicted()) are the phases.
        for (Phase ph : all_phases())
          ASSERT_TRUE(same(std::string(to_string(ph)).c_str(), phase_seconds(got, ph), reference::predicted(want, ph)))
              << where();
      }
    }
  }
  // The grid reaches every outcome, and mostly predicts.
  EXPECT_GT(predicted, kGrid * 10);
  EXPECT_GT(missing, 100);
  EXPECT_GT(inconsistent, 100);
}

TEST(Terms, RequiredParametersAndExercisedPhasesAreTheOnesTheyReplaced) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < kGrid; ++i) {
    const CostCounts c = random_counts(rng);
    // Counts predict() refuses may differ: sized copies with no N_GC needed the staging figures.
    try {
      check_consistent(c);
    } catch (const InputError&) {
      continue;
    }
    for (Variant v : all_variants())
      for (std::int64_t llc : {std::int64_t{0}, std::int64_t{32} << 20})
        for (bool staged : {false, true})
          ASSERT_EQ(as_set(required_params(c, v, Pricing{.llc_bytes = llc, .staging = staged})),
                    as_set(reference::required_params_before(c, v, llc, staged)))
              << to_string(v) << " llc " << llc << " staged " << staged << ": " << to_json(c).dump();
    for (Phase ph : all_phases()) ASSERT_EQ(counts_phase(c, ph), reference::exercised(c, ph)) << to_string(ph);
  }
}

// Each term's `params` text names every parameter its needs() returns, so the docs' table says
// what the code does. Each (term, parameter) pair the grid reaches is checked once: a std::regex
// built for every pair of every counts took 47 s under the sanitizers (now 0.5 s).
TEST(Terms, ParametersColumnNamesEveryParameterATermNeeds) {
  std::set<std::pair<std::size_t, Param>> needed;  // (index in terms(), parameter)
  std::mt19937_64 rng(11);
  for (int i = 0; i < 500; ++i) {
    const CostCounts c = random_counts(rng);
    for (std::size_t k = 0; k < terms().size(); ++k) {
      const Term& t = terms()[k];
      for (Variant v : all_variants())
        for (bool staging : {false, true}) {
          if (!t.applies(v) || !t.price.counted(c)) continue;
          for (Param p : t.price.needs(c, v, Pricing{32 << 20, staging})) needed.emplace(k, p);
        }
    }
  }
  EXPECT_FALSE(needed.empty());
  for (const auto& [k, p] : needed) {
    const Term& t = terms()[k];
    const std::regex word("(^|[^A-Za-z0-9_])" + std::string(info(p).name) + "([^A-Za-z0-9_]|$)");
    EXPECT_TRUE(std::regex_search(std::string(t.params), word)) << t.name << " needs " << info(p).name;
  }
}

TEST(Terms, NamesAndFieldsAreUniqueAndThePredictionJsonHasEveryTerm) {
  std::set<std::string_view> names;
  for (const Term& t : terms()) {
    EXPECT_TRUE(names.insert(t.name).second) << t.name;
    for (const Term& u : terms()) {
      if (&u == &t) continue;
      EXPECT_NE(u.field, t.field) << t.name << " and " << u.name;
    }
  }
  CostCounts c;
  c.N_G = 1000;
  c.N_C = 10;
  c.N_CC = 10;
  c.launches = 2;
  const Prediction p = predict(test::round_profile(), c, Variant::extended);
  const auto j = to_json(p);
  for (const Term& t : terms()) EXPECT_EQ(j.at(std::string(t.name)).get<double>(), p.*t.field) << t.name;
  EXPECT_EQ(j.at("dt_C").get<double>(), p.dt_C);
  EXPECT_EQ(j.at("total").get<double>(), p.total);
  EXPECT_EQ(j.at("variant").get<std::string>(), "extended");
  // The CPU phase's two overlapping terms and its sum.
  EXPECT_DOUBLE_EQ(p.dt_C_arith, 10 / 100e9);
  EXPECT_DOUBLE_EQ(p.dt_CC, 40 / 20e9);
  EXPECT_DOUBLE_EQ(p.dt_C, std::max(p.dt_C_arith, p.dt_CC));
}

// docs/model.md, section 5, holds the code's two tables as they are.
TEST(Terms, TheDocsTablesAreTheCodes) {
  std::ifstream in(std::filesystem::path(DTFLOP_SOURCE_DIR) / "docs/model.md");
  ASSERT_TRUE(in) << "cannot read docs/model.md";
  std::stringstream doc;
  doc << in.rdbuf();
  EXPECT_NE(doc.str().find(terms_markdown()), std::string::npos)
      << "docs/model.md's table of terms is not the code's; paste this in its place:\n"
      << terms_markdown();
  EXPECT_NE(doc.str().find(counts_markdown()), std::string::npos)
      << "docs/model.md's table of counts is not the code's; paste this in its place:\n"
      << counts_markdown();
}

TEST(Terms, EveryCountFieldIsReadWrittenAddedAndScaled) {
  CostCounts c;
  std::int64_t v = 3;
  for (const CountField& f : count_fields()) c.*f.member = v++;
  for (const CountField& f : count_fields())  // parts within their wholes
    if (f.part_of) c.*f.member = c.*f.part_of - 1;
  const CostCounts back = counts_from_json(nlohmann::json::parse(to_json(c).dump()));
  EXPECT_EQ(back, c);
  const CostCounts three = c.scaled(3);
  CostCounts sum = c;
  sum += c;
  sum += c;
  EXPECT_EQ(sum, three);
  for (const CountField& f : count_fields()) {
    EXPECT_EQ(three.*f.member, f.accumulate == CountField::Accumulate::sum ? 3 * (c.*f.member) : c.*f.member) << f.name;
    EXPECT_EQ(count_field(f.member).name, f.name);
  }
  // A part larger than its whole is refused, by the JSON reader and by predict().
  for (const CountField& f : count_fields()) {
    if (!f.part_of) continue;
    auto bad = c;
    bad.*f.member = c.*f.part_of + 1;
    EXPECT_THROW(counts_from_json(to_json(bad)), InputError) << f.name;
    EXPECT_THROW(predict(test::round_profile(), bad, Variant::seed), InputError) << f.name;
  }
}

// The variants form a tree, seed < latency < {memory, extended}: each needs at least what the
// one it extends needs, and memory and extended need the same.
TEST(Terms, EachVariantNeedsWhatTheOneItExtendsNeeds) {
  EXPECT_EQ(simpler_variant(Variant::seed), std::nullopt);
  EXPECT_EQ(simpler_variant(Variant::latency), Variant::seed);
  EXPECT_EQ(simpler_variant(Variant::memory), Variant::latency);
  EXPECT_EQ(simpler_variant(Variant::extended), Variant::latency);
  std::mt19937_64 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const CostCounts c = random_counts(rng);
    for (Variant v : all_variants()) {
      const auto simpler = simpler_variant(v);
      if (!simpler) continue;
      const auto mine = as_set(required_params(c, v, Pricing{.llc_bytes = 32 << 20, .staging = true}));
      for (Param p : required_params(c, *simpler, Pricing{.llc_bytes = 32 << 20, .staging = true}))
        EXPECT_TRUE(mine.count(p)) << to_string(v) << " lacks " << info(p).name << " of " << to_string(*simpler);
    }
    EXPECT_EQ(as_set(required_params(c, Variant::memory, Pricing{.llc_bytes = 32 << 20, .staging = true})),
              as_set(required_params(c, Variant::extended, Pricing{.llc_bytes = 32 << 20, .staging = true})));
  }
}

// ---- The fallback to a simpler variant --------------------------------------------------------

TEST(RichestSupportedVariant, AProbedProfileFallsBackToTheVariantItHasTheParametersOf) {
  // A probed profile without the parameters of the newer probes (cpu-window's K_CW and K_CA,
  // gpu-tiles' B_GS, gpu-atomics' L_atomic) and without the staging figures, which no probe gives.
  MachineProfile probed = h200();
  for (Param p : {Param::K_CW, Param::K_CW_all, Param::K_CA, Param::K_CA_all, Param::B_GS, Param::L_atomic})
    probed.erase(p);
  std::vector<Param> missing;
  // The CPU's sliding-window FLOPs need K_CW in memory and extended: both fall back to latency.
  CostCounts cpu;
  cpu.N_C = 1'000'000;
  cpu.N_CW = 400'000;
  cpu.N_CC = 1'000'000;
  cpu.cpu_syncs = 2;
  cpu.cpu_threads = 16;
  for (Variant wanted : {Variant::memory, Variant::extended}) {
    EXPECT_EQ(richest_supported_variant(probed, cpu, wanted, &missing), Variant::latency) << to_string(wanted);
    EXPECT_EQ(missing, std::vector<Param>{Param::K_CW}) << to_string(wanted);
    const std::string note = fallback_note(wanted, Variant::latency, missing);
    EXPECT_NE(note.find("K_CW ("), std::string::npos) << note;
    EXPECT_NE(note.find("predicting with the latency variant instead"), std::string::npos) << note;
    // The cpu-window probe measures K_CW: the note sends the user to it, not to a calibration.
    EXPECT_NE(note.find("measure K_CW with `dtflop probe`"), std::string::npos) << note;
    EXPECT_EQ(note.find("dtflop calibrate"), std::string::npos) << note;
    EXPECT_EQ(note.find('\n'), std::string::npos) << note;
    EXPECT_NO_THROW(predict(probed, cpu, Variant::latency));
  }
  // Without sliding-window FLOPs the memory variant is within reach.
  auto plain = cpu;
  plain.N_CW = 0;
  EXPECT_EQ(richest_supported_variant(probed, plain, Variant::extended, &missing), Variant::extended);
  EXPECT_TRUE(missing.empty());
  EXPECT_EQ(fallback_note(Variant::extended, Variant::extended, missing), "");
  // Tile fills and atomics need B_GS and L_atomic, in every variant but the seed.
  CostCounts gpu;
  gpu.N_CG = 1'000'000;
  gpu.transfers_CG = 1;
  gpu.N_G = 1'000'000'000;
  gpu.N_GG = 2'000'000;
  gpu.launches = 3;
  gpu.N_GS = 1'000'000;
  gpu.atomics = 64;
  gpu.host_memory = HostMemory::pinned;
  EXPECT_EQ(richest_supported_variant(probed, gpu, Variant::extended, &missing), Variant::seed);
  EXPECT_EQ(as_set(missing), (std::set<Param>{Param::B_GS, Param::L_atomic}));
  // The gpu-tiles and gpu-atomics probes measure them (erased from this profile): the note sends
  // the user to the probe, not to a calibration.
  const std::string probe_note = fallback_note(Variant::extended, Variant::seed, missing);
  EXPECT_NE(probe_note.find("with `dtflop probe`"), std::string::npos) << probe_note;
  EXPECT_EQ(probe_note.find("dtflop calibrate"), std::string::npos) << probe_note;
  EXPECT_NO_THROW(predict(probed, gpu, Variant::seed));
  // A parameter no probe measures (the staging figures) sends the user to a calibration.
  const std::vector<Param> staged = {Param::B_GC_staged};
  const std::string fitted_note = fallback_note(Variant::extended, Variant::latency, staged);
  EXPECT_NE(fitted_note.find("dtflop calibrate"), std::string::npos) << fitted_note;
  EXPECT_EQ(fitted_note.find("dtflop probe"), std::string::npos) << fitted_note;
  // Sized pageable copies: the staging figures apply only where the profile has them, so a
  // probed profile keeps the latency variant's plain line rather than falling back.
  CostCounts copies;
  copies.N_GC = 250'000;
  copies.transfers_GC = 1;
  copies.copies_GC = {{1'000'000, 1}};
  EXPECT_EQ(richest_supported_variant(probed, copies, Variant::latency, &missing), Variant::latency);
  EXPECT_TRUE(missing.empty());
  // A variant at or below the wanted one: never a richer one.
  EXPECT_EQ(richest_supported_variant(probed, cpu, Variant::seed, &missing), Variant::seed);
  EXPECT_EQ(richest_supported_variant(probed, cpu, Variant::latency, nullptr), Variant::latency);
}

TEST(RichestSupportedVariant, ANoteSendsProbedParametersToTheProbe) {
  auto m = test::round_profile();
  m.erase(Param::L_launch);
  CostCounts c;
  c.N_G = 1000;
  c.launches = 1;
  std::vector<Param> missing;
  EXPECT_EQ(richest_supported_variant(m, c, Variant::extended, &missing), Variant::seed);
  EXPECT_EQ(missing, std::vector<Param>{Param::L_launch});
  const std::string note = fallback_note(Variant::extended, Variant::seed, missing);
  EXPECT_NE(note.find("L_launch"), std::string::npos) << note;
  EXPECT_NE(note.find("dtflop probe"), std::string::npos) << note;
  EXPECT_EQ(note.find("dtflop calibrate"), std::string::npos) << note;
}

TEST(RichestSupportedVariant, WithoutTheSeedsParametersItThrowsWhatPredictThrows) {
  MachineProfile cpu_only = h200();
  for (Param p : {Param::V_G_fp32, Param::V_G_fp64, Param::B_GG}) cpu_only.erase(p);
  CostCounts c;
  c.N_G = 1000;
  c.N_GG = 10;
  std::string from_predict;
  try {
    predict(cpu_only, c, Variant::seed);
  } catch (const MissingParameter& e) {
    from_predict = e.what();
  }
  ASSERT_FALSE(from_predict.empty());
  try {
    richest_supported_variant(cpu_only, c, Variant::extended);
    FAIL() << "expected MissingParameter";
  } catch (const MissingParameter& e) {
    EXPECT_EQ(std::string(e.what()), from_predict);
    EXPECT_NE(std::string(e.what()).find("V_G_fp32"), std::string::npos) << e.what();
  }
}

// Over the grid, the fallback's answer always predicts, and is the wanted variant whenever that
// one predicts.
TEST(RichestSupportedVariant, ItsAnswerAlwaysPredicts) {
  std::mt19937_64 rng(5);
  for (const auto& [name, m] : grid_profiles())
    for (int i = 0; i < 500; ++i) {
      CostCounts c = random_counts(rng);
      try {
        check_consistent(c);
      } catch (const InputError&) {
        continue;
      }
      for (Variant wanted : all_variants()) {
        bool wanted_predicts = true;
        try {
          predict(m, c, wanted);
        } catch (const MissingParameter&) {
          wanted_predicts = false;
        }
        bool seed_predicts = true;
        try {
          predict(m, c, Variant::seed);
        } catch (const MissingParameter&) {
          seed_predicts = false;
        }
        std::vector<Param> missing;
        if (!seed_predicts) {
          EXPECT_THROW(richest_supported_variant(m, c, wanted, &missing), MissingParameter);
          continue;
        }
        const Variant got = richest_supported_variant(m, c, wanted, &missing);
        EXPECT_NO_THROW(predict(m, c, got)) << name;
        EXPECT_EQ(got == wanted, wanted_predicts) << name;
        EXPECT_EQ(missing.empty(), wanted_predicts) << name;
        for (Param p : missing) EXPECT_FALSE(m.has(p)) << info(p).name;
      }
    }
}

// ---- The variant a fitted profile chose -------------------------------------------------------

TEST(ChosenVariant, IsReadFromTheProfilesMetadataAndValidated) {
  auto m = test::round_profile();
  EXPECT_EQ(chosen_variant(m), std::nullopt);  // probed: no choice
  EXPECT_EQ(chosen_variant(h200()), std::nullopt);
  for (Variant v : all_variants()) {
    m.metadata[kChosenVariantKey] = std::string(to_string(v));
    EXPECT_EQ(chosen_variant(profile_from_json(to_json(m))), v);  // through the file format
  }
  m.metadata["model_variant"] = "roofline";
  try {
    chosen_variant(m);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("metadata.model_variant"), std::string::npos) << w;
    EXPECT_NE(w.find("roofline"), std::string::npos) << w;
    EXPECT_NE(w.find("seed, latency, memory or extended"), std::string::npos) << w;
    EXPECT_NE(w.find("dtflop calibrate"), std::string::npos) << w;
    EXPECT_EQ(w.find('\n'), std::string::npos) << w;
  }
}

}  // namespace
}  // namespace dtflop
